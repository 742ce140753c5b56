"""Bodies of real shape (docs/columns.md, docs/columns_runners.md): the geometry the runners need of a
block given by its outline (FMU String parameter ``blockK.outline``, a convex polygon "x,y; x,y; ..." in m
in the block's frame: y = 0 its base, x = 0 its axis), or of a rectangle of half sizes, which is the
same thing with four vertices.

A block of parameters `p` (the FMU's defaults merged with the scene's) is a :class:`Body`: its vertices,
base corners ``xL < xR`` (the lowest and highest x on y = 0), top (its highest y, and the x range of the
vertices there), centre of mass ``(xG, yG)`` (``blockK.centreX/centreY`` with ``blockK.inertia`` > 0,
else the uniform polygon's centroid), mass and inertia about the centre (Bourke 1988; Steger 1996 for
the area moments). From these, per side (docs/conventions.md: theta > 0 rocks on the right corner):

    bR = xR - xG, alpha_R = atan(bR / yG), uplift onto R when a_h < -g bR / yG
    bL = xG - xL, alpha_L = atan(bL / yG), uplift onto L when a_h >  g bL / yG

and the landing angles (pi less the hull's interior angle at each base corner: the body lies on the
edge next to that corner). A rectangle's alpha is atan(b / h) on both sides, computed as the rest of the
runners always did.

Pure Python (no NumPy, no SciPy): a run's summary loads nothing heavy (tests/test_startup.py). The
independent reference model/polygon_reference.py is what tests/test_shapes_runners.py checks this
against. Units SI, angles in radians.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

MAX_VERTICES = 64  # the FMU's largest outline (docs/columns.md)


@dataclass(frozen=True)
class Body:
    """One block's geometry and mass distribution in its own frame (m, kg, kg m^2)."""

    vertices: tuple[tuple[float, float], ...]  # as given (a rectangle: bottom-left, bottom-right, top-right, top-left)
    xL: float
    xR: float
    xG: float
    yG: float
    mass: float
    inertia: float  # about the centre of mass
    top: float  # the highest y
    top_left: float  # x range of the top (the vertices at y = top)
    top_right: float
    beta_left: float  # landing angles, rad (> 0): the hull edge next to each base corner on the ground
    beta_right: float
    outline: bool  # given by blockK.outline (False: the rectangle of its half sizes)
    uniform: bool  # centroid and inertia of a uniform polygon

    @property
    def bL(self) -> float:
        return self.xG - self.xL

    @property
    def bR(self) -> float:
        return self.xR - self.xG

    @property
    def alpha_left(self) -> float:
        return math.atan2(self.bL, self.yG)

    @property
    def alpha_right(self) -> float:
        return math.atan2(self.bR, self.yG)

    @property
    def width(self) -> float:
        xs = [x for x, _ in self.vertices]
        return max(xs) - min(xs)

    def rate(self, g: float, side: int) -> float:
        """sqrt(m g rho / I_P) about the right (side +1) or left (-1) corner, rad/s (a rectangle's
        p = sqrt(3 g / (4 R)))."""
        b = self.bR if side > 0 else self.bL
        rho2 = b * b + self.yG * self.yG
        return math.sqrt(self.mass * g * math.sqrt(rho2) / (self.inertia + self.mass * rho2))

    def impact_ratio(self, new_side: int) -> float:
        """omega+ / omega- of the plastic impact landing on corner `new_side` (+1 right, -1 left):
        (IG + m (yG^2 - bL bR)) / (IG + m rho_N^2), Housner's 1 - 1.5 sin^2 alpha for a rectangle."""
        b = self.bR if new_side > 0 else self.bL
        m = self.mass
        return (self.inertia + m * (self.yG ** 2 - self.bL * self.bR)) / (self.inertia + m * (b * b + self.yG ** 2))


def format_outline(vertices: Sequence[Sequence[float]]) -> str:
    """The FMU's String of an outline: "x,y; x,y; ..." (m), each number as Python's shortest exact repr."""
    return "; ".join(f"{float(x)!r},{float(y)!r}" for x, y in vertices)


def parse_outline(text: str) -> list[tuple[float, float]]:
    """The vertices of an FMU outline String (format_outline's inverse); ValueError if it is not one."""
    out = []
    for item in text.split(";"):
        if not item.strip():
            continue
        x, y = item.split(",")
        out.append((float(x), float(y)))
    return out


def has_outline(p: Mapping[str, Any], k: int | None = None) -> bool:
    """Whether block `k` of parameters `p` (any block of the scene's nBlocks when k is None) is given by
    an outline."""
    if k is not None:
        return bool(str(p.get(f"block{k}.outline", "") or "").strip())
    return any(has_outline(p, j) for j in range(1, int(p.get("nBlocks", 1)) + 1))


def polygon_properties(vertices: Sequence[Sequence[float]], mass: float) -> tuple[float, float, float]:
    """Centroid (x, y) and inertia about it (kg m^2) of a uniform polygon of `mass` (shoelace sums,
    about the first vertex to limit cancellation)."""
    x0, y0 = vertices[0]
    pts = [(x - x0, y - y0) for x, y in vertices]
    a2 = cx = cy = j = 0.0
    for (xa, ya), (xb, yb) in zip(pts, pts[1:] + pts[:1]):
        cr = xa * yb - xb * ya
        a2 += cr
        cx += (xa + xb) * cr
        cy += (ya + yb) * cr
        j += (xa * xa + xa * xb + xb * xb + ya * ya + ya * yb + yb * yb) * cr
    if a2 == 0.0:
        raise ValueError("the outline has no area")
    cx, cy = cx / (3 * a2), cy / (3 * a2)
    polar = j / 12.0 / (0.5 * a2)  # per unit area, about the first vertex
    return cx + x0, cy + y0, mass * (polar - (cx * cx + cy * cy))


def _landing(vertices: list[tuple[float, float]], xL: float, xR: float, tol: float) -> tuple[float, float]:
    """(beta_left, beta_right): the rotation that lays the polygon's edge next to each base corner on
    the ground (pi/2 for a rectangle). A corner's neighbour off the base gives the edge's direction."""
    n = len(vertices)

    def up_neighbour(x_corner: float) -> tuple[float, float]:
        i = next(i for i, (x, y) in enumerate(vertices) if abs(y) <= tol and x == x_corner)
        for j in (i - 1, (i + 1) % n):
            if vertices[j][1] > tol:
                return vertices[j][0] - x_corner, vertices[j][1]
        raise ValueError("a base corner without an edge going up")

    dxl, dyl = up_neighbour(xL)
    dxr, dyr = up_neighbour(xR)
    return math.atan2(dyl, -dxl), math.atan2(dyr, dxr)


def body(p: Mapping[str, Any], k: int) -> Body:
    """Block `k` of parameters `p` (defaults included) as a Body: its outline if given, else the rectangle
    of its half sizes. ValueError for an outline the FMU would refuse in ways that matter here (no flat
    base, no area); the FMU's own checks are the full ones."""
    mass = float(p[f"block{k}.mass"])
    if not has_outline(p, k):
        b, h = float(p[f"block{k}.halfWidth"]), float(p[f"block{k}.halfHeight"])
        verts = ((-b, 0.0), (b, 0.0), (b, 2 * h), (-b, 2 * h))
        return Body(verts, -b, b, 0.0, h, mass, mass * (b * b + h * h) / 3, 2 * h, -b, b, math.pi / 2, math.pi / 2,
                    outline=False, uniform=True)
    verts = parse_outline(str(p[f"block{k}.outline"]))
    scale = max(max(abs(x), abs(y)) for x, y in verts)
    tol = 1e-12 * max(1.0, scale)
    base = [x for x, y in verts if abs(y) <= tol]
    if len(base) < 2:
        raise ValueError(f"block{k}.outline has no flat base on y = 0")
    top = max(y for _, y in verts)
    tops = [x for x, y in verts if abs(y - top) <= tol]
    inertia = float(p.get(f"block{k}.inertia", 0.0) or 0.0)
    if inertia > 0:
        xg, yg, ig, uniform = float(p[f"block{k}.centreX"]), float(p[f"block{k}.centreY"]), inertia, False
    else:
        xg, yg, ig = polygon_properties(verts, mass)
        uniform = True
    xl, xr = min(base), max(base)
    beta_l, beta_r = _landing(verts, xl, xr, tol)
    return Body(tuple(verts), xl, xr, xg, yg, mass, ig, top, min(tops), max(tops), beta_l, beta_r,
                outline=True, uniform=uniform)


def alpha(p: Mapping[str, Any], k: int) -> float:
    """Block `k`'s slenderness angle (rad) as the runners' peak |theta| / alpha uses it: atan(b / h) of a
    rectangle; of a body of real shape the smaller of its two sides' atan(bL / yG), atan(bR / yG) (the
    nearer of its two tipping points: the ratio is then an upper bound of either side's)."""
    if not has_outline(p, k):
        return math.atan2(float(p[f"block{k}.halfWidth"]), float(p[f"block{k}.halfHeight"]))
    bd = body(p, k)
    return min(bd.alpha_left, bd.alpha_right)


def alpha_of_point(values: Mapping[str, Any], k: int) -> float:
    """alpha(values, k) where a value may be NaN or None (a sweep point's parameter it does not set)."""
    return alpha({key: v for key, v in values.items() if v is not None}, k)


def stack_bodies(p: Mapping[str, Any]) -> list[Body]:
    """Each block of the stack or column of `p` (block 1 first)."""
    return [body(p, k) for k in range(1, int(p.get("nBlocks", 1)) + 1)]


def joints(p: Mapping[str, Any]) -> list[dict[str, Any]]:
    """Every joint of the blocks of `p` at rest (the ground under block 1, block K - 1's top under block
    K): the blocks from K up tipping as one body about the ends of the joint's contact (block K's base
    within the top below), with their combined centre of mass. Per joint: ``joint`` (K), ``on`` ("ground"
    or "block K-1"), ``right_m_s2`` and ``left_m_s2``, the |a_h| (m/s^2, with a_v = 0) beyond which they
    lift onto the right end (a_h below minus it) and onto the left end (a_h above it), ``alpha_right_rad``
    and ``alpha_left_rad``."""
    g = float(p["g"])
    bodies = stack_bodies(p)
    out = []
    for k in range(1, len(bodies) + 1):
        above = bodies[k - 1:]
        z, m_sum, mx, my = 0.0, 0.0, 0.0, 0.0
        for b in above:
            m_sum += b.mass
            mx += b.mass * b.xG
            my += b.mass * (z + b.yG)
            z += b.top
        xg, yg = mx / m_sum, my / m_sum
        lo, hi = bodies[k - 1].xL, bodies[k - 1].xR
        if k > 1:
            lo, hi = max(lo, bodies[k - 2].top_left), min(hi, bodies[k - 2].top_right)
        out.append({"joint": k, "on": "ground" if k == 1 else f"block {k - 1}", "blocks": list(range(k, len(bodies) + 1)),
                    "right_m_s2": g * (hi - xg) / yg, "left_m_s2": g * (xg - lo) / yg,
                    "alpha_right_rad": math.atan2(hi - xg, yg), "alpha_left_rad": math.atan2(xg - lo, yg)})
    return out


def joint_words(j: Mapping[str, Any], n: int) -> str:
    """What tips at joint `j` of `n` blocks, in words (as runners.engine.scene.uplift_threshold says it)."""
    k = j["joint"]
    if n == 1:
        return "the block rocks"
    if k == 1:
        return "the pair rocks as one body" if n == 2 else "the column rocks as one body"
    if k == n:
        return "the upper block rocks alone" if n == 2 else f"block {n} rocks on block {n - 1}"
    return f"blocks {k}-{n} rock as one body on block {k - 1}"


def uplift(p: Mapping[str, Any]) -> tuple[float, str]:
    """(the least |a_h|, m/s^2, that tips any joint of the blocks of `p` from rest, what starts then) over
    both sides of every joint (joints)."""
    n = int(p.get("nBlocks", 1))
    best = (math.inf, "")
    for j in joints(p):
        for side in ("right", "left"):
            a = j[f"{side}_m_s2"]
            if a < best[0]:
                other = j["left_m_s2" if side == "right" else "right_m_s2"]
                if abs(other - a) <= 1e-12 * a:  # a symmetric body: either side
                    best = (a, joint_words(j, n))
                else:
                    best = (a, f"{joint_words(j, n)}, onto its {side} corner" if n == 1 else
                            f"{joint_words(j, n)}, onto the {side} end of its base")
    return best


def shape_facts(p: Mapping[str, Any]) -> list[dict[str, Any]]:
    """A summary's facts of each block given by an outline: block, vertices, width and height (m), centre
    of mass (m), inertia (kg m^2) and whether uniform, alphas and landing angles per side (rad)."""
    facts = []
    for k in range(1, int(p.get("nBlocks", 1)) + 1):
        if not has_outline(p, k):
            continue
        b = body(p, k)
        facts.append({"block": k, "vertices": [list(v) for v in b.vertices], "width_m": b.width, "height_m": b.top,
                      "base_m": [b.xL, b.xR], "centre_m": [b.xG, b.yG], "inertia_kg_m2": b.inertia,
                      "uniform": b.uniform, "alpha_left_rad": b.alpha_left, "alpha_right_rad": b.alpha_right,
                      "landing_left_rad": b.beta_left, "landing_right_rad": b.beta_right})
    return facts
