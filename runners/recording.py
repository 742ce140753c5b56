"""Rerun recordings (.rrd) of runs, for review offline in the Rerun viewer.

A recording holds, on the ``sim_time`` timeline (s):

- ``/block1/theta``, ``/block1/omega``, ``/block1/alpha_dd`` (and ``/block2/...``
  for a stack): rad, rad/s, rad/s^2, at every output sample;
- ``/ground/ah``, ``/ground/av`` (m/s^2), ``/energy`` (J), ``/block1/pivot``
  (+1 right corner, -1 left, 0 flat; ``/block2/pivot`` likewise);
- ``/events``: impacts, uplift, rest, settling (lock), opening (unlock) and
  overturn as text entries with their values, at their times (events at
  one instant share an entry, separated by "; ");
- ``/scene``: the blocks drawn to scale (outlines and the pivot in use),
  animated at up to 100 frames per simulated second, on the ground line;
- a blueprint that opens on the scene, the angles, the velocities and the
  excitation.

Time series go through the columnar API (``send_columns``). Conventions:
docs/conventions.md (theta > 0 clockwise about the right corner).
"""

from __future__ import annotations

import math
import uuid
from pathlib import Path
from typing import Any

import numpy as np

MAX_FPS = 100.0  # animation frames per simulated second


def _rot(theta: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Rotate body-frame points (k, 2) clockwise by theta (n,): (n, k, 2)."""
    c, s = np.cos(theta)[:, None], np.sin(theta)[:, None]
    x, y = pts[:, 0][None, :], pts[:, 1][None, :]
    return np.stack([c * x + s * y, -s * x + c * y], axis=-1)


def block_outlines(time: np.ndarray, out: dict[str, np.ndarray], p: dict[str, Any]) -> list[np.ndarray]:
    """Closed outlines (n, 5, 2) of each block in the ground frame (m), origin at block 1's bottom centre."""
    b1, h1 = p["block1.halfWidth"], p["block1.halfHeight"]
    th1 = out["block1.theta"]
    s1 = np.where(th1 >= 0, 1.0, -1.0)
    shapes = []
    rect1 = np.array([[-b1, 0], [b1, 0], [b1, 2 * h1], [-b1, 2 * h1], [-b1, 0]])
    # rotate about the pivot (s1 b1, 0): P + R (x - P)
    pts = np.empty((len(time), 5, 2))
    for side in (1.0, -1.0):
        m = s1 == side
        if m.any():
            P = np.array([side * b1, 0.0])
            pts[m] = P + _rot(th1[m], rect1 - P)
    shapes.append(pts)
    if int(p.get("nBlocks", 1)) == 2:
        b2, h2 = p["block2.halfWidth"], p["block2.halfHeight"]
        c = min(b1, b2)
        th2 = out["block2.theta"]
        s2 = np.where(th2 - th1 >= 0, 1.0, -1.0)
        rect2 = np.array([[-b2, 0], [b2, 0], [b2, 2 * h2], [-b2, 2 * h2], [-b2, 0]])
        pts2 = np.empty((len(time), 5, 2))
        for side1 in (1.0, -1.0):
            for side2 in (1.0, -1.0):
                m = (s1 == side1) & (s2 == side2)
                if not m.any():
                    continue
                P1 = np.array([side1 * b1, 0.0])
                K = P1 + _rot(th1[m], np.array([[side2 * c, 2 * h1]]) - P1)[:, 0, :]  # pivot of block 2
                body = rect2 - np.array([side2 * c, 0.0])  # block 2's outline about its pivot
                pts2[m] = K[:, None, :] + _rot(th2[m], body)
        shapes.append(pts2)
    return shapes


def pivots(out: dict[str, np.ndarray], two: bool) -> dict[str, np.ndarray]:
    th1 = out["block1.theta"]
    piv = {"block1": np.sign(th1)}
    if two:
        piv["block2"] = np.sign(out["block2.theta"] - th1)
    return piv


def _blueprint(two: bool):
    import rerun.blueprint as rrb

    blocks = ["block1", "block2"] if two else ["block1"]
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Spatial2DView(origin="/scene", name="blocks"),
            rrb.Vertical(
                rrb.TimeSeriesView(name="theta (rad)", contents=[f"/{b}/theta" for b in blocks]),
                rrb.TimeSeriesView(name="omega (rad/s)", contents=[f"/{b}/omega" for b in blocks]),
                rrb.TimeSeriesView(name="ground (m/s2)", contents=["/ground/**"]),
            ),
            column_shares=[2, 3],
        ),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
    )


def write_recording(path: Path, name: str, time: np.ndarray, out: dict[str, np.ndarray], p: dict[str, Any],
                    events: list | None = None, measured: dict[str, tuple[np.ndarray, np.ndarray]] | None = None
                    ) -> Path:
    """Write one run to path (.rrd); `measured` maps a simulated series name to (time, values) to overlay."""
    import rerun as rr

    two = int(p.get("nBlocks", 1)) == 2
    rec = rr.RecordingStream("rocking", recording_id=str(uuid.uuid4()))
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    rec.save(str(path), default_blueprint=_blueprint(two))
    rec.send_property("run", rr.AnyValues(name=name))
    idx = [rr.TimeColumn("sim_time", duration=np.asarray(time, float))]
    series = {"/block1/theta": "block1.theta", "/block1/omega": "block1.omega", "/block1/alpha_dd": "block1.alpha_dd",
              "/ground/ah": "ground.ahTotal", "/ground/av": "ground.avTotal", "/energy": "energy"}
    if two:
        series.update({"/block2/theta": "block2.theta", "/block2/omega": "block2.omega",
                       "/block2/alpha_dd": "block2.alpha_dd"})
    for entity, var in series.items():
        if var in out:
            rec.send_columns(entity, indexes=idx, columns=rr.Scalars.columns(scalars=np.asarray(out[var], float)))
    for block, piv in pivots(out, two).items():
        rec.send_columns(f"/{block}/pivot", indexes=idx, columns=rr.Scalars.columns(scalars=piv))
    for entity, (mt, mv) in (measured or {}).items():
        rec.send_columns(f"/measured/{entity}", indexes=[rr.TimeColumn("sim_time", duration=np.asarray(mt, float))],
                         columns=rr.Scalars.columns(scalars=np.asarray(mv, float)))
    # the scene: outlines at up to MAX_FPS frames per simulated second, ground line and pivots
    stride = max(1, int(math.ceil((len(time) - 1) / max(1.0, (time[-1] - time[0]) * MAX_FPS)))) if len(time) > 1 else 1
    frames = np.arange(0, len(time), stride)
    frame_idx = [rr.TimeColumn("sim_time", duration=np.asarray(time, float)[frames])]
    shapes = block_outlines(time[frames], {k: np.asarray(v)[frames] for k, v in out.items()}, p)
    colours = [[70, 110, 200], [200, 90, 70]]
    for i, pts in enumerate(shapes, start=1):
        rec.log(f"/scene/block{i}", rr.LineStrips2D.from_fields(colors=[colours[i - 1]]), static=True)
        rec.send_columns(f"/scene/block{i}", indexes=frame_idx,
                         columns=rr.LineStrips2D.columns(strips=pts).partition([1] * len(frames)))
    b1 = p["block1.halfWidth"]
    width = 4 * max(b1, p.get("block2.halfWidth", b1) if two else b1)
    rec.log("/scene/ground", rr.LineStrips2D([[[-width, 0.0], [width, 0.0]]], colors=[[90, 90, 90]]), static=True)
    piv1 = pivots({k: np.asarray(v)[frames] for k, v in out.items()}, False)["block1"]
    rec.send_columns("/scene/pivot", indexes=frame_idx,
                     columns=rr.Points2D.columns(positions=np.stack([piv1 * b1, np.zeros(len(frames))], 1),
                                                 radii=np.full(len(frames), 0.15 * b1)))
    # events at one instant (an impact and the settling it causes, say) share one entry, "; "-separated
    by_time: dict[float, list[str]] = {}
    for ev in events or []:
        values = " ".join(f"{k}={v:.6g}" for k, v in ev.values.items())
        labels = " ".join(f"{k}={v}" for k, v in ev.labels.items())
        by_time.setdefault(float(ev.t), []).append(f"{ev.kind} {labels} {values}".strip())
    for t_ev, texts in by_time.items():
        rec.set_time("sim_time", duration=t_ev)
        rec.log("/events", rr.TextLog("; ".join(texts), level="INFO"))
    rec.flush()
    rec.disconnect()
    return path


def write_sweep_recording(path: Path, factory, sweep_id: int) -> Path:
    """One recording of a sweep: its overturning map as an image and, on a `grid_index`
    sequence, each point's grid values and summary (overturned, impacts, peak / alpha)."""
    import tempfile

    import matplotlib.image as mpimg
    import rerun as rr

    from runners.sweep_map import draw, load

    sw, scene, runs = load(factory, str(sweep_id))
    runs = sorted(runs, key=lambda r: r.grid_index)
    rec = rr.RecordingStream("rocking", recording_id=str(uuid.uuid4()))
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    rec.save(str(path))
    rec.send_property("sweep", rr.AnyValues(id=sw.id, scene=scene.name, total=sw.total))
    with tempfile.TemporaryDirectory() as tmp:
        png = Path(tmp) / "map.png"
        draw(factory, str(sweep_id), png)
        rgba = (mpimg.imread(png) * 255).astype(np.uint8)
    rec.log("/map", rr.Image(rgba), static=True)
    idx = [rr.TimeColumn("grid_index", sequence=np.array([r.grid_index for r in runs], dtype=np.int64))]
    ok = [r.summary is not None for r in runs]
    columns = {
        "overturned": [float(r.summary.overturned) if r.summary else np.nan for r in runs],
        "impacts": [float(r.summary.impacts) if r.summary and r.summary.impacts is not None else np.nan
                    for r in runs],
        "peak1_over_alpha": [r.summary.peak1_over_alpha if r.summary and r.summary.peak1_over_alpha is not None
                             else np.nan for r in runs],
        "failed": [0.0 if good else 1.0 for good in ok],
    }
    for axis in (a[0] for a in sw.grid["axes"]):
        columns[f"grid/{axis}"] = [r.point[axis] for r in runs]
    for name, values in columns.items():
        rec.send_columns(f"/points/{name}", indexes=idx, columns=rr.Scalars.columns(scalars=np.asarray(values, float)))
    rec.flush()
    rec.disconnect()
    return path
