"""Independent Python reference: rocking of one rigid convex body whose centre of
mass is off the centre of its base, on a rigid ground (no sliding, no flight).

Geometry (body frame, rest pose): x right, y up, base on ``y = 0`` with base
corners ``L = (xL, 0)`` and ``R = (xR, 0)``, ``xL < xR``; centre of mass
``G = (xG, yG)`` with ``xL < xG < xR`` and ``yG > 0``; mass ``m``; moment of
inertia ``IG`` about ``G``.  Per corner::

    bR = xR - xG,  rho_R = |G - R|,  alpha_R = atan(bR / yG),  I_R = IG + m rho_R**2
    bL = xG - xL,  rho_L = |G - L|,  alpha_L = atan(bL / yG),  I_L = IG + m rho_L**2

Signs follow docs/conventions.md: ``theta > 0`` is a clockwise rotation about
the right corner R, ``theta < 0`` a counter-clockwise rotation about the left
corner L; ``a_h > 0`` accelerates the ground towards ``+x``; ``a_v > 0``
accelerates it upwards (effective gravity ``g + a_v``).

Derivation (done from scratch here).  Rotating the body clockwise by ``theta``
about its pivot puts ``G`` at ``G - P = rho (sin(theta - s alpha),
cos(theta - s alpha))`` relative to the pivot ``P``, with ``s = +1`` on R and
``s = -1`` on L.  In the frame of the ground (translating with acceleration
``(a_h, a_v)``) the body has kinetic energy ``T = I_P thetadot**2 / 2`` and
potential ``V = m (g + a_v) y_G + m a_h x_G`` (gravity plus the d'Alembert
force ``-m a``).  Lagrange's equation gives::

    I_P thetaddot = m rho [(g + a_v) sin(theta - s alpha) - a_h cos(theta - s alpha)]

the nonlinear equation of Housner (1963) generalised to unequal corners (cf.
Yim, Chopra & Penzien 1980 and Makris & Konstantinidis 2003 for the rectangle).
At rest (``theta = 0``) the right-hand side on R becomes positive (uplift onto
R) when ``a_h < -(g + a_v) bR / yG``, and on L negative when
``a_h > (g + a_v) bL / yG``.

Impact.  When the body rocking on one corner returns to ``theta = 0`` the base
strikes the ground; we take the impact as plastic with the new corner sticking
and the old one releasing (Housner 1963).  The impulse acts through the new
corner, so the angular momentum about it is conserved.  Before the impact, on
the old pivot ``O`` with counter-clockwise rate ``Omega``, ``v_G = Omega z x
(G - O)`` and the angular momentum about the new pivot ``N`` is
``H_N = IG Omega + m (G - N) x v_G = Omega [IG + m (G - N).(G - O)]``.  After,
``H_N = I_N Omega'``.  Hence the ratio of angular velocities after/before::

    r = thetadot+ / thetadot- = (IG + m (yG**2 - bL bR)) / (IG + m rho_N**2)

with ``rho_N`` the distance from G to the *new* pivot.  For a rectangle
(``bL = bR = b``, ``yG = h``, ``IG = m rho**2 / 3``) this is
``(1 + 3 cos 2 alpha) / 4 = 1 - (3/2) sin**2 alpha``, Housner's (1963) ratio.
The law is only consistent while ``r > 0``; by Cauchy-Schwarz
``r**2 I_N <= I_O`` so the impact never creates energy.

Free rocking.  Each side is an inverted pendulum; with ``u = s alpha - theta``
(so ``|u|`` is the angle of ``G - P`` from the vertical) the energy integral
reads ``thetadot**2 = K (cos u_p - cos u)``, ``K = 2 m g rho / I_P``, ``u_p`` at
the peak.  Times follow from ``dt = dtheta / |thetadot|`` by quadrature with
the substitution ``|u| = u_p + sigma**2`` which removes the inverse square-root
singularity at the peak; equivalently (used in the tests) in closed form with
incomplete elliptic integrals of the first kind (Byrd & Friedman 1971).

Uniform polygons: shoelace area, centroid and second moments of area
(e.g. Bourke 1988; Steger 1996).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import quad, solve_ivp

__all__ = [
    "RockingBody",
    "uniform_polygon_properties",
    "convex_hull",
    "landing_angles",
    "body_from_polygon",
    "pivot_geometry",
    "uplift_thresholds",
    "angular_acceleration",
    "impact_ratio",
    "apply_impact",
    "com_position",
    "potential_energy",
    "kinetic_energy",
    "total_energy",
    "peak_angle",
    "rocking_time",
    "FreeRockingResult",
    "free_rocking",
    "sine_pulse",
    "RockingSimulation",
    "simulate_rocking",
    "simulate_sine_pulse",
]

G_DEFAULT = 9.81  # m/s^2, the project's model gravity


# ---------------------------------------------------------------------------
# body description
# ---------------------------------------------------------------------------

@dataclass(frozen=True)
class RockingBody:
    """A rigid body resting on its base edge in its rest pose (body frame).

    Attributes
    ----------
    xL, xR : float
        x of the left and right base corners, m (``xL < xR``; base on y = 0).
    xG, yG : float
        Centre of mass, m (``xL < xG < xR``, ``yG > 0``).
    m : float
        Mass, kg.
    IG : float
        Moment of inertia about the centre of mass, kg m^2.
    beta_left, beta_right : float
        Magnitudes of the rotations (rad, > 0) at which the hull edge adjacent
        to the left / right corner lands on the ground (``theta = -beta_left``,
        ``theta = +beta_right``); ``math.inf`` if unknown.  The rocking model
        is only valid for ``-beta_left < theta < beta_right``.
    """

    xL: float
    xR: float
    xG: float
    yG: float
    m: float
    IG: float
    beta_left: float = math.inf
    beta_right: float = math.inf

    def __post_init__(self) -> None:
        if not (self.xL < self.xG < self.xR):
            raise ValueError("need xL < xG < xR")
        if not (self.yG > 0 and self.m > 0 and self.IG > 0):
            raise ValueError("need yG > 0, m > 0, IG > 0")

    @property
    def bL(self) -> float:
        """Horizontal distance from the left corner to G, m (> 0)."""
        return self.xG - self.xL

    @property
    def bR(self) -> float:
        """Horizontal distance from G to the right corner, m (> 0)."""
        return self.xR - self.xG


def uniform_polygon_properties(vertices: Sequence[Sequence[float]], m: float
                               ) -> tuple[float, tuple[float, float], float]:
    """Area, centroid and centroidal polar moment of inertia of a uniform lamina.

    Parameters
    ----------
    vertices : sequence of (x, y)
        Polygon vertices in order (either orientation), m.  Simple polygon.
    m : float
        Total mass, kg.

    Returns
    -------
    area : float
        Area, m^2 (> 0).
    centroid : (float, float)
        Centroid (= centre of mass), m.
    IG : float
        Polar moment of inertia about the centroid, kg m^2
        (``m / area * integral of |r - c|^2 dA``).
    """
    p = np.asarray(vertices, dtype=float)
    x, y = p[:, 0], p[:, 1]
    # shift to the first vertex to limit cancellation
    x0, y0 = x[0], y[0]
    x, y = x - x0, y - y0
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    cr = x * yn - xn * y
    a2 = cr.sum()  # twice the signed area
    if a2 == 0.0:
        raise ValueError("degenerate polygon")
    cx = ((x + xn) * cr).sum() / (3.0 * a2)
    cy = ((y + yn) * cr).sum() / (3.0 * a2)
    # second moments about the (shifted) origin, signed like a2
    ixx = ((y * y + y * yn + yn * yn) * cr).sum() / 12.0  # integral y^2 dA
    iyy = ((x * x + x * xn + xn * xn) * cr).sum() / 12.0  # integral x^2 dA
    area = 0.5 * a2
    j_origin = (ixx + iyy) / area  # per unit area, sign cancels
    j_centroid = j_origin - (cx * cx + cy * cy)
    return abs(area), (cx + x0, cy + y0), m * j_centroid


def convex_hull(vertices: Sequence[Sequence[float]]) -> np.ndarray:
    """Convex hull, counter-clockwise, without collinear points (Andrew 1979).

    Parameters
    ----------
    vertices : sequence of (x, y), m.

    Returns
    -------
    ndarray of shape (k, 2): hull vertices in counter-clockwise order.
    """
    pts = sorted({(float(a), float(b)) for a, b in vertices})
    if len(pts) < 3:
        raise ValueError("need at least three distinct points")

    def cross(o, a, b) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list[tuple[float, float]] = []
    for q in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], q) <= 0:
            lower.pop()
        lower.append(q)
    upper: list[tuple[float, float]] = []
    for q in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], q) <= 0:
            upper.pop()
        upper.append(q)
    return np.array(lower[:-1] + upper[:-1])


def _base_corners(hull: np.ndarray) -> tuple[int, int]:
    """Indices (iL, iR) of the base corners (lowest edge) of a ccw hull."""
    ymin = hull[:, 1].min()
    tol = 1e-12 * max(1.0, float(np.ptp(hull)))
    low = np.flatnonzero(hull[:, 1] <= ymin + tol)
    if len(low) != 2:
        raise ValueError("the hull's lowest points must form one horizontal base edge")
    i0, i1 = low
    return (i0, i1) if hull[i0, 0] < hull[i1, 0] else (i1, i0)


def landing_angles(vertices: Sequence[Sequence[float]]) -> tuple[float, float]:
    """Rotations at which the hull edge next to each base corner lands on the ground.

    The body is given in its rest pose with a horizontal lowest edge (the base).
    For the right corner R the adjacent hull edge goes up from R at an angle
    ``phi`` above +x; rotating clockwise by ``phi = pi - interior angle at R``
    lays it on the ground.  Likewise for the left corner (counter-clockwise).

    Parameters
    ----------
    vertices : sequence of (x, y), m.

    Returns
    -------
    beta_left, beta_right : float
        Magnitudes in rad (> 0): the edge lands at ``theta = -beta_left``
        (about L) and ``theta = +beta_right`` (about R); pi/2 for a rectangle.
    """
    hull = convex_hull(vertices)
    n = len(hull)
    iL, iR = _base_corners(hull)
    # ccw order: ... L -> R -> next(R) ... prev(L) -> L
    nxt = hull[(iR + 1) % n] - hull[iR]
    prv = hull[(iL - 1) % n] - hull[iL]
    beta_right = math.atan2(nxt[1], nxt[0])          # pi - interior angle at R
    beta_left = math.pi - math.atan2(prv[1], prv[0])  # pi - interior angle at L
    return beta_left, beta_right


def body_from_polygon(vertices: Sequence[Sequence[float]], m: float) -> RockingBody:
    """A :class:`RockingBody` for a uniform convex polygon resting on its lowest edge.

    The polygon is translated so that its base lies on ``y = 0`` (x unchanged).

    Parameters
    ----------
    vertices : sequence of (x, y)
        Vertices of a convex polygon, m.
    m : float
        Mass, kg.
    """
    hull = convex_hull(vertices)
    iL, iR = _base_corners(hull)
    y0 = hull[iL, 1]
    _, (cx, cy), IG = uniform_polygon_properties(hull, m)
    bl, br = landing_angles(hull)
    return RockingBody(xL=float(hull[iL, 0]), xR=float(hull[iR, 0]), xG=float(cx),
                       yG=float(cy - y0), m=m, IG=float(IG), beta_left=bl, beta_right=br)


def _side(theta: float, omega: float = 0.0) -> int:
    """Pivot side: +1 (right corner) for theta > 0, -1 (left) for theta < 0.

    At theta == 0 the direction of motion decides (omega >= 0 -> right)."""
    if theta > 0:
        return 1
    if theta < 0:
        return -1
    return 1 if omega >= 0 else -1


def pivot_geometry(body: RockingBody, side: int) -> tuple[float, float, float]:
    """Distance, angle and inertia for rocking about one corner.

    Parameters
    ----------
    body : RockingBody
    side : int
        +1 for the right corner (theta > 0), -1 for the left corner (theta < 0).

    Returns
    -------
    rho : float
        ``|G - pivot|``, m.
    alpha : float
        Angle of ``G - pivot`` from the vertical at rest, rad (> 0); the body
        is balanced over the pivot at ``|theta| = alpha``.
    I_pivot : float
        ``IG + m rho**2``, kg m^2.
    """
    b = body.bR if side > 0 else body.bL
    rho = math.hypot(b, body.yG)
    return rho, math.atan2(b, body.yG), body.IG + body.m * rho * rho


# ---------------------------------------------------------------------------
# 1. uplift thresholds; 2. equation of motion
# ---------------------------------------------------------------------------

def uplift_thresholds(body: RockingBody, g: float = G_DEFAULT, a_v: float = 0.0
                      ) -> tuple[float, float]:
    """Ground accelerations at which the body at rest starts to rock.

    From the moment balance about each corner (no sliding):

    * onto the **right** corner (``theta > 0``) when ``a_h < a_right``,
      ``a_right = -(g + a_v) bR / yG < 0``;
    * onto the **left** corner (``theta < 0``) when ``a_h > a_left``,
      ``a_left = +(g + a_v) bL / yG > 0``.

    Parameters
    ----------
    body : RockingBody
    g : float
        Gravity, m/s^2.
    a_v : float
        Vertical ground acceleration, m/s^2 (> 0 upwards).

    Returns
    -------
    a_right, a_left : float
        Signed horizontal ground accelerations, m/s^2 (``a_h > 0`` towards +x).
    """
    ge = g + a_v
    return -ge * body.bR / body.yG, ge * body.bL / body.yG


def angular_acceleration(body: RockingBody, theta: float, a_h: float = 0.0,
                         a_v: float = 0.0, g: float = G_DEFAULT,
                         side: int | None = None) -> float:
    """``thetaddot`` while rocking on one corner, rad/s^2.

    ``I_P thetaddot = m rho [(g + a_v) sin(theta - s alpha) - a_h cos(theta - s alpha)]``
    with ``s = +1`` on the right corner, ``-1`` on the left.

    Parameters
    ----------
    body : RockingBody
    theta : float
        Rotation, rad (> 0 clockwise about R, < 0 counter-clockwise about L).
    a_h, a_v : float
        Ground accelerations, m/s^2 (+x, up).
    g : float
        Gravity, m/s^2.
    side : int, optional
        Pivot (+1 right, -1 left); by default from the sign of theta
        (right at theta = 0).
    """
    s = _side(theta) if side is None else side
    rho, alpha, ip = pivot_geometry(body, s)
    phi = theta - s * alpha
    return body.m * rho * ((g + a_v) * math.sin(phi) - a_h * math.cos(phi)) / ip


# ---------------------------------------------------------------------------
# 3. impact
# ---------------------------------------------------------------------------

def impact_ratio(body: RockingBody, new_side: int) -> float:
    """Ratio ``thetadot+ / thetadot-`` at an impact onto the corner ``new_side``.

    Plastic impact: the new corner sticks, the old one releases; angular
    momentum about the new corner is conserved::

        r = (IG + m (yG**2 - bL bR)) / (IG + m rho_new**2)

    For a rectangle ``r = 1 - (3/2) sin**2 alpha`` (Housner 1963).

    Parameters
    ----------
    body : RockingBody
    new_side : int
        +1 if the body continues on the right corner (it was rocking on the
        left one with ``thetadot > 0``), -1 if it continues on the left corner.

    Returns
    -------
    float
        The ratio (< 1; the law is inconsistent if it is <= 0).
    """
    rho, _, ip = pivot_geometry(body, new_side)
    return (body.IG + body.m * (body.yG ** 2 - body.bL * body.bR)) / ip


def apply_impact(body: RockingBody, omega_before: float) -> float:
    """Angular velocity just after an impact at ``theta = 0``, rad/s.

    ``omega_before > 0`` means the body was on the left corner moving
    clockwise and continues on the right corner; ``< 0`` the reverse.
    """
    return impact_ratio(body, 1 if omega_before > 0 else -1) * omega_before


# ---------------------------------------------------------------------------
# 6. energy
# ---------------------------------------------------------------------------

def com_position(body: RockingBody, theta: float) -> tuple[float, float]:
    """Position of the centre of mass for a rotation ``theta``, m.

    Returns ``(x, y)`` of G in a frame fixed to the ground that coincides with
    the body frame at rest (no sliding), for the rotation ``theta`` (rad) about
    the corner its sign implies (the right one at ``theta = 0``).
    """
    s = _side(theta)
    rho, alpha, _ = pivot_geometry(body, s)
    px = body.xR if s > 0 else body.xL
    return px + rho * math.sin(theta - s * alpha), rho * math.cos(theta - s * alpha)


def potential_energy(body: RockingBody, theta: float, g: float = G_DEFAULT,
                     a_h: float = 0.0, a_v: float = 0.0) -> float:
    """Potential energy ``m (g + a_v) y_G + m a_h (x_G - xG)``, J.

    Zero of height at the ground; the horizontal term (the d'Alembert force of
    the ground acceleration, measured from the rest position) vanishes in free
    rocking.  At ``theta = 0`` it is ``m g yG``.
    """
    x, y = com_position(body, theta)
    return body.m * ((g + a_v) * y + a_h * (x - body.xG))


def kinetic_energy(body: RockingBody, theta: float, omega: float) -> float:
    """Kinetic energy relative to the ground ``I_P omega**2 / 2``, J (pivot from theta)."""
    _, _, ip = pivot_geometry(body, _side(theta, omega))
    return 0.5 * ip * omega * omega


def total_energy(body: RockingBody, theta: float, omega: float, g: float = G_DEFAULT) -> float:
    """Kinetic plus gravitational potential energy (free rocking), J."""
    return kinetic_energy(body, theta, omega) + potential_energy(body, theta, g)


# ---------------------------------------------------------------------------
# 4. free rocking by energy and quadrature
# ---------------------------------------------------------------------------

def _peak_u(body: RockingBody, side: int, theta: float, omega: float, g: float
            ) -> float:
    """|u| at the peak on ``side`` (angle of G - pivot from the vertical), rad.

    Returns a negative number if the body overturns (passes over the pivot)."""
    rho, alpha, ip = pivot_geometry(body, side)
    u = alpha - side * theta  # >= 0 on the own side up to the balance point
    # 1 - cos u_p = (1 - cos u) - I omega^2 / (2 m g rho), written with half angles
    one_minus_c = 2.0 * math.sin(0.5 * u) ** 2 - ip * omega * omega / (2.0 * body.m * g * rho)
    if one_minus_c < 0:
        return -1.0
    return 2.0 * math.asin(math.sqrt(0.5 * one_minus_c))


def peak_angle(body: RockingBody, theta: float, omega: float, g: float = G_DEFAULT,
               side: int | None = None) -> float:
    """Extreme rotation reached in free rocking on the current corner, rad.

    Energy conservation on the pivot ``side`` (default: from the signs of
    theta, omega): ``I_P omega**2 / 2 + m g rho cos(theta - s alpha) =
    m g rho cos(theta_p - s alpha)``.

    Returns ``theta_p`` with the sign of the side (``|theta_p| < alpha``), or
    raises ``ValueError`` if the energy is enough to overturn the body.
    """
    s = _side(theta, omega) if side is None else side
    _, alpha, _ = pivot_geometry(body, s)
    up = _peak_u(body, s, theta, omega, g)
    if up < 0:
        raise ValueError("the body overturns")
    return s * (alpha - up)


def rocking_time(body: RockingBody, side: int, theta_a: float, theta_b: float,
                 theta_peak: float, g: float = G_DEFAULT, epsrel: float = 1e-13) -> float:
    """Time to travel between two angles on one corner in free rocking, s.

    ``t = integral dtheta / |thetadot(theta)|`` with ``thetadot**2 =
    K (cos u_p - cos u)``, ``u = alpha - s theta``, ``K = 2 m g rho / I_P``.
    With ``u = u_p + sigma**2`` the integrand
    ``2 / sqrt(K * 2 sin(u_p + sigma**2/2) * sin(sigma**2/2) / sigma**2)`` is
    smooth at the peak (``sigma = 0``).  Integrated with ``scipy.integrate.quad``.

    Parameters
    ----------
    body : RockingBody
    side : int
        +1 right corner (angles >= 0), -1 left corner (angles <= 0).
    theta_a, theta_b : float
        The two angles, rad, between 0 and ``theta_peak`` (order irrelevant).
    theta_peak : float
        The peak on this side, rad (same sign as ``side``).
    g : float
        Gravity, m/s^2.
    epsrel : float
        Relative tolerance of quad (at least 50 machine epsilons).
    """
    rho, alpha, ip = pivot_geometry(body, side)
    k = 2.0 * body.m * g * rho / ip
    up = alpha - side * theta_peak
    da = side * (theta_peak - theta_a)
    db = side * (theta_peak - theta_b)
    if da < -1e-15 or db < -1e-15:
        raise ValueError("angles beyond the peak")
    sa, sb = math.sqrt(max(da, 0.0)), math.sqrt(max(db, 0.0))

    def f(sig: float) -> float:
        x = 0.5 * sig * sig
        # sin(x) / sig^2 = 0.5 * sinc(x/pi)
        h = 0.5 * float(np.sinc(x / math.pi))
        return 2.0 / math.sqrt(2.0 * k * math.sin(up + x) * h)

    lo, hi = min(sa, sb), max(sa, sb)
    if hi == lo:
        return 0.0
    val, _ = quad(f, lo, hi, epsabs=0.0, epsrel=epsrel, limit=200)
    return val


@dataclass
class FreeRockingResult:
    """Events of free rocking.

    Attributes
    ----------
    impact_times : list of float
        Times of the impacts (theta = 0), s.
    omega_before, omega_after : list of float
        Angular velocities just before / after each impact, rad/s.
    peak_times : list of float
        Times of the extreme rotations, s.
    peak_thetas : list of float
        The extreme rotations, rad (signed).
    status : str
        "t_end" (duration reached), "max_impacts", "at_rest" (|omega| after
        an impact below the threshold), "overturns", "side_lands" (a peak
        would exceed a landing angle) or "impact_law_invalid" (ratio <= 0).
    """

    impact_times: list[float] = field(default_factory=list)
    omega_before: list[float] = field(default_factory=list)
    omega_after: list[float] = field(default_factory=list)
    peak_times: list[float] = field(default_factory=list)
    peak_thetas: list[float] = field(default_factory=list)
    status: str = "t_end"


def free_rocking(body: RockingBody, theta0: float, omega0: float, t_end: float,
                 g: float = G_DEFAULT, max_impacts: int = 1000,
                 omega_rest: float = 1e-9) -> FreeRockingResult:
    """Free rocking (``a_h = a_v = 0``) from ``(theta0, omega0)`` by energy and quadrature.

    Peaks come from energy conservation on each corner separately, the times
    between events from :func:`rocking_time`, the impacts from
    :func:`impact_ratio`.  The sequence of impacts accumulates at a finite
    time, so it is cut when ``|omega|`` after an impact falls below
    ``omega_rest`` (status "at_rest") or after ``max_impacts``.

    Parameters
    ----------
    body : RockingBody
    theta0 : float
        Initial rotation, rad.
    omega0 : float
        Initial angular velocity, rad/s (> 0 clockwise).  At ``theta0 = 0``
        its sign selects the corner; ``omega0 = 0`` with ``theta0 != 0``
        starts at a peak (reported at t = 0).
    t_end : float
        Duration, s; only events with ``t <= t_end`` are reported.
    g : float
        Gravity, m/s^2.
    max_impacts : int
    omega_rest : float
        rad/s.
    """
    res = FreeRockingResult()
    if theta0 == 0.0 and omega0 == 0.0:
        res.status = "at_rest"
        return res
    s = _side(theta0, omega0)
    t = 0.0
    theta, omega = theta0, omega0
    while True:
        beta = body.beta_right if s > 0 else body.beta_left
        up = _peak_u(body, s, theta, omega, g)
        if up < 0:
            res.status = "overturns"
            return res
        _, alpha, _ = pivot_geometry(body, s)
        thp = s * (alpha - up)
        if abs(thp) >= beta:
            res.status = "side_lands"
            return res
        outward = omega * s > 0 or (omega == 0.0 and theta != 0.0)
        if outward:
            t_peak = t + rocking_time(body, s, theta, thp, thp, g)
            if t_peak > t_end:
                return res
            res.peak_times.append(t_peak)
            res.peak_thetas.append(thp)
            t_imp = t_peak + rocking_time(body, s, thp, 0.0, thp, g)
            w_before = -s * math.sqrt(_omega_sq(body, s, 0.0, thp, g))
        else:
            t_imp = t + rocking_time(body, s, theta, 0.0, thp, g)
            w_before = omega / abs(omega) * math.sqrt(_omega_sq(body, s, 0.0, thp, g))
        if t_imp > t_end:
            return res
        r = impact_ratio(body, -s)
        if r <= 0:
            res.status = "impact_law_invalid"
            return res
        w_after = r * w_before
        res.impact_times.append(t_imp)
        res.omega_before.append(w_before)
        res.omega_after.append(w_after)
        if len(res.impact_times) >= max_impacts:
            res.status = "max_impacts"
            return res
        if abs(w_after) < omega_rest:
            res.status = "at_rest"
            return res
        t, theta, omega, s = t_imp, 0.0, w_after, -s


def _omega_sq(body: RockingBody, side: int, theta: float, theta_peak: float, g: float
              ) -> float:
    """thetadot**2 at ``theta`` given the peak on ``side`` (free rocking), rad^2/s^2.

    ``K (cos u_p - cos u) = 2 K sin((u + u_p)/2) sin((u - u_p)/2)``."""
    rho, alpha, ip = pivot_geometry(body, side)
    k = 2.0 * body.m * g * rho / ip
    u, up = alpha - side * theta, alpha - side * theta_peak
    return 2.0 * k * math.sin(0.5 * (u + up)) * math.sin(0.5 * (u - up))


# ---------------------------------------------------------------------------
# 5. time stepping with solve_ivp
# ---------------------------------------------------------------------------

def sine_pulse(A: float, f: float, t0: float = 0.0) -> Callable[[float], float]:
    """One cycle ``a(t) = A sin(2 pi f (t - t0))`` for ``t0 <= t <= t0 + 1/f``, else 0.

    ``A`` in m/s^2 (``A > 0`` first pushes the ground to +x), ``f`` in Hz.
    """
    def a(t: float) -> float:
        tau = t - t0
        return A * math.sin(2.0 * math.pi * f * tau) if 0.0 <= tau <= 1.0 / f else 0.0
    return a


def _zero(t: float) -> float:
    return 0.0


@dataclass
class RockingSimulation:
    """Result of :func:`simulate_rocking`.

    Attributes
    ----------
    impact_times, omega_before, omega_after : list of float
        Impacts (s, rad/s, rad/s).
    peak_times, peak_thetas : list of float
        Local extrema of ``|theta|`` (s, rad).
    uplift_times, uplift_sides : list
        Times (s) the body left rest and the corner (+1 right, -1 left).
    rest_times : list of float
        Times (s) the body came to rest (``|omega|`` after an impact below
        ``omega_rest``).
    max_abs_theta : float
        Largest ``|theta|``, rad.
    theta_end, omega_end : float
        State at the end, rad, rad/s.
    status : str
        "t_end", "side_lands" (|theta| reached a landing angle),
        "overturned" (|theta| reached pi, landing angles unknown),
        "impact_law_invalid" or "max_events".
    segments : list
        ``(side, t_start, t_stop, OdeSolution or None)`` for each rocking or
        rest segment (``side = 0`` at rest, no solution); evaluate the dense
        output only on ``[t_start, t_stop]`` (it runs on past an impact).
    """

    impact_times: list[float] = field(default_factory=list)
    omega_before: list[float] = field(default_factory=list)
    omega_after: list[float] = field(default_factory=list)
    peak_times: list[float] = field(default_factory=list)
    peak_thetas: list[float] = field(default_factory=list)
    uplift_times: list[float] = field(default_factory=list)
    uplift_sides: list[int] = field(default_factory=list)
    rest_times: list[float] = field(default_factory=list)
    max_abs_theta: float = 0.0
    theta_end: float = 0.0
    omega_end: float = 0.0
    status: str = "t_end"
    segments: list = field(default_factory=list)


def simulate_rocking(body: RockingBody, t_end: float, g: float = G_DEFAULT,
                     a_h: Callable[[float], float] = _zero,
                     a_v: Callable[[float], float] = _zero,
                     theta0: float = 0.0, omega0: float = 0.0,
                     t_breaks: Sequence[float] = (), rtol: float = 1e-12,
                     atol: float = 1e-14, omega_rest: float = 1e-9,
                     max_step_rest: float = 1e-3, max_events: int = 10000
                     ) -> RockingSimulation:
    """Time-step the rocking with ``solve_ivp`` (DOP853) and events.

    On a corner the state ``(theta, thetadot)`` follows
    :func:`angular_acceleration`; a terminal event at ``theta = 0`` applies
    :func:`impact_ratio` and switches corners; a non-terminal event at
    ``thetadot = 0`` (moving back towards 0) records peaks.  If ``|thetadot|``
    after an impact is below ``omega_rest`` the body is put at rest; at rest
    terminal events detect ``a_h(t)`` crossing the thresholds of
    :func:`uplift_thresholds` (with ``g + a_v(t)``).

    Parameters
    ----------
    body : RockingBody
    t_end : float
        Final time, s.
    g : float
        Gravity, m/s^2.
    a_h, a_v : callable
        Ground accelerations ``a(t)``, m/s^2 (+x, up).
    theta0, omega0 : float
        Initial state, rad, rad/s (both 0: at rest).
    t_breaks : sequence of float
        Times where ``a_h`` or ``a_v`` are not smooth (e.g. the end of a pulse);
        the integration is restarted there.
    rtol, atol : float
        solve_ivp tolerances.
    omega_rest : float
        rad/s, see above.
    max_step_rest : float
        Largest step while at rest (so that threshold crossings are not
        stepped over), s.
    max_events : int
        Safety limit on impacts + uplifts.
    """
    res = RockingSimulation()
    breaks = sorted(tb for tb in t_breaks if 0.0 < tb < t_end) + [t_end]
    t, theta, omega = 0.0, float(theta0), float(omega0)
    side = 0 if (theta == 0.0 and omega == 0.0) else _side(theta, omega)
    if side != 0 and omega == 0.0 and theta != 0.0:
        res.peak_times.append(0.0)
        res.peak_thetas.append(theta)
    res.max_abs_theta = abs(theta)
    n_events = 0

    def next_break(tt: float) -> float:
        for tb in breaks:
            if tb > tt:
                return tb
        return t_end

    while t < t_end:
        if n_events > max_events:
            res.status = "max_events"
            break
        t_stop = next_break(t)
        if side == 0:
            # at rest: wait for the ground acceleration to pass a threshold
            def e_right(tt, y):  # < 0 -> uplift onto the right corner
                return a_h(tt) + (g + a_v(tt)) * body.bR / body.yG
            e_right.terminal, e_right.direction = True, -1

            def e_left(tt, y):  # > 0 -> uplift onto the left corner
                return a_h(tt) - (g + a_v(tt)) * body.bL / body.yG
            e_left.terminal, e_left.direction = True, 1

            if e_right(t, None) < 0:
                side = 1
            elif e_left(t, None) > 0:
                side = -1
            if side != 0:
                res.uplift_times.append(t)
                res.uplift_sides.append(side)
                n_events += 1
                continue
            sol = solve_ivp(lambda tt, y: [0.0], (t, t_stop), [0.0], method="DOP853",
                            events=(e_right, e_left), max_step=max_step_rest,
                            rtol=rtol, atol=atol)
            t_seg0 = t
            if sol.status == 1:
                if len(sol.t_events[0]):
                    t, side = float(sol.t_events[0][0]), 1
                else:
                    t, side = float(sol.t_events[1][0]), -1
                res.uplift_times.append(t)
                res.uplift_sides.append(side)
                n_events += 1
            else:
                t = t_stop
            res.segments.append((0, t_seg0, t, None))
            continue

        s = side
        beta = body.beta_right if s > 0 else body.beta_left
        lim = min(beta, math.pi)

        def rhs(tt, y, s=s):
            return [y[1], angular_acceleration(body, y[0], a_h(tt), a_v(tt), g, side=s)]

        def e_impact(tt, y):
            return y[0]
        e_impact.terminal, e_impact.direction = True, -s

        def e_peak(tt, y):
            return y[1]
        e_peak.terminal, e_peak.direction = False, -s

        def e_land(tt, y, s=s):
            return s * y[0] - lim
        e_land.terminal, e_land.direction = True, 1

        t_seg0 = t
        sol = solve_ivp(rhs, (t, t_stop), [theta, omega], method="DOP853",
                        events=(e_impact, e_peak, e_land), dense_output=True,
                        rtol=rtol, atol=atol)
        res.segments.append((s, t_seg0, float(sol.t[-1]), sol.sol))
        res.max_abs_theta = max(res.max_abs_theta, float(np.max(np.abs(sol.y[0]))))
        for tp, yp in zip(sol.t_events[1], sol.y_events[1]):
            if tp > t_seg0:
                res.peak_times.append(float(tp))
                res.peak_thetas.append(float(yp[0]))
                res.max_abs_theta = max(res.max_abs_theta, abs(float(yp[0])))
        if sol.status == 1 and len(sol.t_events[2]):
            t = float(sol.t_events[2][0])
            theta, omega = (float(v) for v in sol.y_events[2][0])
            res.status = "side_lands" if beta <= math.pi else "overturned"
            break
        if sol.status == 1 and len(sol.t_events[0]):
            t = float(sol.t_events[0][0])
            w_before = float(sol.y_events[0][0][1])
            r = impact_ratio(body, -s)
            res.impact_times.append(t)
            res.omega_before.append(w_before)
            n_events += 1
            if r <= 0:
                res.omega_after.append(float("nan"))
                res.status = "impact_law_invalid"
                theta, omega = 0.0, w_before
                break
            w_after = r * w_before
            res.omega_after.append(w_after)
            theta = 0.0
            if abs(w_after) < omega_rest:
                omega, side = 0.0, 0
                res.rest_times.append(t)
            else:
                omega, side = w_after, -s
            continue
        t = float(sol.t[-1])
        theta, omega = float(sol.y[0, -1]), float(sol.y[1, -1])
    res.theta_end, res.omega_end = theta, omega
    return res


def simulate_sine_pulse(body: RockingBody, A: float, f: float, t_end: float,
                        g: float = G_DEFAULT, **kwargs) -> RockingSimulation:
    """Response to one cycle of ``a_h = A sin(2 pi f t)`` (``a_v = 0``) from rest.

    Parameters
    ----------
    body : RockingBody
    A : float
        Amplitude, m/s^2 (> 0 first pushes the ground to +x).
    f : float
        Frequency, Hz; the pulse lasts ``1/f`` s and is 0 afterwards.
    t_end : float
        Duration, s.
    g : float
        Gravity, m/s^2.
    **kwargs
        Passed to :func:`simulate_rocking`.
    """
    return simulate_rocking(body, t_end, g, a_h=sine_pulse(A, f), t_breaks=[1.0 / f],
                            **kwargs)
