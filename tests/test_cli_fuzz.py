"""Randomised command lines (hypothesis): malformed scenes, grids, options and files given to
the real ``runners`` commands. Every outcome is exit 0 with a result, or a one-line error
with a non-zero exit and nothing stored; never a traceback, never a partial row.

The examples are drawn from a fixed seed (reproducible in CI); ROCKING_FUZZ_EXAMPLES=N
draws N per test from a fresh seed to search further."""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from sqlalchemy import func, inspect, select

from db.schema import Measurement, Record, Run, Scene, Sweep
from db.session import open_database
from runners.engine.scene import KINDS, LAWS, SCHEMA
from tests.conftest import run_cli

ROOT = Path(__file__).resolve().parent.parent
EXTRA = int(os.environ.get("ROCKING_FUZZ_EXAMPLES", "0"))


def fuzz_settings(n: int):
    return settings(max_examples=EXTRA or n, deadline=None, derandomize=not EXTRA, database=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture,
                                           HealthCheck.data_too_large])


# ------------------------------------------------------------------ strategies

NUMBERS = st.one_of(
    st.sampled_from([0, -1, 1, 0.5, 2.0, 1e-300, 1e300, 1e-9, 1e9, math.nan, math.inf, -math.inf, 0.1, 7.0]),
    st.floats(min_value=-50, max_value=50),
    st.integers(min_value=-10**20, max_value=10**20),
)
CHOICES = st.sampled_from([*KINDS, *LAWS, "record", "", "RICKER", "sine_pulse"])
VALUES = st.one_of(NUMBERS, NUMBERS, CHOICES, st.booleans(), st.text(max_size=8),
                   st.lists(st.integers(0, 3), max_size=2))
# small stop times keep every accepted scene quick; the others must be refused
STOP_TIMES = st.sampled_from([0.3, 1.0, 2.5, 0.0, -1.0, math.nan, math.inf, 1e7, 1e-12, "5"])


def toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf") if math.isinf(v) else repr(v)
    if isinstance(v, int):
        return str(v) if abs(v) < 2**63 else repr(float(v))  # TOML integers are 64-bit
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    return json.dumps(v)  # a TOML basic string


@st.composite
def scenes(draw) -> str:
    """A scene file's text: known tables and keys with random values, sometimes an unknown
    table or key, sometimes cut short or with a stray character."""
    lines = []
    tables = draw(st.lists(st.sampled_from([*SCHEMA, "blocks"]), unique=True, max_size=4))
    for table in tables:
        lines.append(f"[{table}]")
        keys = draw(st.lists(st.sampled_from([*SCHEMA.get(table, {"x": 0}), "colour"]), unique=True, max_size=4))
        for key in keys:
            value = draw(STOP_TIMES) if key == "stop_time" else draw(VALUES)
            lines.append(f"{key} = {toml_value(value)}")
    if "simulation" not in tables:  # keep accepted scenes short
        lines += ["[simulation]", f"stop_time = {toml_value(draw(STOP_TIMES))}"]
    text = "\n".join(lines) + "\n"
    damage = draw(st.sampled_from(["none"] * 6 + ["cut", "stray", "binary"]))
    if damage == "cut":
        text = text[:draw(st.integers(0, len(text)))]
    elif damage == "stray":
        i = draw(st.integers(0, len(text)))
        text = text[:i] + draw(st.sampled_from(["=", "[", "\"", "\x00", "é", "\ufeff"])) + text[i:]
    elif damage == "binary":
        return draw(st.binary(max_size=64)).decode("latin-1")
    return text


OPTION_VALUES = st.one_of(st.sampled_from(["0", "-1", "nan", "inf", "1e400", "abc", "", "1e-9", "0.5", "2", "1e6",
                                           "0x10", "1_000", " 1", "9" * 30]),
                          st.floats(allow_nan=False, allow_infinity=False).map(repr))
AXIS_NAMES = st.sampled_from(["w", "a", "scale", "omega_g/p", "excitation.frequency", "excitation.amplitude",
                              "block1.halfWidth", "block2.mass", "restitution.eta", "nope", "", "g"])
AXIS_RANGES = st.one_of(
    st.tuples(st.sampled_from(["1", "0", "-1", "nan", "1e300", "x"]), st.sampled_from(["2", "12", "inf", "-5"]),
              st.sampled_from(["1", "2", "3", "0", "-2", "1.5", "99999999999"])).map(":".join),
    st.sampled_from(["", "1:2", "1:2:3:4", "::", "1:2:x"]))
GRIDS = st.tuples(AXIS_NAMES, AXIS_RANGES).map(lambda t: f"{t[0]}={t[1]}")


def counts(db: str) -> dict[str, int]:
    factory = open_database(db)
    with factory() as s:
        present = set(inspect(factory.kw["bind"]).get_table_names())
        return {m.__tablename__: s.scalar(select(func.count()).select_from(m))
                for m in (Run, Sweep, Scene, Record, Measurement) if m.__tablename__ in present}


def check(p, before: dict[str, int], db: str) -> None:
    """Exit 0, or one line "error: ..." with a non-zero exit and no row added."""
    assert "Traceback" not in p.stderr and "error: unexpected" not in p.stderr, p.stderr
    if p.returncode == 0:
        return
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:"), (p.returncode, p.stderr)
    assert counts(db) == before, f"a failed command stored rows: {p.args}"


@pytest.fixture(scope="module")
def fuzz_db(tmp_path_factory) -> str:
    db = f"sqlite:///{tmp_path_factory.mktemp('fuzz') / 'fuzz.db'}"
    open_database(db)
    return db


# ------------------------------------------------------------------ the tests

@fuzz_settings(60)
@given(text=scenes(), stop=st.one_of(st.none(), OPTION_VALUES), step=st.one_of(st.none(), OPTION_VALUES),
       method=st.sampled_from([None, "fmu", "auto", "scipy", "rk4", "closed-form"]),
       h=st.one_of(st.none(), OPTION_VALUES), rtol=st.one_of(st.none(), OPTION_VALUES))
def test_random_scenes_and_options_to_simulate(fmu_path, fuzz_db, tmp_path_factory, text, stop, step, method, h, rtol):
    scene = tmp_path_factory.mktemp("scene") / "scene.toml"
    scene.write_text(text, encoding="utf-8", errors="surrogatepass")
    args = ["simulate", str(scene)]
    for opt, v in (("--stop-time", stop), ("--step", step), ("--method", method), ("--h", h), ("--rtol", rtol)):
        if v is not None:
            args += [opt, v]
    if stop is None or not stop.replace(".", "").isdigit() or float(stop) > 5:
        args += ["--stop-time", "1"]  # accepted runs stay short (the option given last wins)
    before = counts(fuzz_db)
    p = run_cli(*args, db=fuzz_db, fmu_path=fmu_path)
    check(p, before, fuzz_db)
    if p.returncode == 0:
        assert "stored           run" in p.stdout and counts(fuzz_db)["runs"] == before["runs"] + 1


@fuzz_settings(40)
@given(grids=st.lists(GRIDS, min_size=0, max_size=3), stop=st.one_of(st.none(), OPTION_VALUES),
       scene=st.sampled_from(["sweep_sine_pulse.toml", "free_rocking.toml", "harmonic.toml", "two_blocks_free.toml"]),
       extra=st.sampled_from([[], ["--resume", "1"], ["--workers", "0"], ["--im", "pga=0.1:1:3"], ["--record", "0,x"],
                              ["--records", "nothing-here"], ["--chunk", "5"]]))
def test_random_grids_and_options_to_sweep(fmu_path, fuzz_db, grids, stop, scene, extra):
    args = ["sweep", str(ROOT / "examples" / scene), "--quiet", "--workers", "1", *extra]
    for g in grids:
        args += ["--grid", g]
    if stop is not None:
        args += ["--stop-time", stop]
    before = counts(fuzz_db)
    p = run_cli(*args, db=fuzz_db, fmu_path=fmu_path) if _small(grids) else None
    if p is not None:
        check(p, before, fuzz_db)


def _small(grids: list[str]) -> bool:
    """Grids of at most 200 points (larger ones are accepted and would only take time)."""
    n = 1
    for g in grids:
        try:
            n *= max(1, int(g.rsplit(":", 1)[1]))
        except (IndexError, ValueError):
            pass
    return n <= 200


@fuzz_settings(40)
@given(data=st.one_of(st.binary(max_size=200),
                      st.lists(st.sampled_from(["# units: time=s, acceleration=m/s2", "# sign: +x", "# units: time=ms",
                                                "time,acceleration", "0,0", "0.01,1.5", "0.01,nan", "0.02,1e9",
                                                "0.005,1", "a,b", "1;2", "0,0,0", "\ufeff", "# kind: rotation",
                                                "time,theta", "# station: N\xeemes"]),
                               max_size=8).map(lambda ls: "\n".join(ls).encode("utf-8"))),
       command=st.sampled_from([["records", "import"], ["import-measured"]]),
       suffix=st.sampled_from([".csv", ".AT2", ".txt"]))
def test_random_files_to_import(fmu_path, fuzz_db, tmp_path_factory, data, command, suffix):
    path = tmp_path_factory.mktemp("file") / f"input{suffix}"
    path.write_bytes(data)
    before = counts(fuzz_db)
    p = run_cli(*command, str(path), db=fuzz_db, fmu_path=fmu_path)
    check(p, before, fuzz_db)


@fuzz_settings(40)
@given(command=st.sampled_from([["db", "show", "run"], ["db", "show", "sweep"], ["map"], ["rrd"], ["fragility"],
                                ["ida"], ["calibrate"], ["db", "list"]]),
       ident=st.one_of(st.sampled_from(["1", "0", "-1", "latest", "99999999999999999999999", "x", "1.5", "", "runs"]),
                       st.integers(-5, 10**30).map(str)))
def test_random_ids_to_read_commands(fmu_path, fuzz_db, tmp_path_factory, command, ident):
    out = tmp_path_factory.mktemp("out") / "out.png"
    extra = ["--out", str(out.with_suffix(".rrd"))] if command == ["rrd"] else \
        ["--out", str(out)] if command[0] in ("map", "fragility", "ida") else []
    before = counts(fuzz_db)
    p = run_cli(*command, ident, *extra, db=fuzz_db, fmu_path=fmu_path)
    check(p, before, fuzz_db)
