"""runners bench's two-block rocking–sliding rows (issue 27): the harness's two-block scenes again
with contact.model = 1 (mu 5 at both contacts: nothing slides) and a statue on a plinth that slides,
with their cost against the rigid stack's."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest

from runners.analysis import bench
from runners.engine.fmu import FMUError, RockingFMU


def has_sliding_stack(fmu_path: Path) -> bool:
    with RockingFMU(fmu_path) as fmu:
        try:
            fmu.validate({**bench.STACK_FREE, "contact.model": 1})
        except FMUError:
            return False
    return True


@pytest.fixture
def native(fmu_path, tmp_path):
    return bench._compile_native(fmu_path, tmp_path)


def test_the_custom_form_runs_the_harness_rows_two_block_scenes(fmu_path, native):
    """The parameters the new rows start from are the harness's own two-block rows: the custom
    form of each gives the impacts the harness's row gives."""
    rows = {r[0]: r for r in bench._native_rows(*native, 1)}
    timer = bench._Custom(native, fmu_path)
    for rigid, params, stop, _ in bench.STACK_SLIDING_CASES:
        if rigid in rows:
            us, impacts = timer.time(params, stop, 1)
            assert us > 0 and impacts == int(rows[rigid][2]) > 0, rigid


def test_the_rocking_sliding_stack_rows_sit_next_to_the_two_block_rows(fmu_path, native):
    if not has_sliding_stack(fmu_path):
        assert bench._stack_sliding_rows(fmu_path, native, 1) == []  # a build before it: no rows, no error
        pytest.skip("the FMU has no rocking-sliding stack yet")
    stack = bench._stack_sliding_rows(fmu_path, native, 1)
    rows = {r[0]: r for r in bench._native_rows(*native, 1)}
    timed = {r[0]: r for r, _ in stack}
    for rigid, params, stop, what in bench.STACK_SLIDING_CASES:  # each case a row, or the FMU's one-line refusal
        name = bench._stack_sliding_name(rigid, what)
        short = rigid.removeprefix("two blocks, ")
        head = f"- not run with the rocking-sliding stack, {short}:"
        refusal = [line for line in stack.refused if line.startswith(head)]
        assert (name in timed) != bool(refusal) and all("\n" not in line for line in refusal), name
    assert bench._stack_sliding_name(*bench.STACK_SLIDING_CASES[0][::3]) in timed  # the free pair: a harness row
    assert bench.STATUE in timed and bench.STATUE not in rows  # the statue's rigid twin, timed with them
    for rigid, params, stop, what in bench.STACK_NOTHING_SLIDES:  # mu 5: nothing slides, the rigid stack's impacts
        row = timed.get(bench._stack_sliding_name(rigid, what))
        twin = rows.get(rigid) or timed[rigid]
        assert row is None or (row[2] == twin[2] and row[3] == twin[3]), (row, twin)
    with RockingFMU(fmu_path) as fmu:  # nothing slides at mu 5; the plinth row's block 1 really slides on the floor
        for r, (p, stop) in stack:
            if "rocking-sliding" not in r[0]:
                continue
            out = fmu.run(p, stop, stop, outputs=["block1.maxAbsSlip", "block2.maxAbsSlip", "slides"],
                          events=False).outputs
            if "the plinth slides" in r[0]:
                assert out["block1.maxAbsSlip"][-1] > 1e-3, r[0]
            elif r[0].startswith(f"two blocks, rocking-sliding, mu {bench.STACK_MU:g}:"):
                assert out["block1.maxAbsSlip"][-1] == out["block2.maxAbsSlip"][-1] == out["slides"][-1] == 0, r[0]
    lines = bench._stack_sliding_ratios(list(rows.values()), stack, bench._Custom(native, fmu_path))
    ratios = [line for line in lines if line.startswith("- rocking-sliding stack")]
    assert len(ratios) == len(bench.STACK_SLIDING_CASES) - len(stack.refused)
    if stack.refused:  # under the ratios
        assert lines[-len(stack.refused):] == stack.refused


@pytest.mark.slow  # the whole native benchmark, and valgrind's counts where installed
def test_runners_bench_reports_the_stacks_ratio_in_time_and_instructions(fmu_path):
    if not has_sliding_stack(fmu_path):
        pytest.skip("the FMU has no rocking-sliding stack yet")
    text = bench.run_native_bench(fmu_path, repeats=1)
    table = [line for line in text.splitlines() if line.startswith("| two blocks")]
    first = next(i for i, line in enumerate(table) if "rocking-sliding" in line)
    assert all("rocking-sliding" not in line for line in table[:first])  # after the rigid two-block rows
    pattern = r"^- rocking-sliding stack where nothing slides, .*: (\d+\.\d+)x the rigid stack's time"
    if shutil.which("valgrind"):
        pattern += r", (\d+\.\d+)x its instructions$"
    found = [re.match(pattern, line) for line in text.splitlines()]
    refused = sum(line.startswith("- not run with the rocking-sliding stack") for line in text.splitlines())
    assert 1 <= sum(m is not None for m in found) <= len(bench.STACK_NOTHING_SLIDES)
    assert sum(m is not None for m in found) + refused >= len(bench.STACK_NOTHING_SLIDES)
