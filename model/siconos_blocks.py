#!/usr/bin/python3
"""A column of 1 to 8 stacked rigid blocks on a moving ground, by Siconos: an independent nonsmooth peer.

Run with the system Python that has the Debian package ``python3-siconos`` (the project's venv cannot
import it)::

    /usr/bin/python3 model/siconos_blocks.py case.json > run.json
    /usr/bin/python3 model/siconos_blocks.py < case.json > run.json

**Model.** N = 1 to 8 rigid rectangles stacked centred (body 1 on the ground, body k on body k - 1's top),
body k of half width ``b_k``, half height ``h_k`` (m), mass ``m_k`` (kg), ``Ic = m (b^2 + h^2) / 3``
(kg m^2), in the ground's frame: each body carries its weight and the inertial force of the ground's
motion, ``-m (a_h, g + a_v)`` (N). Coordinates of body k: its centre ``(X_k, Y_k)`` (m; origin at body
1's base centre at rest, x right, y up) and its rotation ``theta_k`` (rad, clockwise positive,
docs/conventions.md), absolute. Every bottom corner of a body is a unilateral contact with its
support's top face (the ground for body 1, body k - 1's top face for body k) with Coulomb friction
(``mu`` on the ground, ``mu_interface`` between the bodies) and a plastic impact law (Newton
restitution 0, tangential restitution 0).

**Siconos classes.** One ``LagrangianLinearTIDS`` holds all 3 N coordinates (constant diagonal mass
matrix); each corner is an ``Interaction`` with a ``NewtonImpactFrictionNSL(0, 0, mu, 2)`` and a
``LagrangianLinearTIR`` whose rows are the corner's gap and its tangential coordinate along the
support's face, relinearised at the start of every step (``C = dg/dq(q_k)``, ``e = g(q_k) - C q_k``;
Moreau-Jean only needs the gap at ``q_k`` to select the active contacts and the Jacobian at ``q_k``
for the velocity-level problem; a ``LagrangianScleronomousR`` subclassed in Python, the direct way,
crashes Siconos 4.4.0 in ``MoreauJeanOSI::computeFreeOutput`` once a contact closes, and a linear
relation makes Siconos cache the Delassus blocks, hence ``setHasBeenUpdated(False)`` every step).
``MoreauJeanOSI(theta)`` (Moreau 1988; Jean 1999; Acary & Brogliato
2008) and a ``FrictionContact(2)`` problem solved by ``SICONOS_FRICTION_2D_NSGS`` (the Lemke solver
of this version returns impulses outside the cone when a flat body's two tangential rows coincide).
The ground's forces on a step are their mean over the step (exact impulses). A contact is put in the
active set where its predicted gap ``g + h/2 g'`` is ``<= 0``; the gap is given an activation margin
of 1e-9 m so that a corner resting at zero gap with a rounding-level positive rate stays active (it
can still leave: the velocity-level problem lets an active contact separate). With ``"hold": V`` (m/s) in
the input, a contact active at the previous step stays active while its gap is at most ``V h`` (a hysteresis;
otherwise the rule above): the corners of a flat interface that Moreau-Jean's drift has tilted by rounding sit
at the activation threshold, and one left out of the step of a ground impact lets the impact open that
interface, a sequence of impacts where every touching contact takes the impact at once (the FMU's law);
a held contact lands at most ``V h`` early, an error of the method's own order.

**Input** (JSON, a file named on the command line or stdin; SI units)::

    {"blocks": [{"b": 0.3, "h": 0.36, "m": 1.0}, ...],    # 1 to 8, body 1 first
     "mu": 0.3, "mu_interface": 0.5,                       # between the blocks: one value, or N - 1 bottom up
     "g": 9.81,                                            # optional, m/s2
     "excitation": [{"kind": "sine", "A": 3.0, "V": -15.0, "f": 2.0, "t0": 0.0},
                    {"kind": "constant", "ah": 0.0, "av": 0.0},
                    {"kind": "record", "t": [...], "ah": [...], "av": [...], "t0": 0.0}],
     "t_end": 1.0, "h": 1e-4, "theta": 0.5,                # s, s, Moreau-Jean's theta (0.5 or 1)
     "t_out": [...]  or  "dt_out": 0.001,                  # output times (s)
     "tol": 1e-10,                                         # optional, the NSGS tolerance
     "hold": 0.01}                                         # optional, m/s: active contacts held to a gap V h

The excitation is the sum of its terms (a single object is one term): a sine pulse
``a_h = A sin(2 pi f (t - t0))``, ``a_v = V sin(2 pi f (t - t0))`` for one cycle from ``t0``
(the FMU's ``excitation.kind = 1``), zero outside; constants; a record, linear between its samples
(``a_v`` optional), zero outside ``[t0 + t[0], t0 + t[-1]]``. ``a_h > 0`` accelerates the ground to
``+x``, ``a_v > 0`` upwards. The bodies start at rest, flat, centred.

**Output** (JSON on stdout)::

    {"t": [...], "h": ..., "theta": ..., "steps": ..., "cpu_s": ...,
     "solver_warnings": ...,   # steps whose friction-contact solve reported no convergence
     "blocks": [{"X", "Y", "theta", "vX", "vY", "omega", "slip", "gap"}: lists per output time]}

``X, Y`` (m), ``theta`` (rad, clockwise), their rates (m/s, rad/s). ``slip`` (m) is the coordinate of
the body's lowest corner along its support's face less that corner's rest offset ``c b`` (``c = +1``
right, ``-1`` left): for body 1 the ``x`` of the lowest corner relative to the ground, for body 2
its position along body 1's top face in body 1's frame (docs/conventions.md). ``gap`` (m) is the
height of the lowest corner above its support's face (negative: Moreau-Jean's penetration, of the
order of the step). Values at output times between two steps are linear between them.
"""
from __future__ import annotations

import json
import math
import os
import sys
import tempfile
import time
from collections.abc import Callable, Sequence

import numpy as np

GAP_MARGIN = 1e-9  # m: a corner at zero gap counts as touching (see the docstring)
MAX_BLOCKS = 8  # blocks in a column


# ------------------------------------------------------------------ ground motion


def _sine_term(term: dict) -> Callable[[float, float], tuple[float, float]]:
    """Mean (a_h, a_v) in m/s2 over [ta, tb] of a one-cycle sine pulse (the FMU's excitation.kind = 1)."""
    A, V, f, t0 = float(term["A"]), float(term.get("V", 0.0)), float(term["f"]), float(term.get("t0", 0.0))
    w, t1 = 2.0 * math.pi * f, t0 + 1.0 / f

    def mean(ta: float, tb: float) -> tuple[float, float]:
        lo, hi = max(ta, t0), min(tb, t1)
        if hi <= lo:
            return 0.0, 0.0
        s = (math.cos(w * (lo - t0)) - math.cos(w * (hi - t0))) / w / (tb - ta)  # mean of sin(w (t - t0))
        return A * s, V * s

    return mean


def _record_term(term: dict) -> Callable[[float, float], tuple[float, float]]:
    """Mean (a_h, a_v) in m/s2 over [ta, tb] of a record linear between its samples, zero outside."""
    t0 = float(term.get("t0", 0.0))
    ts = t0 + np.asarray(term["t"], dtype=float)
    series = [np.asarray(term["ah"], dtype=float),
              np.asarray(term["av"], dtype=float) if term.get("av") is not None else np.zeros_like(ts)]
    if len(ts) < 2 or np.any(np.diff(ts) <= 0) or any(len(a) != len(ts) for a in series):
        raise ValueError("a record needs >= 2 increasing times and as many accelerations")
    # cumulative integral at the samples (trapezoids are exact for a linear piece)
    cum = [np.concatenate(([0.0], np.cumsum(0.5 * (a[1:] + a[:-1]) * np.diff(ts)))) for a in series]

    def integral(t: float, a: np.ndarray, c: np.ndarray) -> float:
        if t <= ts[0]:
            return 0.0
        if t >= ts[-1]:
            return float(c[-1])
        i = int(np.searchsorted(ts, t, side="right")) - 1
        dt, s = t - ts[i], (a[i + 1] - a[i]) / (ts[i + 1] - ts[i])
        return float(c[i] + a[i] * dt + 0.5 * s * dt * dt)

    def mean(ta: float, tb: float) -> tuple[float, float]:
        return tuple((integral(tb, a, c) - integral(ta, a, c)) / (tb - ta) for a, c in zip(series, cum))

    return mean


def ground_mean(excitation: dict | Sequence[dict]) -> Callable[[float, float], tuple[float, float]]:
    """The mean ground acceleration (a_h, a_v) in m/s2 over a step [ta, tb] (s), summed over the terms."""
    terms = [excitation] if isinstance(excitation, dict) else list(excitation)
    parts: list[Callable[[float, float], tuple[float, float]]] = []
    for term in terms:
        kind = term.get("kind")
        if kind == "sine":
            parts.append(_sine_term(term))
        elif kind == "record":
            parts.append(_record_term(term))
        elif kind == "constant":
            ah, av = float(term.get("ah", 0.0)), float(term.get("av", 0.0))
            parts.append(lambda ta, tb, ah=ah, av=av: (ah, av))
        else:
            raise ValueError(f"unknown excitation kind {kind!r} (sine, constant, record)")

    def mean(ta: float, tb: float) -> tuple[float, float]:
        ah = av = 0.0
        for p in parts:
            a, v = p(ta, tb)
            ah, av = ah + a, av + v
        return ah, av

    return mean


# ------------------------------------------------------------------ kinematics


def corner_offset(b: float, h: float, c: int, theta: float) -> tuple[float, float]:
    """(rx, ry) in m: bottom corner c (+1 right, -1 left) of a body of half sizes b, h rotated by theta
    (rad, clockwise), from its centre; d(rx, ry)/dtheta = (ry, -rx)."""
    ct, st = math.cos(theta), math.sin(theta)
    return c * b * ct - h * st, -c * b * st - h * ct


def contact_rows(q: np.ndarray, blocks: Sequence[dict], k: int, c: int) -> tuple[float, float, np.ndarray]:
    """Gap (m), tangential coordinate (m) and their Jacobian (2 x 3N) of body k's corner c against its
    support's top face (the ground for k = 0, body k - 1 otherwise), at coordinates q
    (X, Y, theta per body; m, m, rad clockwise)."""
    n = len(q)
    X, Y, th = q[3 * k:3 * k + 3]
    rx, ry = corner_offset(blocks[k]["b"], blocks[k]["h"], c, th)
    J = np.zeros((2, n))
    if k == 0:
        J[0, 0:3] = (0.0, 1.0, -rx)
        J[1, 0:3] = (1.0, 0.0, ry)
        return Y + ry, X + rx, J
    X1, Y1, th1 = q[3 * (k - 1):3 * k]
    h1 = blocks[k - 1]["h"]
    nrm = np.array([math.sin(th1), math.cos(th1)])   # body 1's top face: outward normal
    tan = np.array([math.cos(th1), -math.sin(th1)])  # and its +x direction
    d = np.array([X + rx - X1, Y + ry - Y1])         # the corner from body 1's centre
    gap, xi = float(d @ nrm) - h1, float(d @ tan)
    dP = np.array([ry, -rx])                          # d(corner)/d(theta_k)
    i1, i2 = 3 * (k - 1), 3 * k
    J[0, i1:i1 + 3] = (-nrm[0], -nrm[1], xi)          # d(d.n)/dtheta_1 = d.t
    J[0, i2:i2 + 3] = (nrm[0], nrm[1], float(dP @ nrm))
    J[1, i1:i1 + 3] = (-tan[0], -tan[1], -(gap + h1))  # d(d.t)/dtheta_1 = -d.n
    J[1, i2:i2 + 3] = (tan[0], tan[1], float(dP @ tan))
    return gap, xi, J


def observe(q: np.ndarray, blocks: Sequence[dict]) -> list[tuple[float, float]]:
    """(slip, gap) in m per body: its lowest corner's coordinate along its support's face less that
    corner's rest offset c b, and that corner's height above the face."""
    out = []
    for k, blk in enumerate(blocks):
        rows = [(contact_rows(q, blocks, k, c)[:2], c) for c in (-1, 1)]
        (gap, xi), c = min(rows, key=lambda r: r[0][0])
        out.append((xi - c * blk["b"], gap))
    return out


# ------------------------------------------------------------------ the simulation


def simulate(case: dict) -> dict:
    """Run one case (the module docstring's input) and return the output dictionary."""
    import siconos.kernel as sk
    import siconos.numerics as sn

    blocks = [{"b": float(b["b"]), "h": float(b["h"]), "m": float(b["m"])} for b in case["blocks"]]
    if not 1 <= len(blocks) <= MAX_BLOCKS:
        raise ValueError(f"1 to {MAX_BLOCKS} blocks")
    N = len(blocks)
    g = float(case.get("g", 9.81))
    above = case.get("mu_interface", []) if N > 1 else []
    mus = [float(case["mu"])] + ([float(m) for m in above] if isinstance(above, list) else [float(above)] * (N - 1))
    if len(mus) != N:
        raise ValueError(f"mu_interface: {N - 1} values (one per interface, bottom up) or one for all")
    t_end, step, theta = float(case["t_end"]), float(case["h"]), float(case.get("theta", 0.5))
    if "t_out" in case:
        t_out = np.asarray(case["t_out"], dtype=float)
    else:
        t_out = np.arange(0.0, t_end + 0.5 * float(case["dt_out"]), float(case["dt_out"]))
    t_out = t_out[t_out <= t_end + 1e-12]
    mean_ground = ground_mean(case["excitation"])

    masses = np.concatenate([[b["m"], b["m"], b["m"] * (b["b"] ** 2 + b["h"] ** 2) / 3.0] for b in blocks])
    q0 = np.zeros(3 * N)
    y = 0.0
    for k, b in enumerate(blocks):
        q0[3 * k + 1] = y + b["h"]
        y += 2.0 * b["h"]
    ds = sk.LagrangianLinearTIDS(q0, np.zeros(3 * N), np.diag(masses))
    fext = np.zeros(3 * N)
    ds.setFExtPtr(fext)
    nsds = sk.NonSmoothDynamicalSystem(0.0, t_end)
    nsds.insertDynamicalSystem(ds)
    contacts = []  # (body, corner, relation)
    for k in range(N):
        for c in (-1, 1):
            rel = sk.LagrangianLinearTIR(np.zeros((2, 3 * N)), np.zeros(2))
            inter = sk.Interaction(sk.NewtonImpactFrictionNSL(0.0, 0.0, mus[k], 2), rel)
            nsds.link(inter, ds)
            contacts.append((k, c, rel))
    osi = sk.MoreauJeanOSI(theta)
    osnspb = sk.FrictionContact(2, sn.SICONOS_FRICTION_2D_NSGS)
    opts = osnspb.numericsSolverOptions()
    opts.iparam[sn.SICONOS_IPARAM_MAX_ITER] = 100000
    opts.dparam[sn.SICONOS_DPARAM_TOL] = float(case.get("tol", 1e-10))
    sim = sk.TimeStepping(nsds, sk.TimeDiscretisation(0.0, step), osi, osnspb)

    hold = float(case.get("hold", 0.0)) * step  # m: an active contact stays active up to this gap
    held = [False] * len(contacts)

    def relinearise(q: np.ndarray) -> None:
        v = np.array(ds.velocity())
        for j, (k, c, rel) in enumerate(contacts):
            gap, xi, J = contact_rows(q, blocks, k, c)
            rel.setJachqPtr(J)
            if hold > 0.0:  # the active set chosen here, given to Siconos as the sign of y
                held[j] = gap - GAP_MARGIN + 0.5 * step * float(J[0] @ v) <= 0.0 or (held[j] and gap <= hold)
                rel.setEPtr(np.array([-1.0 if held[j] else 1.0, xi]) - J @ q)
            else:
                rel.setEPtr(np.array([gap - GAP_MARGIN, xi]) - J @ q)

    def state() -> np.ndarray:
        q, v = np.array(ds.q()), np.array(ds.velocity())
        obs = observe(q, blocks)
        return np.concatenate([np.concatenate([q[3 * k:3 * k + 3], v[3 * k:3 * k + 3], obs[k]]) for k in range(N)])

    n_steps = int(round(t_end / step))
    rows = np.empty((len(t_out), 8 * N))
    j = 0
    prev_t, prev = 0.0, state()
    while j < len(t_out) and t_out[j] <= 0.0:
        rows[j] = prev
        j += 1
    cpu = time.process_time()
    for i in range(n_steps):
        ta, tb = i * step, (i + 1) * step
        ah, av = mean_ground(ta, tb)
        for k, b in enumerate(blocks):
            fext[3 * k:3 * k + 3] = (-b["m"] * ah, -b["m"] * (g + av), 0.0)
        ds.setFExtPtr(fext)
        relinearise(np.array(ds.q()))
        osnspb.setHasBeenUpdated(False)  # the contact Jacobians changed: rebuild the Delassus blocks
        sim.computeOneStep()
        sim.nextStep()
        cur = state()
        while j < len(t_out) and t_out[j] <= tb + 1e-12:
            s = (t_out[j] - prev_t) / step
            rows[j] = (1.0 - s) * prev + s * cur
            j += 1
        prev_t, prev = tb, cur
    rows[j:] = prev
    cpu = time.process_time() - cpu
    names = ["X", "Y", "theta", "vX", "vY", "omega", "slip", "gap"]
    return {"t": t_out.tolist(), "h": step, "theta": theta, "steps": n_steps, "cpu_s": cpu,
            "blocks": [{name: rows[:, 8 * k + n].tolist() for n, name in enumerate(names)} for k in range(N)]}


def main(argv: list[str]) -> int:
    """Read the case (a file named in argv, or stdin), print the run as JSON on stdout.

    What Siconos prints (on the C level's stdout) goes to stderr; its solver warnings are counted in
    the output's ``solver_warnings``."""
    text = open(argv[1]).read() if len(argv) > 1 and argv[1] != "-" else sys.stdin.read()
    case = json.loads(text)
    sys.stdout.flush()
    saved = os.dup(1)
    with tempfile.TemporaryFile(mode="w+b") as log:
        os.dup2(log.fileno(), 1)
        try:
            run = simulate(case)
        finally:
            sys.stdout.flush()
            os.dup2(saved, 1)
            os.close(saved)
        log.seek(0)
        printed = log.read().decode(errors="replace")
    sys.stderr.write(printed)
    run["solver_warnings"] = printed.count("Non smooth solver warning")
    json.dump(run, sys.stdout)
    sys.stdout.write("\n")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
