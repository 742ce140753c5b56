"""Restoring corrupted FMU states: RockingBlock.fmu checks every field of a state before it
adopts it (fmi2SetFMUstate, after fmi2DeSerializeFMUstate), so a state no run leaves is
refused with fmi2Error and the instance goes on unchanged; no state crashes the FMU or
makes fmi2DoStep hang.

The fuzz test mutates serialized states of real runs (one block rocking with a peak pending,
with the Taylor-series integrator, under a record, at rest, overturned; two blocks in each
pattern; states before and in initialisation, after termination and after a failed step) and
restores each in a child process, which steps a restored state a few times; the parent allows
5 s per state and watches for the child's death. Fields are found by diffing states that
differ in a known way (a parameter set or not, a peak pending or not) or by their values,
never from the C layout.
"""

from __future__ import annotations

import math
import os
import pickle
import queue
import struct
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from conftest import PATIENCE, cpu_seconds
from runners.engine.fmu import RockingFMU

SINE = {"excitation.kind": 1, "excitation.amplitude": 5.0, "excitation.frequency": 3.0}
TAYLOR = {**SINE, "solver.method": 1}
TALL = {"nBlocks": 2, "block1.halfWidth": 0.1, "block1.halfHeight": 0.3, "block1.mass": 10.0,
        "block2.halfWidth": 0.1, "block2.halfHeight": 0.2, "block2.mass": 5.0}
STACK = {**TALL, "block1.theta0": 0.05, "block2.theta0": -0.08, "excitation.kind": 3,
         "excitation.frequency": 2.0, "excitation.displacement": 0.04, "excitation.cycles": 0}
LAST_SUCCESSFUL_TIME = 2  # fmi2StatusKind fmi2LastSuccessfulTime
STEPS, STEP = 3, 0.01  # DoSteps after a restore that is accepted
PER_STATE = 5.0  # s of CPU time a child may spend on one state (a busy machine does not stretch it)
ROOT = Path(__file__).resolve().parent.parent


# ------------------------------------------------------------------ runs and their states

class Run:
    """One instance of the FMU, logging its error messages."""

    def __init__(self, fmu: RockingFMU, params: dict | None = None, initialize: bool = True):
        self.fmu = fmu
        self.messages: list[str] = []
        self.s, self._cb = fmu.instantiate(lambda status, cat, msg: self.messages.append(msg))
        self.vr = {n: v.valueReference for n, v in fmu.vars.items()}
        self.s.setupExperiment(startTime=0.0)
        fmu.set_parameters(self.s, params or {})
        if initialize:
            self.s.enterInitializationMode()
            self.s.exitInitializationMode()

    @property
    def time(self) -> float:
        return self.s.getRealStatus(LAST_SUCCESSFUL_TIME)

    def run_to(self, t: float, dt: float = 0.01) -> "Run":
        tc = self.time
        while tc < t - 1e-12:
            h = min(dt, t - tc)
            self.s.doStep(tc, h)
            tc += h
        return self

    def real(self, *names: str) -> list[float]:
        return self.s.getReal([self.vr[n] for n in names])

    def blob(self) -> bytes:
        state = self.s.getFMUstate()
        try:
            return bytes(self.s.serializeFMUstate(state))
        finally:
            self.s.freeFMUstate(state)

    def restore(self, blob: bytes) -> bool:
        """Deserialize and set the state; False (with a message logged) if the FMU refuses it."""
        try:
            state = self.s.deSerializeFMUstate(blob)
        except Exception:
            return False
        try:
            self.s.setFMUstate(state)
            return True
        except Exception:
            return False
        finally:
            self.s.freeFMUstate(state)

    def close(self) -> None:
        self.s.freeInstance()


def ints(blob: bytes) -> np.ndarray:
    return np.frombuffer(blob[: len(blob) // 4 * 4], dtype="<i4")


def int_diffs(a: bytes, b: bytes) -> list[int]:
    """Offsets of the 4-byte aligned fields that differ."""
    return [int(i) * 4 for i in np.nonzero(ints(a) != ints(b))[0]]


def put_int(blob: bytes, offset: int, value: int) -> bytes:
    return blob[:offset] + struct.pack("<i", value) + blob[offset + 4:]


def put_double(blob: bytes, offset: int, value: float) -> bytes:
    return blob[:offset] + struct.pack("<d", value) + blob[offset + 8:]


def offsets_of(blob: bytes, value: float) -> list[int]:
    """8-byte aligned offsets that hold exactly this double."""
    pattern = struct.pack("<d", value)
    return [o for o in range(0, len(blob) - 7, 8) if blob[o:o + 8] == pattern]


def event_times(fmu: RockingFMU, params: dict, stop: float) -> tuple[list[float], list[float]]:
    """Times of the peaks and impacts of a run, read from its outputs at fine steps."""
    r = Run(fmu, params)
    peaks, impacts, seen = [], [], (0, 0)
    try:
        for i in range(int(round(stop / 1e-3))):
            r.s.doStep(i * 1e-3, 1e-3)
            p, k = r.s.getInteger([r.vr["peaks"], r.vr["impacts"]])
            if p != seen[0]:
                peaks.append(r.real("lastPeakTime")[0])
            if k != seen[1]:
                impacts.append(r.real("lastImpactTime")[0])
            seen = (p, k)
    finally:
        r.close()
    return peaks, impacts


def state_before_a_peak(fmu: RockingFMU, params: dict) -> tuple[Run, float]:
    """A run stopped 1 us before its first peak after its first impact: the integrator has
    stepped past the peak, which is located but not yet committed (pending)."""
    peaks, impacts = event_times(fmu, params, 2.0)
    tp = next(p for p in peaks if p > impacts[0])
    return Run(fmu, params).run_to(tp - 1e-6), tp


class Fields:
    """Offsets of fields, each found by diffing two states that differ in a known way."""

    def __init__(self, fmu: RockingFMU):
        # nBlocks: two states before initialisation, with nBlocks = 1 and 2
        r = Run(fmu, initialize=False)
        one = r.blob()
        r.s.setInteger([r.vr["nBlocks"]], [2])
        two = r.blob()
        (self.n_blocks,) = int_diffs(one, two)
        # the String parameters (excitation.file, the blocks' outlines): each one's text buffer, found by the text set
        # there; random mutations leave its unused rest alone
        self.strings: list[tuple[int, int]] = []
        for name in [n for n, v in fmu.vars.items() if v.type == "String" and v.causality == "parameter"]:
            before = r.blob()
            r.s.setString([r.vr[name]], ["x" * 100])
            diff = np.nonzero(np.frombuffer(before, np.uint8) != np.frombuffer(r.blob(), np.uint8))[0]
            assert len(diff) == 100 and diff[-1] - diff[0] == 99, name
            start = end = int(diff[0])
            while one[end] == 0:  # the unused rest of the text buffer (zeros) up to the next parameter
                end += 1
            self.strings.append((start, end // 8 * 8))
            r.s.setString([r.vr[name]], [""])
        r.close()
        # the motion pattern: at rest and rocking from the same start, right after initialisation;
        # the state's pattern and the outputs pattern and atRest change from 1 to 0 together
        rest, rocking = Run(fmu), Run(fmu, {"block1.omega0": 0.5})
        r0, r1 = ints(rest.blob()), ints(rocking.blob())
        self.pattern = [int(i) * 4 for i in np.nonzero((r0 == 1) & (r1 == 0))[0]]
        assert len(self.pattern) == 3, self.pattern
        rest.close()
        rocking.close()
        # nStepPeaks: 1 with a peak pending, 0 once an input change brings the integrator back to the
        # communication point (the peak lies after it), 0 just after an impact (no peak in that step);
        # the flags of a valid step (fValid, denseValid) are 1 just after an impact
        a, _ = state_before_a_peak(fmu, SINE)
        pending = a.blob()
        a.s.setReal([a.vr["ground.ah"]], [1e-9])
        rolled_back = a.blob()
        a.close()
        _, impacts = event_times(fmu, SINE, 0.5)
        c = Run(fmu, SINE).run_to(impacts[0] + 1e-4)
        after_impact = c.blob()
        c.close()
        p, b, i = ints(pending), ints(rolled_back), ints(after_impact)
        (found,) = np.nonzero((p == 1) & (b == 0) & (i == 0))[0]
        self.n_step_peaks = int(found) * 4


@pytest.fixture(scope="module")
def fields(fmu) -> Fields:
    return Fields(fmu)


def assert_refused_and_unchanged(run: Run, blob: bytes, text: str | tuple[str, ...]) -> None:
    """The restore fails with a one-line reason containing text; the instance keeps its state."""
    before = run.blob()
    n = len(run.messages)
    assert not run.restore(blob), "the corrupted state was accepted"
    msgs = run.messages[n:]
    texts = (text,) if isinstance(text, str) else text
    assert msgs and any(t in msgs[-1] for t in texts) and "\n" not in msgs[-1], msgs
    assert run.blob() == before


# ------------------------------------------------------------------ targeted corruptions

def test_restored_state_with_out_of_range_peak_count_is_refused(fmu, fields):
    run, _ = state_before_a_peak(fmu, SINE)
    blob = run.blob()
    assert ints(blob)[fields.n_step_peaks // 4] == 1
    for value in (5, 77, -1, 2**31 - 1, -2**31):
        assert_refused_and_unchanged(run, put_int(blob, fields.n_step_peaks, value), "nStepPeaks")
    # the Taylor-series integrator locates at most two peaks in a step
    taylor, _ = state_before_a_peak(fmu, TAYLOR)
    assert_refused_and_unchanged(taylor, put_int(taylor.blob(), fields.n_step_peaks, 3), "nStepPeaks")
    # two blocks locate none
    stack = Run(fmu, STACK).run_to(1.0)
    assert_refused_and_unchanged(stack, put_int(stack.blob(), fields.n_step_peaks, 1), "nStepPeaks")
    for r in (run, taylor, stack):
        r.close()


def _indicator_record(blob: bytes, corner: int) -> tuple[int, int] | None:
    """Offset of the contact engine's stored end-of-step indicators of one block rocking on `corner`
    (+1 right, -1 left) and the length n of their arrays, found by their values (never from the C
    layout): their count 4, then their kinds (the closed corner's opening 1, the other corner's
    landing 4, slip 2, overturn 5, in the corners' order), the n - 4 unused kinds 0, the n bodies 0,
    then the corners (-1, +1, the pivot, +-1)."""
    kinds = [4, 1, 2, 5] if corner > 0 else [1, 4, 2, 5]
    v = ints(blob)
    for j in range(len(v) - 40):
        if v[j] == 4 and list(v[j + 1:j + 5]) == kinds:
            nonzero = np.nonzero(v[j + 5:])[0]
            zeros = int(nonzero[0]) if len(nonzero) else 0
            start = j + 5 + zeros
            if zeros >= 4 and zeros % 2 == 0 and list(v[start:start + 3]) == [-1, 1, corner]:
                return int(j) * 4, (zeros + 4) // 2
    return None


def test_restored_state_with_corrupt_end_of_step_indicators_is_refused(fmu):
    """The contact engine stores the indicators of the last step's end (their count, kinds, bodies and
    corners), which the next step starts from: a count beyond the array or a body the stack does not
    have is refused with a one-line reason, not read out of bounds."""
    run = Run(fmu, {**SINE, "contact.model": 1, "contact.muGround": 100.0})
    offset = None
    for t in np.arange(0.05, 1.0, 0.01):
        run.run_to(float(t))
        blob = run.blob()
        theta = run.real("block1.theta")[0]
        found = _indicator_record(blob, 1 if theta > 0 else -1) if theta else None
        if found is not None:
            break
    assert found is not None, "no state with stored end-of-step indicators found"
    offset, n = found
    assert run.restore(blob)  # the state as it is is accepted
    for count in (n + 1, 1000, -1):
        assert_refused_and_unchanged(run, put_int(blob, offset, count), "indicators")
    assert_refused_and_unchanged(run, put_int(blob, offset + 4 * (n + 1), 1), "indicator 0")  # body 2 of one block
    assert_refused_and_unchanged(run, put_int(blob, offset + 4, 9), "indicator 0")  # no such kind
    run.close()


def test_restored_state_with_wrong_block_count_is_refused(fmu, fields):
    stack = Run(fmu, STACK).run_to(1.0)
    blob = stack.blob()
    assert ints(blob)[fields.n_blocks // 4] == 2
    for value in (0, 9, -1):
        assert_refused_and_unchanged(stack, put_int(blob, fields.n_blocks, value), "nBlocks")
    for value in (3, 8):  # a column's count, its blocks' values left those of the stack
        assert_refused_and_unchanged(stack, put_int(blob, fields.n_blocks, value), "does not match its own parameters")
    # Two rocking blocks relabelled as one block, their parameters and derived values made exactly
    # those of one block: every byte that stays put during a run of each and differs between the
    # two (nBlocks, the derived values of a stack) is taken from a one-block run of the same blocks.
    def state_at(params: dict, t: float) -> np.ndarray:
        r = Run(fmu, params).run_to(t)
        b = np.frombuffer(r.blob(), np.uint8)
        r.close()
        return b

    one = {**STACK, "nBlocks": 1}
    o1, o2, t1, t2 = state_at(one, 0.5), state_at(one, 1.0), state_at(STACK, 0.5), state_at(STACK, 1.0)
    fixed = (o1 == o2) & (t1 == t2) & (o2 != t2)
    assert fixed[fields.n_blocks]
    relabelled = t2.copy()
    relabelled[fixed] = o2[fixed]
    assert_refused_and_unchanged(stack, relabelled.tobytes(), ("pattern", "side", "component", "two-block"))
    # and the other way round: a single block's state under two-block parameters
    single = Run(fmu, SINE).run_to(0.5)
    assert_refused_and_unchanged(single, put_int(single.blob(), fields.n_blocks, 2),
                                 "does not match its own parameters")
    stack.close()
    single.close()


def test_restored_state_with_unknown_mode_is_refused(fmu, fields):
    run, _ = state_before_a_peak(fmu, SINE)
    blob = run.blob()
    # out of range, a two-block pattern for one block, and "at rest" while the block rocks
    for offset in fields.pattern:
        assert ints(blob)[offset // 4] == 0  # rocking
        for value in (77, 6, -1, 3, 1):
            assert_refused_and_unchanged(run, put_int(blob, offset, value), ("pattern", "atRest", "rest", "rock"))
    # two blocks: pattern 0 (one block's rocking) is not one of theirs
    stack = Run(fmu, STACK).run_to(1.0)
    sb = stack.blob()
    for offset in fields.pattern:
        assert_refused_and_unchanged(stack, put_int(sb, offset, 0 if ints(sb)[offset // 4] else 7),
                                     ("pattern", "atRest"))
    run.close()
    stack.close()


def test_restored_state_with_nan_angle_is_refused(fmu):
    for params, name in ((SINE, "block1.theta"), (STACK, "block1.theta"), (STACK, "block2.theta")):
        run = Run(fmu, params).run_to(0.61)
        # an input change brings the integrator back to the communication point: the state's angle
        # is then the output's, bit for bit, and can be found by its value
        run.s.setReal([run.vr["ground.ah"]], [1e-9])
        blob = run.blob()
        found = offsets_of(blob, run.real(name)[0])
        assert len(found) >= 2, found  # the output and the state
        for offset in found:
            for value in (math.nan, math.inf, -math.inf):
                assert_refused_and_unchanged(run, put_double(blob, offset, value), "finite")
        run.close()


def test_restored_state_from_the_future_or_the_past_is_refused(fmu):
    """The integrator's time may run ahead of the communication point only by the step that
    covers it; a state whose time lies behind it or far ahead is refused."""
    run, _ = state_before_a_peak(fmu, SINE)
    run.s.setReal([run.vr["ground.ah"]], [1e-9])  # integrator time = communication point
    blob = run.blob()
    tc = run.time
    found = offsets_of(blob, tc)  # the communication point and the integrator's time
    assert len(found) >= 2, found
    for offset in found:
        for value in (tc - 1e-3, tc + 10.0, -1.0, 1e300):
            assert_refused_and_unchanged(run, put_double(blob, offset, value), ("t =", "time", "communication point"))
    run.close()


def test_failed_restore_leaves_instance_usable(fmu, tmp_path):
    """A refused state of another record run changes nothing, not even the instance's record: it
    continues exactly as it would have without the attempt."""
    t = np.arange(0.0, 3.0001, 0.01)
    paths = []
    for k, f in enumerate((1.5, 2.5)):
        path = tmp_path / f"record{k}.txt"
        np.savetxt(path, np.column_stack([t, 4.0 * np.sin(2 * np.pi * f * t)]), fmt="%.17g")
        paths.append(path)
    a = Run(fmu, {"excitation.kind": 4, "excitation.file": str(paths[0])}).run_to(1.0)
    b = Run(fmu, {"excitation.kind": 4, "excitation.file": str(paths[1])}).run_to(1.0)
    mine = a.blob()
    a.s.doStep(1.0, 1.0)
    expected = a.real("block1.theta", "block1.omega", "energy")
    pattern, impacts = a.s.getInteger([a.vr["pattern"], a.vr["impacts"]])
    assert pattern == 0 and impacts >= 3  # still rocking: the record matters
    assert a.restore(mine)
    # the other run's state: its window end one step of the last digit up (a derived value), and a
    # NaN angle (a state value); its record file is read and matches, before the state is refused
    other = b.blob()
    (end,) = offsets_of(other, 3.0)  # where the record's window ends
    bad_end = put_double(other, end, np.nextafter(3.0, 4.0))
    b.s.setReal([b.vr["ground.ah"]], [1e-9])
    rolled = b.blob()
    nan_angle = [put_double(rolled, o, math.nan) for o in offsets_of(rolled, b.real("block1.theta")[0])]
    for blob, text in [(bad_end, "does not match its own parameters")] + [(x, "finite") for x in nan_angle]:
        assert_refused_and_unchanged(a, blob, text)
        a.s.doStep(1.0, 1.0)
        assert a.real("block1.theta", "block1.omega", "energy") == expected
        assert a.restore(mine)
    # and the other state itself is taken, with its record: it continues as the other run does
    for r in (a, b):
        assert r.restore(other)
        r.s.doStep(1.0, 1.0)
    assert a.real("block1.theta", "block1.omega", "energy") == b.real("block1.theta", "block1.omega", "energy")
    a.close()
    b.close()


def test_states_of_every_phase_and_block_count_round_trip(fmu):
    """The checks refuse nothing a run leaves: states before, during and after initialisation, while
    rocking, at rest, overturned, after termination and after a failed step are all taken back."""
    cases = [
        (SINE, None), (SINE, 0.0), (SINE, 0.3), (SINE, 1.7), ({"block1.theta0": 0.3}, 2.5),
        (TAYLOR, 0.4), (STACK, 0.0), (STACK, 1.3), ({**TALL, "block2.theta0": 0.1}, 0.7),
        ({**SINE, "excitation.amplitude": 9.0}, 2.0),
    ]
    for params, t in cases:
        r = Run(fmu, params, initialize=t is not None)
        if t:
            r.run_to(t)
        blob = r.blob()
        assert r.restore(blob), r.messages
        assert r.blob() == blob
        r.close()
    init = Run(fmu, SINE, initialize=False)
    init.s.enterInitializationMode()
    assert init.restore(init.blob()), init.messages
    init.close()
    done = Run(fmu, SINE).run_to(0.5)
    done.s.terminate()
    assert done.restore(done.blob()), done.messages
    done.close()
    failed = Run(fmu, SINE)
    failed.s.setReal([failed.vr["ground.ah"]], [1e300])  # the step finds no step size
    with pytest.raises(Exception):
        failed.s.doStep(0.0, 0.1)
    assert failed.restore(failed.blob()), failed.messages
    failed.close()


def test_a_time_too_large_to_resolve_the_excitation_is_an_error_not_a_hang(fmu_path):
    """At rest at t = 1e20 s the next quarter period of a 1 Hz table motion is not a different
    double: the search for uplift cannot advance, and says so (it used to loop for ever). In a
    child process, so that a hang fails the test instead of stopping the suite."""
    script = ("import sys\nfrom runners.engine.fmu import RockingFMU\n"
              "with RockingFMU(sys.argv[1]) as f:\n"
              "    msgs = []\n"
              "    s, _ = f.instantiate(lambda st, c, m: msgs.append(m))\n"
              "    s.setupExperiment(startTime=1e20)\n"
              "    f.set_parameters(s, {'excitation.kind': 3, 'excitation.frequency': 1.0,\n"
              "                         'excitation.displacement': 0.01, 'excitation.cycles': 0})\n"
              "    s.enterInitializationMode()\n"
              "    s.exitInitializationMode()\n"
              "    try:\n"
              "        s.doStep(1e20, 1e5)\n"
              "        print('no error')\n"
              "    except Exception:\n"
              "        print(msgs[-1])\n")
    out = subprocess.run([sys.executable, "-c", script, str(fmu_path)], capture_output=True, text=True,
                         timeout=PATIENCE, cwd=ROOT).stdout
    assert "too large to resolve the excitation" in out, out


# ------------------------------------------------------------------ fuzz

INT_VALUES = [-1, 2, 5, 77, 2**31 - 1, -2**31, 3, 1 << 16, 6, 0]
DOUBLE_VALUES = [math.nan, math.inf, -math.inf, 1e300, -1e300, 5e-324, -1.0, 0.0, 1e-300, 4.0]


def base_states(fmu: RockingFMU, record: Path) -> list[tuple[str, bytes]]:
    """Serialized states of real runs: one block rocking with a peak pending (Dormand-Prince,
    Taylor, a record), at rest, overturned; two blocks in every pattern; before and in
    initialisation, after termination and after a failed step."""
    out = []
    for name, params in [("sine", SINE), ("taylor", TAYLOR),
                         ("record", {"excitation.kind": 4, "excitation.file": str(record)})]:
        run, _ = state_before_a_peak(fmu, params)
        out.append((name, run.blob()))
        run.close()
    upper = {**TALL, "block2.theta0": 0.1}  # block 2 rocks alone, then both, locked, rest
    slender = {"nBlocks": 2, "block1.halfWidth": 0.2, "block1.halfHeight": 0.2, "block1.mass": 20.0,
               "block2.halfWidth": 0.05, "block2.halfHeight": 0.25, "block2.mass": 3.0, "excitation.kind": 1,
               "excitation.amplitude": 3.0, "excitation.frequency": 2.0}
    for name, params, t in [("rest", {"block1.theta0": 0.3}, 4.0), ("overturned", {**SINE, "excitation.amplitude": 9.0}, 2.0),
                            ("upper", upper, 0.05), ("both", upper, 0.2), ("locked", STACK, 1.0),
                            ("upper-pulse", slender, 0.5), ("stack-rest", upper, 3.5)]:
        run = Run(fmu, params).run_to(t)
        out.append((name, run.blob()))
        run.close()
    instantiated = Run(fmu, SINE, initialize=False)
    out.append(("instantiated", instantiated.blob()))
    instantiated.s.enterInitializationMode()
    out.append(("initialization", instantiated.blob()))
    instantiated.close()
    done = Run(fmu, SINE).run_to(0.8)
    done.s.terminate()
    out.append(("terminated", done.blob()))
    done.close()
    failed = Run(fmu, SINE)
    failed.s.setReal([failed.vr["ground.ah"]], [1e300])  # the step finds no step size
    with pytest.raises(Exception):
        failed.s.doStep(0.0, 0.1)
    out.append(("failed", failed.blob()))
    failed.close()
    return out


def _patch(blob: bytes, data: bytes) -> bytes | tuple[int, bytes]:
    """A mutated state as the bytes it changed, (offset, those bytes) (the state itself where its length changed):
    thousands of 60 kB states would not fit in memory."""
    if len(data) != len(blob):
        return data
    diff = np.nonzero(np.frombuffer(blob, np.uint8) != np.frombuffer(data, np.uint8))[0]
    if not len(diff):
        return (0, b"")
    return int(diff[0]), data[int(diff[0]):int(diff[-1]) + 1]


def patched(blob: bytes, data: bytes | tuple[int, bytes]) -> bytes:
    """The state a case (mutations) stands for, on its base `blob`."""
    if isinstance(data, bytes):
        return data
    offset, payload = data
    return blob[:offset] + payload + blob[offset + len(payload):]


def mutations(blob: bytes, fields: Fields, seed: int, checked: bool = True) -> list[tuple[str, object, bool]]:
    """(label, bytes, must be refused) for one state: every 8-byte field set to an absurd double,
    every 4-byte field to an absurd integer (values rotating with the seed), the named fields out of
    range (refused unless the state is not checked yet: parameters set before initialisation are
    checked, and the state built, when the instance initialises), random bit flips and byte runs,
    truncations and extensions (always refused)."""
    rng = np.random.default_rng(seed)
    skip = set().union(*(range(a + 8, b) for a, b in fields.strings))  # the String parameters' unused buffers
    out: list[tuple[str, object, bool]] = []

    def add(case: tuple[str, bytes, bool]) -> None:  # (each kept as the bytes it changes)
        out.append((case[0], _patch(blob, case[1]), case[2]))
    for k, o in enumerate(range(0, len(blob) - 7, 8)):
        if o not in skip:
            v = DOUBLE_VALUES[(k + seed) % len(DOUBLE_VALUES)]
            add((f"double@{o}={v!r}", put_double(blob, o, v), False))
    for k, o in enumerate(range(0, len(blob) - 3, 4)):
        if o not in skip:
            v = INT_VALUES[(k + seed) % len(INT_VALUES)]
            add((f"int@{o}={v}", put_int(blob, o, v), False))
    named = [(fields.n_step_peaks, v) for v in (5, 77, -1, 2**31 - 1)] + \
            [(fields.n_blocks, v) for v in (0, 3, 7, -1)] + [(o, 77) for o in fields.pattern]
    for o, v in named:
        add((f"field@{o}={v}", put_int(blob, o, v), checked))
    positions = np.array([o for o in range(len(blob)) if o not in skip])
    for k in range(150):
        b = bytearray(blob)
        for _ in range(1 + k % 3):
            o = int(rng.choice(positions))
            b[o] ^= 1 << int(rng.integers(8))
        add((f"flip#{k}", bytes(b), False))
    for k in range(100):
        o, n = int(rng.choice(positions)), int(rng.integers(1, 17))
        b = bytearray(blob)
        b[o:o + n] = rng.integers(0, 256, size=len(b[o:o + n]), dtype=np.uint8).tobytes()
        add((f"bytes#{k}@{o}+{n}", bytes(b), False))
    for n in [0, 1, 4, 8, 100, len(blob) // 2] + [int(x) for x in rng.integers(1, len(blob), 8)]:
        add((f"truncated-{n}", blob[: len(blob) - n] if n else b"", True))
    add(("extended-1", blob + b"\0", True))
    add(("extended-8", blob + b"\0" * 8, True))
    return out


def _worker(fmu_path: str, unzipdir: str, cases_path: str, start: int) -> None:
    """Child process: restore cases[start:] one by one into one instance, after its base state;
    print one line per case: index, then 'refused' or 'taken' (or 'BAD reason')."""
    with open(cases_path, "rb") as fh:
        bases, cases = pickle.load(fh)
    fmu = RockingFMU(fmu_path, unzipdir=unzipdir)
    outputs = [v.valueReference for v in fmu.model_description.modelVariables
               if v.causality == "output" and v.type == "Real"]

    def fresh() -> tuple[Run, list]:
        run = Run(fmu, initialize=False)
        return run, [run.s.deSerializeFMUstate(b) for b in bases]

    run, pristine = fresh()
    print("ready", flush=True)
    for i in range(start, len(cases)):
        base, data, _ = cases[i]
        data = patched(bases[base], data)
        try:
            run.s.setFMUstate(pristine[base])
            status = "refused"
            if run.restore(data):
                status = "taken"
                try:  # a state in initialization mode leaves it first (an error in any other phase)
                    run.s.exitInitializationMode()
                except Exception:
                    pass
                for k in range(STEPS + 1):  # outputs finite, or an error
                    try:
                        values = run.s.getReal(outputs)
                    except Exception:
                        break
                    if not all(math.isfinite(x) for x in values):
                        status = "BAD non-finite output"
                        break
                    try:
                        if k < STEPS:
                            run.s.doStep(run.time, STEP)
                    except Exception:
                        break
            elif run.blob() != bases[base]:
                status = "BAD a refused state changed the instance"
        except Exception as e:  # e.g. the instance no longer takes its base state back
            status = f"BAD {type(e).__name__}: {e}"
            run, pristine = fresh()
        print(i, status, flush=True)
    print("done", flush=True)


def _next_line(lines: queue.Queue, pid: int) -> str | None:
    """The worker's next line; queue.Empty once it has spent PER_STATE s of CPU time without one
    (a hang: time a busy machine does not give it does not count), or PATIENCE s of wall time."""
    start, end = cpu_seconds(pid), time.monotonic() + PATIENCE
    while True:
        try:
            return lines.get(timeout=PER_STATE)
        except queue.Empty:
            if cpu_seconds(pid) - start > PER_STATE or time.monotonic() > end:
                raise


def _fuzz(fmu_path: Path, unzipdir: str, cases_path: Path, n: int, log: Path) -> dict[int, str]:
    """Run the worker over all cases, restarting it after a crash or a hang (the case at fault is
    recorded as 'CRASH ...' or 'HANG'); returns the status of every case."""
    status: dict[int, str] = {}
    start = 0
    while start < n and sum(s.startswith(("CRASH", "HANG")) for s in status.values()) < 10:
        with open(log, "ab") as err:
            proc = subprocess.Popen([sys.executable, __file__, str(fmu_path), unzipdir, str(cases_path), str(start)],
                                    stdout=subprocess.PIPE, stderr=err, text=True, cwd=ROOT, env=os.environ.copy())
        lines: queue.Queue = queue.Queue()
        threading.Thread(target=lambda: [lines.put(x) for x in proc.stdout] + [lines.put(None)], daemon=True).start()
        line = lines.get(timeout=PATIENCE)  # start-up (slow under the sanitizers)
        assert line and line.strip() == "ready", (line, log.read_text()[-3000:])
        i = start
        while i < n:
            try:
                line = _next_line(lines, proc.pid)
            except queue.Empty:
                proc.kill()
                status[i] = "HANG"
                break
            if line is None:  # the child died on case i
                proc.wait()
                status[i] = f"CRASH (exit {proc.returncode})"
                break
            if line.strip() == "done":
                break
            k, s = line.rstrip("\n").split(" ", 1)
            status[int(k)] = s
            i = int(k) + 1
        proc.wait()
        start = i + 1 if i < n else n
    return status


def test_fuzzed_states_are_refused_or_step_without_crash_or_hang(fmu, fmu_path, fields, tmp_path):
    t = np.arange(0.0, 2.0001, 0.01)
    record = tmp_path / "record.txt"
    np.savetxt(record, np.column_stack([t, 4.0 * np.sin(2 * np.pi * 1.5 * t)]), fmt="%.17g")
    bases = base_states(fmu, record)
    cases, labels = [], []
    for k, (name, blob) in enumerate(bases):
        for label, data, must in mutations(blob, fields, seed=k, checked=name != "instantiated"):
            cases.append((k, data, must))
            labels.append(f"{name}:{label}")
    assert len(cases) >= 1000
    path = tmp_path / "cases.pickle"
    path.write_bytes(pickle.dumps(([b for _, b in bases], cases)))
    log = tmp_path / "children.log"
    t0 = time.perf_counter()
    status = _fuzz(fmu_path, fmu.unzipdir, path, len(cases), log)
    elapsed = time.perf_counter() - t0
    bad = {labels[i]: s for i, s in status.items() if s not in ("refused", "taken")}
    kinds = sorted({s.split(":")[0] for s in bad.values()})
    assert not bad, (f"{len(bad)} of {len(cases)} states: {kinds}", list(bad.items())[:20], log.read_text()[-1500:])
    assert len(status) == len(cases)
    missed = [labels[i] for i, (_, _, must) in enumerate(cases) if must and status[i] != "refused"]
    assert not missed, missed
    n_refused = sum(s == "refused" for s in status.values())
    print(f"{len(cases)} corrupted states in {elapsed:.1f} s: {n_refused} refused, {len(cases) - n_refused} taken")
    assert n_refused > len(cases) // 2


if __name__ == "__main__":
    _worker(sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4]))
