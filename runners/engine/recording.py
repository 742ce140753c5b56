"""Rerun recordings (.rrd) of runs, for review offline in the Rerun viewer.

A recording holds, on the ``sim_time`` timeline (s):

- ``/block1/theta``, ``/block1/omega``, ``/block1/alpha_dd`` (and ``/block2/...``
  for a stack): rad, rad/s, rad/s^2, at every output sample;
- ``/ground/ah``, ``/ground/av`` (m/s^2), ``/energy`` (J), ``/block1/pivot``
  (+1 right corner, -1 left, 0 flat; ``/block2/pivot`` likewise);
- for a rocking-sliding run (contact.model = 1): ``/block1/slip`` (m, +x), ``/block1/slip_rate``
  (m/s), ``/block1/gap`` (m: its lowest corner above the ground, 0 touching) and ``/block1/mode``
  (0 rest, 1 slide, 2 rock, 3 slide-rock, 4 overturned, 6 flight), with a plot of the slip, its rate
  and the gap; for a stack also ``/block2/slip``, ``/block2/slip_rate`` (along block
  1's top, relative to it) and ``/block2/mode`` (5: fell off);
- ``/events``: impacts, uplift, rest, settling (lock), opening (unlock) and
  overturn as text entries with their values, at their times (events at
  one instant share an entry, separated by "; ");
- ``/scene``: the blocks drawn to scale (outlines and each block's pivot in use)
  on the moving base, animated at up to 100 frames per simulated second; a block that slides
  is drawn where it has slid (its pivot corner at x = slip + s b on the base), a block that flies
  where it flies (raised by its gap);
- for a run driven by a record: ``/record/ah`` (and ``/record/av``), the
  record's own samples times its scale (m/s^2), and ``/record/about``, a text
  with its name, provenance, scale and intensity measures;
- ``/contact/ground/demand`` (and ``/contact/interface/demand`` for a stack):
  the friction demand ``|T| / N`` the contact needs (docs/contact.md), with
  ``.../mu``, its coefficient of friction, as a line: rigid rocking holds while
  the demand stays below it; no value while ``N <= 0`` (flight);
- a blueprint that opens on the scene, the angles, the velocities, the
  excitation and the friction demand (and the record's text), each plot with a y range symmetric
  about 0 chosen so that the viewer labels several ticks (axis_range).

Every entity is logged on whole nanoseconds rounded once (``_ns``), so samples of one instant share
a row. Time series go through the columnar API (``send_columns``). Conventions:
docs/conventions.md (theta > 0 clockwise about the right corner).
"""

from __future__ import annotations

import contextlib
import math
import uuid
from pathlib import Path
from typing import Any, Iterator

import numpy as np

from runners.engine.files import staged
from runners.engine.shapes import has_outline, stack_bodies
from runners.errors import FileError

MAX_FPS = 100.0  # animation frames per simulated second


def _ns(seconds: float | np.ndarray) -> np.timedelta64 | np.ndarray:
    """Times in s as whole nanoseconds (numpy timedelta64[ns]), rounded to the nearest: every entity
    is logged on the same time values. Rerun truncates float seconds, so a series at the FMU's output
    times (a step of 0.004999999999999893 s, a record's smallest sample interval) and the record's
    samples at 0.005 s fell on two rows (4999999 and 5000000 ns), doubling the rows a reader got."""
    ns = np.round(np.asarray(seconds, float) * 1e9).astype(np.int64)
    return ns.astype("timedelta64[ns]")[()]  # [()]: a scalar for one time


def _rot(theta: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Rotate body-frame points (k, 2) clockwise by theta (n,): (n, k, 2)."""
    c, s = np.cos(theta)[:, None], np.sin(theta)[:, None]
    x, y = pts[:, 0][None, :], pts[:, 1][None, :]
    return np.stack([c * x + s * y, -s * x + c * y], axis=-1)


def block_outlines(time: np.ndarray, out: dict[str, np.ndarray], p: dict[str, Any]
                   ) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Closed outlines (n, 5, 2) of each block in the ground frame (m), origin at block 1's
    bottom centre at rest, and each block's pivot (n, 2): block 1's corner on the ground, block 2's
    end of the contact on block 1. Block 1 stands where it has slid: its pivot corner at
    x = slip + s b (s = +1 right, -1 left; ``block1.slip`` in m, +x, 0 when `out` has none), the
    outline rotated by theta about it, so the base's centre is at x = slip + s b (1 - cos theta), and
    raised by ``block1.gap`` (m) while it flies (its lowest corner at that height).
    Block 2 stands on block 1 where it has slid along its top: its pivot at s2 c + ``block2.slip``
    in block 1's frame (c = min(b1, b2); the slip 0 when `out` has none)."""
    if has_outline(p):  # bodies of real shape: every block's own polygon
        return shape_outlines(time, out, p)
    b1, h1 = p["block1.halfWidth"], p["block1.halfHeight"]
    th1 = out["block1.theta"]
    slip = np.asarray(out.get("block1.slip", np.zeros(len(time))), float)
    s1 = np.where(th1 >= 0, 1.0, -1.0)
    shapes, pivot_points = [], [np.stack([slip + s1 * b1, np.zeros(len(time))], 1)]
    rect1 = np.array([[-b1, 0], [b1, 0], [b1, 2 * h1], [-b1, 2 * h1], [-b1, 0]])
    # rotate about the pivot P = (slip + s1 b1, 0): P + R (x + (slip, 0) - P)
    pts = np.empty((len(time), 5, 2))
    for side in (1.0, -1.0):
        m = s1 == side
        if m.any():
            P = np.array([side * b1, 0.0])
            pts[m] = P + _rot(th1[m], rect1 - P)
    pts[:, :, 0] += slip[:, None]
    gap = np.asarray(out.get("block1.gap", np.zeros(len(time))), float)  # in flight: its lowest corner's height
    pts[:, :, 1] += gap[:, None]
    pivot_points[0][:, 1] = gap
    shapes.append(pts)
    if int(p.get("nBlocks", 1)) == 2:
        b2, h2 = p["block2.halfWidth"], p["block2.halfHeight"]
        c = min(b1, b2)
        th2 = out["block2.theta"]
        slip2 = np.asarray(out.get("block2.slip", np.zeros(len(time))), float)
        s2 = np.where(th2 - th1 >= 0, 1.0, -1.0)
        rect2 = np.array([[-b2, 0], [b2, 0], [b2, 2 * h2], [-b2, 2 * h2], [-b2, 0]])
        pts2, K2 = np.empty((len(time), 5, 2)), np.empty((len(time), 2))
        for side1 in (1.0, -1.0):
            for side2 in (1.0, -1.0):
                m = (s1 == side1) & (s2 == side2)
                if not m.any():
                    continue
                P1 = np.array([side1 * b1, 0.0])
                # block 2's pivot in block 1's frame, relative to block 1's pivot, then turned with it
                arm = np.stack([side2 * c + slip2[m] - side1 * b1, np.full(int(m.sum()), 2 * h1)], 1)
                cth, sth = np.cos(th1[m])[:, None], np.sin(th1[m])[:, None]
                K = P1 + np.hstack([cth * arm[:, :1] + sth * arm[:, 1:], -sth * arm[:, :1] + cth * arm[:, 1:]])
                K[:, 0] += slip[m]
                K[:, 1] += gap[m]
                body = rect2 - np.array([side2 * c, 0.0])  # block 2's outline about its pivot
                pts2[m] = K[:, None, :] + _rot(th2[m], body)
                K2[m] = K
        shapes.append(pts2)
        pivot_points.append(K2)
    for k in range(2, int(p.get("nBlocks", 1)) + 1) if int(p.get("nBlocks", 1)) >= 3 else ():
        pts, K = _stacked_outline(time, out, p, k, shapes[-1])
        shapes.append(pts)
        pivot_points.append(K)
    return shapes, pivot_points


def _turn(theta: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Points q (n, 2), one per sample, rotated clockwise by theta (n,)."""
    c, s = np.cos(theta), np.sin(theta)
    return np.stack([c * q[:, 0] + s * q[:, 1], -s * q[:, 0] + c * q[:, 1]], 1)


def shape_outlines(time: np.ndarray, out: dict[str, np.ndarray], p: dict[str, Any]
                   ) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """block_outlines of blocks that may be bodies of real shape (runners.engine.shapes.Body): each block's
    closed polygon (n, k + 1, 2) in the ground frame (m) and its pivot (n, 2). Block 1 turns by its theta
    about its base corner (xR when theta >= 0, else xL; x from its axis) at x = slip + that corner, raised
    by its gap; block K turns by its absolute theta about the end of its contact with block K - 1 (its
    base's right end, within the top below, when it turns clockwise relative to block K - 1, else the
    left), placed at that end + blockK.slip along the top of block K - 1 as block K - 1 stands. The centre
    of a body is drawn where its own outline puts it (its centre of mass needs no drawing of its own)."""
    n = len(time)
    zero = np.zeros(n)
    bodies = stack_bodies(p)
    shapes, pivot_points = [], []
    poses: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []  # (world pivot, pivot in the body's frame, theta)
    for k, bd in enumerate(bodies, start=1):
        poly = np.array([*bd.vertices, bd.vertices[0]], float)
        th = np.asarray(out[f"block{k}.theta"], float)
        slip = np.asarray(out.get(f"block{k}.slip", zero), float)
        if k == 1:
            side = np.where(th >= 0, 1.0, -1.0)
            corner = np.where(side > 0, bd.xR, bd.xL)
            gap = np.asarray(out.get("block1.gap", zero), float)
            K = np.stack([slip + corner, gap], 1)
        else:
            below = bodies[k - 2]
            K_b, P_b, th_b = poses[-1]
            side = np.where(th - th_b >= 0, 1.0, -1.0)
            corner = np.where(side > 0, min(bd.xR, below.top_right), max(bd.xL, below.top_left))
            on_top = np.stack([corner + slip, np.full(n, below.top)], 1)  # in block K - 1's frame
            K = K_b + _turn(th_b, on_top - P_b)
        P = np.stack([corner, zero], 1)
        pts = K[:, None, :] + _rot(th, poly)  - _turn(th, P)[:, None, :]
        poses.append((K, P, th))
        shapes.append(pts)
        pivot_points.append(K)
    return shapes, pivot_points


def _stacked_outline(time: np.ndarray, out: dict[str, np.ndarray], p: dict[str, Any], k: int,
                     below: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Block `k` of a column (outline (n, 5, 2) and pivot (n, 2), m) on the block below, whose outline
    is `below`: its pivot on the top of the block below at s c + ``blockK.slip`` from that top's
    centre, along it (c = min(b_{K-1}, b_K), s = +1 when it turns clockwise relative to the block
    below, -1 otherwise, its slip 0 when `out` has none), its outline rotated by its absolute theta."""
    b, h = p[f"block{k}.halfWidth"], p[f"block{k}.halfHeight"]
    c = min(p[f"block{k - 1}.halfWidth"], b)
    th, th_below = np.asarray(out[f"block{k}.theta"], float), np.asarray(out[f"block{k - 1}.theta"], float)
    slip = np.asarray(out.get(f"block{k}.slip", np.zeros(len(time))), float)
    side = np.where(th - th_below >= 0, 1.0, -1.0)
    top_left, top_right = below[:, 3, :], below[:, 2, :]  # the outline's corners: bottom-left, -right, top-right, -left
    centre = 0.5 * (top_left + top_right)
    along = top_right - top_left
    along = along / np.maximum(np.linalg.norm(along, axis=1, keepdims=True), 1e-300)
    K = centre + (side * c + slip)[:, None] * along
    rect = np.array([[-b, 0], [b, 0], [b, 2 * h], [-b, 2 * h], [-b, 0]])
    pts = np.empty((len(time), 5, 2))
    for sd in (1.0, -1.0):
        m = side == sd
        if m.any():
            pts[m] = K[m, None, :] + _rot(th[m], rect - np.array([sd * c, 0.0]))
    return pts, K


def pivots(out: dict[str, np.ndarray], two: bool | int) -> dict[str, np.ndarray]:
    """Each block's pivot side (+1 right, -1 left, 0 flat) relative to what it stands on; `two`:
    True for two blocks, or the number of blocks."""
    n = int(two) + 1 if isinstance(two, bool) else int(two)
    th1 = out["block1.theta"]
    piv = {"block1": np.sign(th1)}
    for k in range(2, n + 1):
        piv[f"block{k}"] = np.sign(np.asarray(out[f"block{k}.theta"]) - np.asarray(out[f"block{k - 1}.theta"]))
    return piv


def base_motion(time: np.ndarray, ah: np.ndarray, av: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ground displacement (x, y) in m for drawing the moving base.

    The total ground accelerations (m/s^2, at the output samples) integrated twice
    by the trapezoid rule, then a least-squares line removed from each: that is the
    same motion seen from an inertial frame moving at constant velocity, so nothing
    about the block's motion relative to the base changes, and a harmonic table
    motion stays centred instead of drifting off the picture.
    """
    t = np.asarray(time, float)
    if len(t) < 3:
        return np.zeros(len(t)), np.zeros(len(t))
    dt = np.diff(t)

    def twice(a: np.ndarray) -> np.ndarray:
        a = np.asarray(a, float)
        v = np.concatenate([[0.0], np.cumsum(0.5 * dt * (a[1:] + a[:-1]))])
        x = np.concatenate([[0.0], np.cumsum(0.5 * dt * (v[1:] + v[:-1]))])
        return x - np.polyval(np.polyfit(t, x, 1), t)

    return twice(ah), twice(av)


def _to_view(pts: np.ndarray) -> np.ndarray:
    """Rerun's 2D views have y pointing down: flip y for drawing (drawing only)."""
    return pts * np.array([1.0, -1.0])


def _ground_hatch(x0: np.ndarray, y0: np.ndarray, width: float) -> np.ndarray:
    """The base drawn as a line with slanted hatching, (n, 1 + 2 k, 2) strips per frame, so its motion shows."""
    d = width / 8
    offsets = np.arange(-width + d, width, d)
    n = len(x0)
    strips = np.empty((n, 1 + len(offsets), 2, 2))
    strips[:, 0, 0] = np.stack([x0 - width, y0], 1)
    strips[:, 0, 1] = np.stack([x0 + width, y0], 1)
    for j, o in enumerate(offsets, start=1):
        strips[:, j, 0] = np.stack([x0 + o, y0], 1)
        strips[:, j, 1] = np.stack([x0 + o - 0.5 * d, y0 - 0.5 * d], 1)
    return strips


def axis_range(*series: np.ndarray) -> tuple[float, float]:
    """A y range for a plot of `series`: symmetric about 0, +-R with R the smallest of 1, 1.5, 2 or
    3 times a power of ten that is at least 1.1 times the largest |value|. The viewer labels its
    y axis at powers of ten only where they lie far enough apart; so the labels 0 and +-10^k
    (and +-2, +-3 x 10^k) always show, and the curves fill a third to all of the height, where
    an auto-scaled theta of +-0.045 rad had the single label 0."""
    peak = max((float(np.nanmax(np.abs(s))) for s in series if len(s) and np.isfinite(s).any()), default=0.0)
    if not peak > 0.0 or not math.isfinite(peak):
        return (-1.0, 1.0)
    target = 1.1 * peak
    k = math.floor(math.log10(target))
    for m in (1.0, 1.5, 2.0, 3.0, 10.0):
        if m * 10.0 ** k >= target * (1 - 1e-12):
            r = float(f"{m * 10.0 ** k:.3g}")
            return (-r, r)
    return (-10.0 ** (k + 1), 10.0 ** (k + 1))  # not reached


def _blueprint(two: bool | int, measured: list[str], bounds: tuple[float, float, float, float], record: bool = False,
               ranges: dict[str, tuple[float, float]] | None = None, sliding: bool = False):
    """Scene on the left (over the record's text, if any); angles, velocities and excitation on the
    right, each plot with its y range (`ranges`: theta, omega, ground -> (low, high), axis_range);
    the run playing in a loop."""
    import rerun.blueprint as rrb

    n = int(two) + 1 if isinstance(two, bool) else int(two)
    blocks = [f"block{k}" for k in range(1, n + 1)]
    ranges = ranges or {}

    def y_axis(key: str) -> "rrb.ScalarAxis | None":
        return rrb.ScalarAxis(range=ranges[key], zoom_lock=False) if key in ranges else None

    def plot(name: str, var: str) -> "rrb.TimeSeriesView":
        extra = [f"/measured/{m}" for m in measured if m.endswith(f"/{var}")]
        return rrb.TimeSeriesView(name=name, contents=[f"/{b}/{var}" for b in blocks] + extra, axis_y=y_axis(var))

    x0, x1, y0, y1 = bounds
    scene = rrb.Spatial2DView(origin="/scene", name="blocks (to scale)",
                              visual_bounds=rrb.VisualBounds2D(x_range=[x0, x1], y_range=[y0, y1]))
    if record:
        scene = rrb.Vertical(scene, rrb.TextDocumentView(origin="/record/about", name="record"), row_shares=[3, 1])
    return rrb.Blueprint(
        rrb.Horizontal(
            scene,
            rrb.Vertical(
                plot("theta (rad)", "theta"),
                plot("omega (rad/s)", "omega"),
                rrb.TimeSeriesView(name="ground (m/s2)", contents=["/ground/**", "/record/ah", "/record/av"],
                                   axis_y=y_axis("ground")),
                rrb.TimeSeriesView(name="friction demand |T|/N against mu", contents=["/contact/**"],
                                   axis_y=y_axis("demand")),
                *([rrb.TimeSeriesView(name="slip and gap (m), slip rate (m/s)",
                                      contents=["/block1/slip", "/block1/slip_rate", "/block1/gap", "/block2/slip",
                                                "/block2/slip_rate", *[f"/{b}/slip" for b in blocks[2:]]],
                                      axis_y=y_axis("slip"))]
                  if sliding else []),
            ),
            column_shares=[2, 3],
        ),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(state="collapsed", timeline="sim_time", play_state="playing", loop_mode="all"),
    )


COLOURS = {"block1": (70, 110, 200), "block2": (200, 90, 70), "block3": (60, 160, 90), "block4": (150, 90, 180),
           "block5": (200, 150, 40), "block6": (40, 160, 170), "block7": (170, 80, 120), "block8": (110, 110, 110),
           "ground/ah": (60, 60, 60),
           "ground/av": (150, 150, 150), "record": (220, 150, 40), "energy": (120, 80, 160),
           "demand": (40, 150, 90), "mu": (200, 40, 40)}


def friction_demand(out: dict[str, np.ndarray], p: dict[str, Any], two: bool
                    ) -> dict[str, tuple[np.ndarray, float]]:
    """contact -> (|T| / N at the samples, NaN where N <= 0; its mu), for the contacts the
    run's outputs have reactions of (docs/contact.md)."""
    result = {}
    for contact, name, mu in (("ground", "ground", "contact.muGround"),
                              ("interface", "interface", "contact.muInterface")):
        T, N = out.get(f"contact.{name}T"), out.get(f"contact.{name}N")
        if T is None or N is None or (contact == "interface" and not two):
            continue
        T, N = np.asarray(T, float), np.asarray(N, float)
        with np.errstate(divide="ignore", invalid="ignore"):
            result[contact] = (np.where(N > 0, np.abs(T) / N, np.nan), float(p.get(mu, 0.7)))
    return result


def _colour(entity: str, shade: float = 1.0) -> tuple[int, int, int]:
    """The colour of an entity's series: each block keeps its scene colour in every plot."""
    key = next((k for k in COLOURS if entity.strip("/").startswith(k)), "energy")
    return tuple(int(round(c * shade)) for c in COLOURS[key])


# the series of a recording: entity path -> output variable
SERIES = {"/block1/theta": "block1.theta", "/block1/omega": "block1.omega", "/block1/alpha_dd": "block1.alpha_dd",
          "/block2/theta": "block2.theta", "/block2/omega": "block2.omega", "/block2/alpha_dd": "block2.alpha_dd",
          "/ground/ah": "ground.ahTotal", "/ground/av": "ground.avTotal", "/energy": "energy",
          # rocking-sliding (contact.model = 1): m, m/s, and the mode (0 rest ... 4 overturned)
          "/block1/slip": "block1.slip", "/block1/slip_rate": "block1.slipRate", "/block1/mode": "block1.mode",
          "/block1/gap": "block1.gap",
          "/block2/slip": "block2.slip", "/block2/slip_rate": "block2.slipRate", "/block2/mode": "block2.mode"}
# blocks 3 to 8 of a column: angle, velocity, slip on the block below, mode
SERIES.update({f"/block{k}/{var}": f"block{k}.{name}" for k in range(3, 9)
               for var, name in (("theta", "theta"), ("omega", "omega"), ("slip", "slip"), ("mode", "mode"))})
SHADES = {"/block1/slip_rate": 0.6, "/block1/mode": 0.4, "/block1/gap": 0.8, "/block2/slip_rate": 0.6, "/block2/mode": 0.4}  # lighter than the block's colour, in the same plot


def record_text(info: dict[str, Any], scale: float) -> str:
    """Markdown about the record of a run: name, provenance, scale, measures of the scaled record."""
    from runners.engine.intensity import G0 as g0
    lines = [f"**{info['name']}** x {scale:g}"]
    if info.get("event"):
        lines.append(f"{info['event']} {info.get('year') or ''}, M {info.get('magnitude')}, station "
                     f"{info.get('station')}, {info.get('distance_km')} km")
    if info.get("source"):
        lines.append(str(info["source"]))
    if info.get("pga") is not None:
        lines.append(f"scaled: PGA {abs(scale) * info['pga'] / g0:.3f} g, PGV {abs(scale) * info['pgv']:.3f} m/s, "
                     f"PGD {abs(scale) * info['pgd']:.3f} m, Arias {scale * scale * info['arias']:.3f} m/s, "
                     f"D5-95 {info['d5_95']:.2f} s")
    return "\n\n".join(lines)


def write_recording(path: Path, name: str, time: np.ndarray, out: dict[str, np.ndarray], p: dict[str, Any],
                    events: list | None = None, measured: dict[str, tuple[np.ndarray, np.ndarray]] | None = None,
                    record: dict[str, Any] | None = None) -> Path:
    """Write one run to path (.rrd) and return the path.

    `out` holds output series at `time` (s); `p` the run's FMU parameters; `events` the
    FMU's events (runners.engine.fmu.Event); `measured` maps an output name (block1.theta,
    block1.omega, block2.theta, block2.omega) to (time in s, values in rad or rad/s) to
    overlay as /measured/block1/theta etc. in the same plots; `record` describes the
    record of a record-driven run (runners.engine.records.row, with "source"); its samples are
    read from the run's excitation.file.

    Each call writes through its own RecordingStream to its own file, so recordings can
    be written from several threads or processes at once.
    """
    import rerun as rr

    n_blocks = int(p.get("nBlocks", 1))
    two = n_blocks == 2
    time = np.asarray(time, float)
    measured = measured or {}
    unknown = sorted(set(measured) - {"block1.theta", "block1.omega", "block2.theta", "block2.omega"})
    if unknown:
        raise ValueError(f"cannot overlay measured {', '.join(unknown)}: block1/2 .theta and .omega only")
    measured_paths = ["/".join(k.split(".")) for k in measured]
    # the scene: outlines at up to MAX_FPS frames per simulated second, on the moving base
    stride = max(1, int(math.ceil((len(time) - 1) / max(1.0, (time[-1] - time[0]) * MAX_FPS)))) if len(time) > 1 else 1
    frames = np.arange(0, len(time), stride)
    at_frames = {k: np.asarray(v)[frames] for k, v in out.items()}
    zero = np.zeros(len(time))
    xg, yg = base_motion(time, out.get("ground.ahTotal", zero), out.get("ground.avTotal", zero))
    xg, yg = xg[frames], yg[frames]
    offset = np.stack([xg, yg], 1)[:, None, :]
    outlines, pivot_points = block_outlines(time[frames], at_frames, p)
    shapes = [pts + offset for pts in outlines]
    b1 = p["block1.halfWidth"]
    slid = float(np.abs(np.asarray(out["block1.slip"], float)).max(initial=0.0)) if "block1.slip" in out else 0.0
    width = 4 * max(b1, p.get("block2.halfWidth", b1) if two else b1) + slid
    height = 2 * p["block1.halfHeight"] + (2 * p["block2.halfHeight"] if two else 0.0)
    if n_blocks >= 3:  # a column: its whole height, and its lean (a column sways more than it slides)
        height = sum(2 * p[f"block{k}.halfHeight"] for k in range(1, n_blocks + 1))
        width = max(width, 0.6 * height)
    if has_outline(p):  # bodies of real shape: their outlines' extents
        bodies = stack_bodies(p)
        b1 = 0.5 * (bodies[0].xR - bodies[0].xL)  # (the pivots' marker size)
        height = sum(bd.top for bd in bodies)
        width = max(2 * max(bd.width for bd in bodies) + slid, 0.6 * height)
    reach = max(np.abs(xg).max(initial=0.0), np.abs(yg).max(initial=0.0))
    bounds = (-width - reach, width + reach, -1.15 * height - reach, 0.25 * height + reach)  # y down

    blocks = [f"block{k}" for k in range(1, n_blocks + 1)]
    ranges = {var: axis_range(*[np.asarray(out[f"{b}.{var}"], float) for b in blocks if f"{b}.{var}" in out],
                              *[np.asarray(v[1], float) for k, v in measured.items() if k.endswith(f".{var}")])
              for var in ("theta", "omega")}
    ranges["ground"] = axis_range(*[np.asarray(out[k], float) for k in ("ground.ahTotal", "ground.avTotal")
                                    if k in out])
    demand = friction_demand(out, p, two)
    if demand:
        ranges["demand"] = (0.0, 2.0 * max(mu for _, mu in demand.values()))
    sliding = "block1.slip" in out
    if sliding:
        ranges["slip"] = axis_range(*[np.asarray(out[k], float) for k in ("block1.slip", "block1.slipRate", "block1.gap",
                                                                          "block2.slip", "block2.slipRate",
                                                                          *[f"{b}.slip" for b in blocks[2:]])
                                      if k in out])
    path = Path(path)
    with _stream(path, _blueprint(n_blocks, measured_paths, bounds, record is not None, ranges, sliding)) as rec:
        rec.send_property("run", rr.AnyValues(name=name))
        if record is not None:
            from runners.engine.record_files import read_record_file

            scale, start = float(p.get("excitation.scale", 1.0)), float(p.get("excitation.startTime", 0.0))
            rt, rah, rav = read_record_file(p["excitation.file"])
            rec.send_property("record", rr.AnyValues(name=record["name"], scale=scale))
            rec.log("/record/about", rr.TextDocument(record_text(record, scale), media_type="text/markdown"),
                    static=True)
            for entity, values in (("/record/ah", rah), ("/record/av", rav)):
                if values is not None:
                    rec.log(entity, rr.SeriesPoints(colors=[_colour("record")], marker_sizes=1.5,
                                                    names=[f"record samples {entity[-2:]} x {scale:g}"]), static=True)
                    rec.send_columns(entity, indexes=[rr.TimeColumn("sim_time", duration=_ns(start + rt))],
                                     columns=rr.Scalars.columns(scalars=scale * values))
        idx = [rr.TimeColumn("sim_time", duration=_ns(time))]
        for entity, var in SERIES.items():
            if var in out and int(entity.split("/")[1][5:] if entity.startswith("/block") else 1) <= n_blocks:
                rec.log(entity, rr.SeriesLines(colors=[_colour(entity, SHADES.get(entity, 1.0))],
                                               names=[entity.strip("/")]), static=True)
                rec.send_columns(entity, indexes=idx, columns=rr.Scalars.columns(scalars=np.asarray(out[var], float)))
        for block, piv in pivots(out, n_blocks).items():
            rec.send_columns(f"/{block}/pivot", indexes=idx, columns=rr.Scalars.columns(scalars=piv))
        for contact, (values, mu) in demand.items():
            rec.log(f"/contact/{contact}/demand",
                    rr.SeriesLines(colors=[_colour("demand")], names=[f"{contact} |T|/N"]), static=True)
            rec.send_columns(f"/contact/{contact}/demand", indexes=idx, columns=rr.Scalars.columns(scalars=values))
            rec.log(f"/contact/{contact}/mu", rr.SeriesLines(colors=[_colour("mu")], names=[f"{contact} mu"]),
                    static=True)
            rec.send_columns(f"/contact/{contact}/mu",
                             indexes=[rr.TimeColumn("sim_time", duration=_ns(time[[0, -1]]))],
                             columns=rr.Scalars.columns(scalars=np.array([mu, mu])))
        for entity, (mt, mv) in zip(measured_paths, measured.values()):
            rec.log(f"/measured/{entity}", rr.SeriesPoints(colors=[_colour(entity, 0.6)], markers="circle",
                                                            marker_sizes=3.0, names=[f"measured {entity}"]),
                    static=True)
            rec.send_columns(f"/measured/{entity}", indexes=[rr.TimeColumn("sim_time", duration=_ns(mt))],
                             columns=rr.Scalars.columns(scalars=np.asarray(mv, float)))
        frame_idx = [rr.TimeColumn("sim_time", duration=_ns(time[frames]))]
        for i, pts in enumerate(shapes, start=1):
            rec.log(f"/scene/block{i}", rr.LineStrips2D.from_fields(colors=[COLOURS[f"block{i}"]]), static=True)
            rec.send_columns(f"/scene/block{i}", indexes=frame_idx,
                             columns=rr.LineStrips2D.columns(strips=_to_view(pts)).partition([1] * len(frames)))
        hatch = _ground_hatch(xg, yg, width)
        rec.log("/scene/ground", rr.LineStrips2D.from_fields(colors=[[90, 90, 90]]), static=True)
        rec.send_columns("/scene/ground", indexes=frame_idx,
                         columns=rr.LineStrips2D.columns(strips=_to_view(hatch.reshape(-1, 2, 2)).reshape(-1, 2, 2))
                         .partition([hatch.shape[1]] * len(frames)))
        for (block, piv), where in zip(pivots(at_frames, n_blocks).items(), pivot_points):
            rec.log(f"/scene/pivot/{block}", rr.Points2D.from_fields(colors=[(170, 40, 170)]), static=True)
            rec.send_columns(f"/scene/pivot/{block}", indexes=frame_idx,
                             columns=rr.Points2D.columns(positions=_to_view(where + offset[:, 0, :]),
                                                         radii=np.where(piv == 0, 0.0, 0.12 * b1)))  # none when flat
        # events at one instant (an impact and the settling it causes, say) share one entry, "; "-separated
        by_time: dict[float, list[str]] = {}
        for ev in events or []:
            values = " ".join(f"{k}={v:.6g}" for k, v in ev.values.items())
            labels = " ".join(f"{k}={v}" for k, v in ev.labels.items())
            by_time.setdefault(float(ev.t), []).append(f"{ev.kind} {labels} {values}".strip())
        for t_ev, texts in by_time.items():
            rec.set_time("sim_time", duration=_ns(t_ev))
            rec.log("/events", rr.TextLog("; ".join(texts), level="INFO"))
    return path


def write_sweep_recording(path: Path, factory, sweep_id: int, picture: bytes | None = None) -> Path:
    """One recording of a sweep: on a `grid_index` sequence, each point's grid values (and record,
    scale and intensity measures) and summary (overturned, impacts, peak / alpha), whether the
    point was recorded in full (runners sweep --record), and `picture`, a PNG of the sweep (its
    overturning map, or for a sweep over records its IDA curves: runners.analysis.sweep_map.
    sweep_picture draws it), at the first grid index (entity /map, or /ida for a sweep over records).

    Nothing large is static: Rerun's dataframe API joins static data to every row of a query,
    so ``dataset.reader(index="grid_index").to_arrow_table()`` of a 10,000-point sweep would
    repeat a static image 10,000 times (23 GB for an 880 x 660 RGBA map). Logged once at the
    first index, the viewer still shows it at every index (latest-at) and the read stays small
    (1.5 MB for 10,000 points; tests/test_recording.py)."""
    import rerun as rr

    from runners.engine.sweep_runs import load

    sw, scene, runs = load(factory, str(sweep_id))
    runs = sorted(runs, key=lambda r: r.grid_index)
    path = Path(path)
    with _stream(path) as rec:
        rec.send_property("sweep", rr.AnyValues(id=sw.id, scene=scene.name, total=sw.total))
        on_records = bool(sw.grid.get("records"))
        if picture is not None:
            # The picture is logged once, at the first grid index, and not static: the viewer shows it at every
            # later index (latest-at), while a dataframe query on grid_index carries it in one row only. Static
            # data is joined to every row of such a query (a 10,000-point sweep would repeat it 10,000 times).
            first = [rr.TimeColumn("grid_index", sequence=[min((r.grid_index for r in runs), default=0)])]
            rec.send_columns("/ida" if on_records else "/map", indexes=first,
                             columns=rr.EncodedImage.columns(blob=[picture], media_type=["image/png"]))
        idx = [rr.TimeColumn("grid_index", sequence=np.array([r.grid_index for r in runs], dtype=np.int64))]
        ok = [r.summary is not None for r in runs]
        columns = {
            "overturned": [float(r.summary.overturned) if r.summary else np.nan for r in runs],
            "impacts": [float(r.summary.impacts) if r.summary and r.summary.impacts is not None else np.nan
                        for r in runs],
            "peak1_over_alpha": [r.summary.peak1_over_alpha if r.summary and r.summary.peak1_over_alpha is not None
                                 else np.nan for r in runs],
            "failed": [0.0 if good else 1.0 for good in ok],
            "recorded": [1.0 if r.recording else 0.0 for r in runs],  # simulated in full, with its own recording
        }
        for axis in (a[0] for a in sw.grid["axes"]):
            columns[f"grid/{axis}"] = [r.point[axis] for r in runs]
        if on_records:  # each point's record (its id), scale and the scaled record's measures
            for key in ("record_id", "scale", "pga", "pgv", "pgd", "arias"):
                columns[f"grid/{key}"] = [r.point.get(key, np.nan) for r in runs]
        for name, values in columns.items():
            rec.send_columns(f"/points/{name}", indexes=idx,
                             columns=rr.Scalars.columns(scalars=np.asarray(values, float)))
    return path


@contextlib.contextmanager
def _stream(path: Path, blueprint=None) -> Iterator[Any]:
    """A RecordingStream of its own, saved to a temporary file beside ``path`` (its folder made if
    missing) that replaces ``path`` once the block has logged everything and the stream is flushed:
    a recording that cannot be written is a FileError, in one line naming it, and leaves ``path``
    as it was, with nothing half-written. ``blueprint``: the recording's default blueprint."""
    import rerun as rr

    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise FileError(f"cannot write the recording {path}: its folder cannot be made ({exc.strerror or exc})") \
            from None
    with staged({"the recording": path}) as tmp:
        rec = rr.RecordingStream("rocking", recording_id=str(uuid.uuid4()))
        try:
            _rerun_writes(path, lambda: rec.save(tmp["the recording"]))
            if blueprint is not None:  # sent once the file is open: a failed save leaves no blueprint behind
                rec.send_blueprint(blueprint, make_active=False, make_default=True)
            yield rec
            _rerun_writes(path, rec.flush)
        finally:
            rec.disconnect()


def _rerun_writes(path: Path, call) -> None:
    """``call()``, a save or flush of a Rerun stream: its failure to write the file (a full disk, a
    file system that refuses it) a FileError in one line naming ``path``."""
    try:
        call()
    except RuntimeError as exc:
        raise FileError(f"cannot write the recording {path}: {(str(exc).splitlines() or [type(exc).__name__])[0]}") \
            from None
