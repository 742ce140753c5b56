"""Columns of 3 to 8 blocks (nBlocks >= 3, docs/columns_runners.md): their outputs, each block's
outcome and the column's, for single runs and sweeps alike.

Block 1 stands on the ground, block K on block K - 1. Each block's slip is its dislocation relative
to what it stands on (block 1's on the ground, block K's along the top of block K - 1, m, +x), its
value at the end of the run the residual dislocation. ``blockK.overturned`` is true when the block
fell, or rode a block under it that fell; ``blockK.fellOff`` when it left the top of the block
below. A fall of any block ends the run's motion (the FMU's pattern 2).

Column outcomes: ``collapsed`` (a block overturned or fell off), ``lowest_fallen`` (the lowest
block that did: the blocks from it up are gone), ``max_residual_slip`` (the largest |residual
dislocation| of any block on what it stands on, "any drum", m) and the block it is of, and
``max_abs_slip`` (the largest peak |slip| of any block, m). Units SI, angles in radians.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np

MIN_COLUMN = 3  # blocks: a column from here on (1 and 2 blocks keep their own summaries)

# block1.mode (the FMU's Enumeration ContactMode) -> its name (as summary.MODES)
MODES = {0: "rest", 1: "slide", 2: "rock", 3: "slide-rock", 4: "overturned", 5: "fell off", 6: "flight"}


def n_blocks(p: Mapping[str, Any]) -> int:
    return int(p.get("nBlocks", 1))


def is_column(p: Mapping[str, Any]) -> bool:
    """Whether FMU parameters `p` describe a column (3 blocks or more)."""
    return n_blocks(p) >= MIN_COLUMN


def block_outputs(k: int) -> list[str]:
    """The outputs of block `k` a column's run reads (sampled, stored and exported)."""
    names = [f"block{k}.{n}" for n in ("theta", "omega", "slip", "mode", "maxAbsTheta", "maxAbsSlip", "overturned")]
    return names + ([f"block{k}.fellOff"] if k >= 2 else [])


def final_outputs(n: int) -> list[str]:
    """The outputs whose final values make a column's per-block outcomes (sweeps read these only)."""
    return [name for k in range(1, n + 1) for name in block_outputs(k)
            if not name.endswith((".theta", ".omega"))]


def column_outputs(p: Mapping[str, Any]) -> tuple[str, ...]:
    """Every block's outputs of a column of parameters `p` (none for 1 or 2 blocks)."""
    if not is_column(p):
        return ()
    return tuple(name for k in range(1, n_blocks(p) + 1) for name in block_outputs(k))


def alpha(p: Mapping[str, Any], k: int) -> float:
    """Block k's alpha (rad): atan(b / h), or a body of real shape's smaller side's (runners.engine.shapes)."""
    from runners.engine.shapes import alpha as shape_alpha

    return shape_alpha(p, k)


def block_rows(final: Mapping[str, Any], p: Mapping[str, Any]) -> list[dict[str, Any]]:
    """Each block's outcome from the final outputs `final` of a column's run of parameters `p`:
    block, peak |theta| (rad) and over its own alpha (None once it fell: no demand then), peak and
    residual slip on what it stands on (m), overturned, fell off, final contact mode."""
    rows = []
    for k in range(1, n_blocks(p) + 1):
        over = bool(final[f"block{k}.overturned"])
        fell = bool(final.get(f"block{k}.fellOff", False))
        peak = float(final[f"block{k}.maxAbsTheta"])
        mode = int(final[f"block{k}.mode"])
        rows.append({"block": k, "max_abs_theta": peak, "peak_over_alpha": None if over or fell else peak / alpha(p, k),
                     "max_abs_slip": float(final[f"block{k}.maxAbsSlip"]),
                     "residual_slip": float(final[f"block{k}.slip"]), "overturned": over, "fell_off": fell,
                     "final_mode": MODES.get(mode, str(mode))})
    return rows


def column_outcome(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """The column's outcome from its blocks' (block_rows): collapsed, lowest_fallen (None: none),
    max_residual_slip (m, |residual| of the block that has the largest, of the blocks still
    standing; the fallen ones' slips are where the run stopped following them) and its block,
    max_abs_slip (m, the largest peak |slip|, standing blocks)."""
    fallen = [r["block"] for r in rows if r["overturned"] or r["fell_off"]]
    lowest = min(fallen) if fallen else None
    standing = [r for r in rows if lowest is None or r["block"] < lowest]
    worst = max(standing, key=lambda r: abs(r["residual_slip"]), default=None)
    return {"collapsed": bool(fallen), "lowest_fallen": lowest,
            "max_residual_slip": None if worst is None else abs(worst["residual_slip"]),
            "max_residual_slip_block": None if worst is None else worst["block"],
            "max_abs_slip": max((r["max_abs_slip"] for r in standing), default=None)}


def fallen_range(lowest: int | None, n: int) -> str | None:
    """The run_summaries overturned_blocks of a column: the blocks gone, "K-N" (lowest to top), or
    "N" when only the top one is; None when none."""
    if lowest is None:
        return None
    return str(lowest) if lowest == n else f"{lowest}-{n}"


def summary_part(final: Mapping[str, Any], p: Mapping[str, Any], events: list | None = None,
                 end_time: float | None = None) -> dict[str, Any]:
    """A column run's summary additions (runners simulate --json): ``per_block`` (block_rows) and
    ``column`` (column_outcome, with ``collapse_time_s``: the first fall or fall-off event, s)."""
    rows = block_rows(final, p)
    col = column_outcome(rows)
    t = None
    for e in events or ():
        kind = e.kind if hasattr(e, "kind") else e.get("kind")
        if kind in ("overturn", "fell-off", "fall-off", "fell off"):
            t = float(e.t if hasattr(e, "t") else e.get("t"))
            break
    if t is None and col["collapsed"]:
        over_t = float(final.get("overturnTime", -1.0))
        t = over_t if over_t >= 0 else None
    col["collapse_time_s"] = t
    return {"per_block": rows, "column": col}


def summary_columns_rows(row: dict[str, Any], col: dict[str, Any], n: int) -> None:
    """Fill the run_summaries columns of a column's run (`row`, changed in place) from its outcome `col`."""
    row.update(collapsed=col["collapsed"], lowest_fallen=col["lowest_fallen"],
               max_residual_slip=col["max_residual_slip"], max_residual_slip_block=col["max_residual_slip_block"],
               overturned_blocks=fallen_range(col["lowest_fallen"], n))


def sweep_rows(out: Mapping[str, np.ndarray], param, n: int, ok: list[bool]) -> tuple[dict[str, list], list[list[dict]]]:
    """For a sweep's points of a column: (their run_summaries column additions, one list per point) and
    (each point's block rows, [] for a failed point), from their final outputs `out` (name -> one value
    per point) and parameters (`param(name)`: one value per point)."""
    count = len(ok)
    cols: dict[str, list] = {k: [None] * count for k in ("collapsed", "lowest_fallen", "max_residual_slip",
                                                        "max_residual_slip_block", "overturned_blocks")}
    blocks: list[list[dict]] = []
    sizes = {f"block{k}.{s}": np.broadcast_to(np.asarray(param(f"block{k}.{s}"), dtype=float), (count,))
             for k in range(1, n + 1) for s in ("halfWidth", "halfHeight", "mass", "centreX", "centreY", "inertia")}
    outlines = {f"block{k}.outline": np.broadcast_to(np.asarray(param(f"block{k}.outline"), dtype=object), (count,))
                for k in range(1, n + 1)}
    for i in range(count):
        if not ok[i]:
            blocks.append([])
            continue
        final = {name: np.asarray(col)[i].item() for name, col in out.items() if name.startswith("block")}
        p = {"nBlocks": n, **{k: float(v[i]) for k, v in sizes.items()},
             **{k: v[i] if isinstance(v[i], str) else "" for k, v in outlines.items()}}
        rows = block_rows(final, p)
        row: dict[str, Any] = {}
        summary_columns_rows(row, column_outcome(rows), n)
        for k, v in row.items():
            cols[k][i] = v
        blocks.append(rows)
    return cols, blocks


def format_table(s: dict[str, Any]) -> list[str]:
    """A column's summary lines: its outcome, then one row per block (runners simulate)."""
    col, rows = s["column"], s["per_block"]
    if col["collapsed"]:
        k = col["lowest_fallen"]
        what = ("overturned" if any(r["overturned"] and not r["fell_off"] for r in rows if r["block"] == k)
                else f"fell off block {k - 1}")
        gone = f"block {k} {what}" + (f", taking blocks {k + 1}-{len(rows)} with it" if k + 1 < len(rows) else
                                      f", taking block {k + 1} with it" if k < len(rows) else "")
        when = "" if col.get("collapse_time_s") is None else f" at t = {col['collapse_time_s']:.4f} s"
        outcome = f"collapse: {gone}{when}"
    else:
        outcome = "standing: no block overturned or fell off"
    res = col["max_residual_slip"]
    lines = [f"column           {outcome}"]
    if res is not None:
        lines.append(f"dislocation      largest residual {1e3 * res:.3g} mm (block {col['max_residual_slip_block']} on "
                     f"{'the ground' if col['max_residual_slip_block'] == 1 else 'block ' + str(col['max_residual_slip_block'] - 1)}),"
                     f" largest peak {1e3 * (col['max_abs_slip'] or 0.0):.3g} mm (standing blocks)")
    lines.append("block  on        peak |theta|  /alpha    peak |slip|   residual slip  outcome")
    for r in rows:
        on = "ground" if r["block"] == 1 else f"block {r['block'] - 1}"
        gone = "fell off" if r["fell_off"] else "overturned" if r["overturned"] else r["final_mode"]
        ratio = "-" if r["peak_over_alpha"] is None else f"{r['peak_over_alpha']:.4f}"
        theta = "-" if r["peak_over_alpha"] is None else f"{r['max_abs_theta']:.5f} rad"
        lines.append(f"{r['block']:<6} {on:<9} {theta:<13} {ratio:<9} {1e3 * r['max_abs_slip']:>8.3f} mm  "
                     f"{1e3 * r['residual_slip']:>+10.3f} mm  {gone}")
    return lines
