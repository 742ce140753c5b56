"""runners bench --interfaces: one run through each FMI interface, measured in one process."""

from __future__ import annotations

from runners.analysis.bench_interfaces import SCENES, run_interface_bench


def test_every_interface_is_timed_and_checked_against_co_simulation(fmu_path, fmu3_path):
    table = run_interface_bench(fmu_path, fmu3_path, repeats=1)
    rows = [[c.strip() for c in line.strip("|").split("|")] for line in table.splitlines()
            if line.startswith("| ") and not line.startswith("| scene")]
    assert len(rows) == 4 * len(SCENES)
    by = {(r[0], r[1]): r for r in rows}
    for scene, _ in SCENES:
        cs = by[(scene, "FMI 2.0 Co-Simulation")]
        fmi3 = by[(scene, "FMI 3.0 Co-Simulation, early return at events")]
        cvode = by[(scene, "FMI 2.0 Model Exchange, fmpy CVode rtol 1e-10")]
        assert float(cs[2]) > 0 and float(cs[3]) == 1.0
        assert fmi3[4] == cs[4] and float(fmi3[5]) == 0.0  # the same trajectory
        assert cvode[4] == cs[4] and float(cvode[5]) < 1e-7
        assert all(float(r[2]) > 0 for r in rows if r[0] == scene)
