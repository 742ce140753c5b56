"""Event-driven reference for two stacked blocks (independent of the C core).

scipy's solve_ivp integrates the Jacobian-form equations of model/two_blocks.py
between events; impacts, overturning and the opening of closed contacts are
its terminal events, and the pattern rules of docs/two_blocks.md decide what
happens at each (uplift from rest by a static check of the candidates, the
momentum map with impulse admissibility, constant restitution as a kinetic
energy ratio, settling of negligible rebounds). State q = (theta1, theta2),
w = q', absolute clockwise rotations in rad; SI units.
"""

from __future__ import annotations

import bisect
import math
import time
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from model import two_blocks as tb
from model.solvers import Ground, no_ground

TOL_OPEN = 1e-9  # a closed contact opens once its margin falls below -TOL_OPEN
# Impacts are events of s * gap + GAP_EPS falling through 0: the gap is exactly 0 when
# the integration restarts after an impact, and solve_ivp would report that start as a root.
GAP_EPS = 1e-15  # rad


@dataclass(frozen=True)
class StackScene:
    stack: tb.Stack
    law: str = "momentum"  # or "constant"
    eta_ground: float = 0.95  # constant law: kinetic energy ratio eta^2 per impact
    eta_interface: float = 0.98
    theta0: tuple[float, float] = (0.0, 0.0)  # rad, absolute
    omega0: tuple[float, float] = (0.0, 0.0)  # rad/s
    ground: Ground = no_ground
    breaks: tuple[float, ...] = ()
    rest_ratio: float = 1e-6


@dataclass
class StackEvent:
    kind: str  # impact, settle, open, uplift, overturn
    t: float
    contact: str = ""  # ground or interface
    pattern: str = ""  # the pattern after the event


@dataclass
class StackSolution:
    events: list[StackEvent] = field(default_factory=list)
    overturned: tuple[bool, bool] = (False, False)
    pattern: str = "rest"
    max_abs_theta: tuple[float, float] = (0.0, 0.0)
    wall_time: float = 0.0

    def impacts(self, contact: str | None = None) -> list[float]:
        return [e.t for e in self.events if e.kind == "impact" and (contact is None or e.contact == contact)]


class _Stack:
    def __init__(self, scene: StackScene):
        self.sc = scene
        st = self.st = scene.stack
        self.yG = (st.m1 * st.h1 + st.m2 * (2 * st.h1 + st.h2)) / (st.m1 + st.m2)
        self.kappa = min(st.b1 / self.yG, st.c / st.h2)
        M0 = tb.mass_matrix(st, np.zeros(2), 1, 1)
        self.I_pair = float(M0.sum())  # the pair about a corner of block 1
        self.R_I = math.hypot(st.c, st.h2)
        self.I_upper = st.Ic2 + st.m2 * self.R_I**2

    def settle_rate(self, interface: bool, av: float) -> float:
        st, ge = self.st, self.st.g + av
        if interface:
            W, R, a, I = st.m2 * ge, self.R_I, math.atan2(st.c, st.h2), self.I_upper
        else:
            W, R, a, I = (st.m1 + st.m2) * ge, math.hypot(st.b1, self.yG), math.atan2(st.b1, self.yG), self.I_pair
        lift = math.cos(a - self.sc.rest_ratio * a) - math.cos(a)
        return math.sqrt(2 * W * R * lift / I) if lift > 0 else 0.0

    def rest_margins(self, ah: float, av: float) -> float:
        st, ge = self.st, self.st.g + av
        g = min(e * ah * self.yG + st.b1 * ge for e in (1, -1)) / (st.g * st.b1)
        i = min(e * ah * st.h2 + st.c * ge for e in (1, -1)) / (st.g * st.c)
        return min(g, i)

    def admissible(self, pattern: str, q, w, s1: int, s2: int, ah: float, av: float) -> bool:
        if pattern in ("locked", "upper"):
            if tb.contact_margins(self.st, pattern, q, w, s1, s2, ah, av).min() < -TOL_OPEN:
                return False
        if pattern == "rest":
            return self.rest_margins(ah, av) >= -TOL_OPEN
        acc = tb.pattern_accelerations(self.st, pattern, q, w, s1, s2, ah, av)
        tol = 1e-12 * self.st.g / math.hypot(self.st.b1, self.yG)
        if pattern in ("locked", "both") and q[0] == 0 and w[0] == 0 and s1 * acc[0] < -tol:
            return False
        if pattern in ("upper", "both") and q[1] == q[0] and w[1] == w[0] and s2 * (acc[1] - acc[0]) < -tol:
            return False
        return True

    def uplift(self, t0: float, t1: float, dt: float = 1e-3) -> float | None:
        def indicator(t):
            ah, av = self.sc.ground(t)
            return abs(ah) - (self.st.g + av) * self.kappa

        if indicator(t0) > 0:
            return t0
        # sampled every dt and at the scene's breaks (a record's samples, where |a_h| of a
        # piecewise-linear record peaks)
        breaks = np.asarray(self.sc.breaks, dtype=float)
        grid = np.union1d(np.append(np.arange(t0, t1, dt), t1), breaks[(breaks > t0) & (breaks < t1)])
        for a, b in zip(grid[:-1], grid[1:]):
            if indicator(b) > 0:
                return brentq(indicator, a, b, xtol=1e-15, rtol=4 * np.finfo(float).eps)
        return None


def _initial(sc: StackScene) -> tuple[str, int, int]:
    (t1, t2), (w1, w2) = sc.theta0, sc.omega0
    sgn = lambda x, y: 1 if x > 0 or (x == 0 and y >= 0) else -1  # noqa: E731
    if t1 == 0 and w1 == 0:
        if t2 == 0 and w2 == 0:
            return "rest", 1, 1
        s2 = sgn(t2, w2)
        return "upper", s2, s2
    s1 = sgn(t1, w1)
    if t2 == t1 and w2 == w1:
        return "locked", s1, s1
    return "both", s1, sgn(t2 - t1, w2 - w1)


def solve_stack(scene: StackScene, t_end: float, method: str = "DOP853", rtol: float = 1e-10,
                atol: float = 1e-12, max_impacts: int | None = None) -> StackSolution:
    """Simulate the stack from its initial state to t_end (s)."""
    m = _Stack(scene)
    st = m.st
    sol = StackSolution()
    start = time.perf_counter()
    t = 0.0
    q, w = np.array(scene.theta0, float), np.array(scene.omega0, float)
    pattern, s1, s2 = _initial(scene)
    ah, av = scene.ground(0.0)
    if pattern in ("upper", "locked") and not m.admissible(pattern, q, w, s1, s2, ah, av):
        margins = tb.contact_margins(st, pattern, q, w, s1, s2, ah, av)
        end = 1 if margins[0] < margins[1] else -1
        s1, s2 = (end, s2) if pattern == "upper" else (s1, end)
        pattern = "both"
    mx = [abs(q[0]), abs(q[1])]
    breaks = sorted(b for b in scene.breaks if b > 0)
    ovt = [False, False]
    while t < t_end and not any(ovt):
        if pattern == "rest":
            tu = m.uplift(t, t_end)
            if tu is None:
                break
            t = tu
            ah, av = scene.ground(t)
            side = -1 if ah > 0 else 1
            q, w = np.zeros(2), np.zeros(2)
            pattern = next((p for p in ("locked", "upper", "both")
                            if m.admissible(p, q, w, side, side, ah, av)), "both")
            s1 = s2 = side
            sol.events.append(StackEvent("uplift", t, pattern=pattern))
            continue
        ah, av = scene.ground(t)
        if pattern in ("locked", "upper"):  # a closed contact that already pulls opens now
            margins = tb.contact_margins(st, pattern, q, w, s1, s2, ah, av)
            if margins.min() < -TOL_OPEN:
                end = 1 if margins[0] < margins[1] else -1
                s1, s2 = (end, s2) if pattern == "upper" else (s1, end)
                sol.events.append(StackEvent("open", t, "ground" if pattern == "upper" else "interface", "both"))
                pattern = "both"
                continue
        k = bisect.bisect_right(breaks, t)
        t_stop = min(breaks[k], t_end) if k < len(breaks) else t_end
        events, kinds = [], []

        def add(fn, direction, kind):
            fn.terminal, fn.direction = True, direction
            events.append(fn)
            kinds.append(kind)

        if pattern in ("both", "locked"):
            add(lambda tt, y: s1 * y[0] + GAP_EPS, -1, "ground")
            add(lambda tt, y: s1 * y[0] - math.pi / 2, 1, "overturn1")
        if pattern in ("both", "upper"):
            add(lambda tt, y: s2 * (y[1] - y[0]) + GAP_EPS, -1, "interface")
            add(lambda tt, y: s2 * (y[1] - y[0]) - math.pi / 2, 1, "overturn2")
        if pattern in ("locked", "upper"):
            for k in (0, 1):
                def margin(tt, y, k=k):
                    a_h, a_v = scene.ground(tt)
                    return tb.contact_margins(st, pattern, y[:2], y[2:], s1, s2, a_h, a_v)[k] + TOL_OPEN
                add(margin, -1, "open")

        for j in (0, 1):  # peaks of each block (not terminal): for the largest |theta|
            def peak(tt, y, j=j):
                return y[2 + j]
            peak.terminal = False
            events.append(peak)
            kinds.append("peak")

        def rhs(tt, y):
            a_h, a_v = scene.ground(tt)
            acc = tb.pattern_accelerations(st, pattern, y[:2], y[2:], s1, s2, a_h, a_v)
            return [y[2], y[3], acc[0], acc[1]]

        r = solve_ivp(rhs, (t, t_stop), np.concatenate([q, w]), method=method, rtol=rtol, atol=atol,
                      events=events)
        mx = [max(mx[0], np.max(np.abs(r.y[0]))), max(mx[1], np.max(np.abs(r.y[1])))]
        for i, kind in enumerate(kinds):
            if kind == "peak" and r.y_events[i].size:
                mx = [max(mx[0], np.max(np.abs(r.y_events[i][:, 0]))), max(mx[1], np.max(np.abs(r.y_events[i][:, 1])))]
        hit = [(te[0], i) for i, te in enumerate(r.t_events) if te.size and kinds[i] != "peak"]
        if not hit:
            t, q, w = float(r.t[-1]), r.y[:2, -1].copy(), r.y[2:, -1].copy()
            continue
        te, i = min(hit)
        y = r.y_events[i][0]
        t, q, w, kind = float(te), y[:2].copy(), y[2:].copy(), kinds[i]
        ah, av = scene.ground(t)
        if kind.startswith("overturn"):
            ovt = [kind == "overturn1", True]
            sol.events.append(StackEvent("overturn", t, pattern="overturned"))
            break
        if kind == "open":
            margins = tb.contact_margins(st, pattern, q, w, s1, s2, ah, av)
            end = 1 if margins[0] < margins[1] else -1
            s1, s2 = (end, s2) if pattern == "upper" else (s1, end)
            sol.events.append(StackEvent("open", t, "ground" if pattern == "upper" else "interface", "both"))
            pattern = "both"
            continue
        pattern, s1, s2, q, w = _impact(m, kind, pattern, s1, s2, q, w, ah, av, sol, t)
        if max_impacts is not None and len(sol.impacts()) >= max_impacts:
            break
    sol.overturned, sol.pattern = (ovt[0], ovt[1]), ("overturned" if any(ovt) else pattern)
    sol.max_abs_theta = (float(mx[0]), float(mx[1]))
    sol.wall_time = time.perf_counter() - start
    return sol


def _impact(m: _Stack, contact: str, pattern: str, s1: int, s2: int, q, w, ah, av, sol, t):
    st, sc = m.st, m.sc
    ground = contact == "ground"
    old = (s1, s2)
    if ground:
        q[0] = 0.0
        if pattern == "locked":
            q[1] = 0.0
        n1, n2 = -s1, (-s1 if pattern == "locked" else s2)
    else:
        q[1] = q[0]
        n1, n2 = (-s2 if pattern == "upper" else s1), -s2
    new = pattern
    wp, ok = tb.pattern_impact(st, q, w, old, (n1, n2), pattern)
    if not ok:  # the closed contact would pull: it opens about one end
        for e in (1, -1):
            piv = (e, n2) if pattern == "upper" else (n1, e)
            wb, _ = tb.pattern_impact(st, q, w, old, piv, "both")
            opening = e * wb[0] if pattern == "upper" else e * (wb[1] - wb[0])
            if opening > 0:
                new, (n1, n2), wp = "both", piv, wb
                break
    if sc.law == "constant":
        eta = sc.eta_ground if ground else sc.eta_interface
        Tm, Tp = tb.kinetic_energy(st, q, w, *old), tb.kinetic_energy(st, q, wp, n1, n2)
        wp = wp * (eta * math.sqrt(Tm / Tp) if Tp > 0 else 0.0)
    sol.events.append(StackEvent("impact", t, contact, new))
    # settling of negligible rebounds (docs/two_blocks.md, "Settling and locking")
    g_open, i_open = new in ("both", "locked"), new in ("both", "upper")
    g_settles = not g_open or (q[0] == 0 and abs(wp[0]) < m.settle_rate(False, av))
    i_settles = not i_open or (q[1] == q[0] and abs(wp[1] - wp[0]) < m.settle_rate(True, av))
    candidates = ["rest"] if g_settles and i_settles else []
    if new == "both":
        order = [("upper", g_settles), ("locked", i_settles)]
        if not ground:
            order.reverse()
        candidates += [p for p, ok_ in order if ok_]
    for cand in candidates:
        wq, _ = tb.pattern_impact(st, q, wp, (n1, n2), (n1, n2), cand)
        if m.admissible(cand, q, wq, n1, n2, ah, av):
            new, wp = cand, wq
            sol.events.append(StackEvent("settle", t, pattern=cand))
            break
    if new == "locked":
        n2 = n1
    if new == "upper":
        n1 = n2
    if new == "rest":
        return "rest", 1, 1, np.zeros(2), np.zeros(2)
    return new, n1, n2, q, wp
