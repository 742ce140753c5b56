"""A hostile importer against RockingBlock.fmu's FMI 2.0 interface, Model Exchange above all:
every function in every phase, NULL and wrongly sized arrays, non-finite and backward times,
states set where no solver would put them, long Euler steps, inputs that lift or tip the
block, the event iteration called over and over or not at all; in Co-Simulation, FMU states
around a step that ends the run at an overturn, tolerances at and beyond their limits; many
instances of both kinds in threads.

Every call goes to the compiled FMU through ctypes with the status returned, not raised, so
that a test sees exactly which status a call gives. Also run against the AddressSanitizer
and UBSan build (make sanitize)."""

from __future__ import annotations

import math
import random
import threading
from ctypes import POINTER, byref, c_char, c_double, c_int, c_size_t, c_uint, c_void_p

import pytest
from fmpy.fmi2 import (FMU2Model, FMU2Slave, calloc, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                       fmi2CallbackFunctions, fmi2CallbackLoggerTYPE, fmi2EventInfo, free)

from runners.engine.fmu import with_scene_defaults

OK, DISCARD, ERROR = 0, 2, 3
LAST_SUCCESSFUL_TIME, TERMINATED = 2, 3  # fmi2StatusKind
PI2 = math.pi / 2

# argument types of the functions called here (fmpy declares only those of its own class)
_ARGS = {
    "fmi2SetupExperiment": [c_int, c_double, c_double, c_int, c_double],
    "fmi2EnterInitializationMode": [], "fmi2ExitInitializationMode": [], "fmi2Terminate": [], "fmi2Reset": [],
    "fmi2SetReal": [POINTER(c_uint), c_size_t, POINTER(c_double)],
    "fmi2GetReal": [POINTER(c_uint), c_size_t, POINTER(c_double)],
    "fmi2SetInteger": [POINTER(c_uint), c_size_t, POINTER(c_int)],
    "fmi2GetInteger": [POINTER(c_uint), c_size_t, POINTER(c_int)],
    "fmi2SetBoolean": [POINTER(c_uint), c_size_t, POINTER(c_int)],
    "fmi2GetBoolean": [POINTER(c_uint), c_size_t, POINTER(c_int)],
    "fmi2SetTime": [c_double],
    "fmi2SetContinuousStates": [POINTER(c_double), c_size_t],
    "fmi2GetContinuousStates": [POINTER(c_double), c_size_t],
    "fmi2GetDerivatives": [POINTER(c_double), c_size_t],
    "fmi2GetEventIndicators": [POINTER(c_double), c_size_t],
    "fmi2GetNominalsOfContinuousStates": [POINTER(c_double), c_size_t],
    "fmi2NewDiscreteStates": [POINTER(fmi2EventInfo)],
    "fmi2EnterEventMode": [], "fmi2EnterContinuousTimeMode": [],
    "fmi2CompletedIntegratorStep": [c_int, POINTER(c_int), POINTER(c_int)],
    "fmi2DoStep": [c_double, c_double, c_int],
    "fmi2GetRealStatus": [c_int, POINTER(c_double)],
    "fmi2GetBooleanStatus": [c_int, POINTER(c_int)],
    "fmi2GetFMUstate": [POINTER(c_void_p)], "fmi2SetFMUstate": [c_void_p], "fmi2FreeFMUstate": [POINTER(c_void_p)],
    "fmi2SerializedFMUstateSize": [c_void_p, POINTER(c_size_t)],
    "fmi2SerializeFMUstate": [c_void_p, POINTER(c_char), c_size_t],
    "fmi2DeSerializeFMUstate": [POINTER(c_char), c_size_t, POINTER(c_void_p)],
}
_LOAD = threading.Lock()


class Raw:
    """One instance (Model Exchange or Co-Simulation) with its log captured; calls return
    the status."""

    def __init__(self, fmu, kind="ME", name="hostile"):
        self.messages: list[str] = []
        self.fmu = fmu

        def logger(env, instance, status, category, message):
            self.messages.append((message or b"").decode(errors="replace"))

        cb = fmi2CallbackFunctions()
        cb.logger = fmi2CallbackLoggerTYPE(logger)
        cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        self._cb = cb
        md = fmu.model_description
        cls, ident = (FMU2Model, md.modelExchange) if kind == "ME" else (FMU2Slave, md.coSimulation)
        with _LOAD:
            self.model = cls(guid=md.guid, unzipDirectory=fmu.unzipdir, modelIdentifier=ident.modelIdentifier,
                             instanceName=name)
        self.model.instantiate(callbacks=cb, loggingOn=True)
        self.c = c_void_p(self.model.component)
        self.vr = {n: v.valueReference for n, v in fmu.vars.items()}
        self.types = {n: v.type for n, v in fmu.vars.items()}

    def call(self, fn, *args):
        f = getattr(self.model.dll, fn)
        f.argtypes, f.restype = [c_void_p] + _ARGS[fn], c_int
        return f(self.c, *args)

    def free(self):
        self.model.dll.fmi2FreeInstance(self.c)

    def said(self, text, since=0):
        return any(text in m for m in self.messages[since:])

    # variables
    def set(self, **values):
        for name, v in values.items():
            name = name.replace("__", ".")
            t = {"Real": ("fmi2SetReal", c_double), "Boolean": ("fmi2SetBoolean", c_int)}.get(
                self.types[name], ("fmi2SetInteger", c_int))
            st = self.call(t[0], byref(c_uint(self.vr[name])), 1, byref(t[1](v)))
            assert st == OK, (name, v, self.messages[-1:])

    def setp(self, params):
        self.set(**{k.replace(".", "__"): v for k, v in params.items()})

    def get(self, name):
        t = self.types[name]
        fn, ct = ("fmi2GetReal", c_double) if t == "Real" else (
            ("fmi2GetBoolean", c_int) if t == "Boolean" else ("fmi2GetInteger", c_int))
        x = ct()
        assert self.call(fn, byref(c_uint(self.vr[name])), 1, byref(x)) == OK, self.messages[-1:]
        return x.value if t != "Boolean" else bool(x.value)

    # life cycle
    def setup(self, tolerance=None, start=0.0, stop=None):
        return self.call("fmi2SetupExperiment", int(tolerance is not None), tolerance or 0.0, start,
                         int(stop is not None), stop or 0.0)

    def start(self, params=None, iterate=True, **setup):
        assert self.setup(**setup) == OK, self.messages[-1:]
        self.setp(with_scene_defaults(params or {}))  # at rest unless params tilt it
        assert self.call("fmi2EnterInitializationMode") == OK, self.messages[-1:]
        assert self.call("fmi2ExitInitializationMode") == OK, self.messages[-1:]
        if iterate and self.model.__class__ is FMU2Model:
            assert self.nds()[0] == OK

    # Model Exchange
    def nds(self):
        e = fmi2EventInfo()
        st = self.call("fmi2NewDiscreteStates", byref(e))
        return st, dict(needed=e.newDiscreteStatesNeeded, terminate=e.terminateSimulation,
                        changed=e.valuesOfContinuousStatesChanged, timed=e.nextEventTimeDefined,
                        next=e.nextEventTime)

    def array(self, fn, n, size=None):
        a = (c_double * max(size if size is not None else n, 1))()
        return self.call(fn, a, n), list(a)[:n]

    def x(self):
        st, v = self.array("fmi2GetContinuousStates", 2)
        assert st == OK, self.messages[-1:]
        return v

    def dx(self):
        return self.array("fmi2GetDerivatives", 2)

    def z(self):
        return self.array("fmi2GetEventIndicators", 6)

    def set_x(self, values):
        return self.call("fmi2SetContinuousStates", (c_double * len(values))(*values), len(values))

    def completed(self):
        enter, term = c_int(7), c_int(7)
        st = self.call("fmi2CompletedIntegratorStep", 1, byref(enter), byref(term))
        return st, enter.value, term.value

    def to_continuous(self):
        assert self.call("fmi2EnterContinuousTimeMode") == OK, self.messages[-1:]

    def event(self):
        """Event mode, one event iteration (the FMU never asks for a second one), back to
        continuous-time mode."""
        assert self.call("fmi2EnterEventMode") == OK
        st, info = self.nds()
        assert st == OK and not info["needed"], self.messages[-1:]
        self.to_continuous()
        return info

    # Co-Simulation
    def step(self, t, h):
        return self.call("fmi2DoStep", t, h, 1)

    def status(self, kind):
        if kind == TERMINATED:
            b = c_int()
            st = self.call("fmi2GetBooleanStatus", kind, byref(b))
            return st, bool(b.value)
        r = c_double()
        st = self.call("fmi2GetRealStatus", kind, byref(r))
        return st, r.value

    def get_state(self):
        s = c_void_p()
        assert self.call("fmi2GetFMUstate", byref(s)) == OK, self.messages[-1:]
        return s

    def serialize(self, s):
        n = c_size_t()
        assert self.call("fmi2SerializedFMUstateSize", s, byref(n)) == OK
        buf = (c_char * n.value)()
        assert self.call("fmi2SerializeFMUstate", s, buf, n) == OK
        return buf, n


@pytest.fixture
def new(fmu):
    made: list[Raw] = []

    def make(kind="ME", name="hostile"):
        made.append(Raw(fmu, kind, name))
        return made[-1]

    yield make
    for r in made:
        r.free()


PULSE = {"excitation.kind": 1, "excitation.amplitude": 4.0, "excitation.frequency": 2.0}
OVERTURNING = {"excitation.kind": 1, "excitation.amplitude": 12.0, "excitation.frequency": 1.0}
B, H, G = 0.1, 0.3, 9.81  # the FMU's default block and gravity
THRESHOLD = G * B / H  # |ah| above which the ground tips a block at rest


def close(expected):
    return pytest.approx(expected, rel=1e-12, abs=1e-300)


def _rhs(theta, side, ah=0.0, av=0.0):
    """theta'' of the equation of motion (model.h), written out here."""
    R, alpha = math.sqrt(B * B + H * H), math.atan(B / H)
    phi = side * alpha - theta
    return -(3.0 / (4.0 * R)) * ((G + av) * math.sin(phi) + ah * math.cos(phi))


# ------------------------------------------------------------ call sequences

def _in_phase(r: Raw, phase: str) -> Raw:
    if phase == "instantiated":
        return r
    r.setup()
    r.set(block1__theta0=0.1)
    assert r.call("fmi2EnterInitializationMode") == OK
    if phase == "initialization":
        return r
    assert r.call("fmi2ExitInitializationMode") == OK
    if phase == "event":
        return r
    if phase == "continuous":
        r.to_continuous()
    elif phase == "terminated":
        assert r.call("fmi2Terminate") == OK
    elif phase == "error":
        r.set(ground__av=-20.0)  # the ground falls faster than g: the event update fails
        assert r.nds()[0] == ERROR
    return r


CALLS = {
    "SetTime": lambda r: r.call("fmi2SetTime", 0.5),
    "SetContinuousStates": lambda r: r.set_x([0.05, 0.1]),
    "GetContinuousStates": lambda r: r.array("fmi2GetContinuousStates", 2)[0],
    "GetDerivatives": lambda r: r.dx()[0],
    "GetEventIndicators": lambda r: r.z()[0],
    "GetNominalsOfContinuousStates": lambda r: r.array("fmi2GetNominalsOfContinuousStates", 2)[0],
    "NewDiscreteStates": lambda r: r.nds()[0],
    "EnterEventMode": lambda r: r.call("fmi2EnterEventMode"),
    "EnterContinuousTimeMode": lambda r: r.call("fmi2EnterContinuousTimeMode"),
    "CompletedIntegratorStep": lambda r: r.completed()[0],
    "SetInput": lambda r: r.call("fmi2SetReal", byref(c_uint(r.vr["ground.ah"])), 1, byref(c_double(1.0))),
    "SetParameter": lambda r: r.call("fmi2SetReal", byref(c_uint(r.vr["block1.theta0"])), 1, byref(c_double(0.2))),
    "GetReal": lambda r: r.call("fmi2GetReal", byref(c_uint(r.vr["block1.theta"])), 1, byref(c_double())),
    "DoStep": lambda r: r.step(0.0, 0.1),
    "GetFMUstate": lambda r: r.call("fmi2GetFMUstate", byref(c_void_p())),
    "SerializedFMUstateSize": lambda r: r.call("fmi2SerializedFMUstateSize", None, byref(c_size_t())),
    "GetBooleanStatus": lambda r: r.call("fmi2GetBooleanStatus", TERMINATED, byref(c_int())),
}
PHASES = ["instantiated", "initialization", "event", "continuous", "terminated", "error"]
# the calls that succeed in each phase (FMI 2.0's Model Exchange state machine; fmi2EnterEventMode is also
# accepted in event mode, where it changes nothing); all others are fmi2Error
ALLOWED = {
    "instantiated": {"GetNominalsOfContinuousStates", "SetInput", "SetParameter"},
    "initialization": {"GetContinuousStates", "GetDerivatives", "GetEventIndicators", "GetNominalsOfContinuousStates",
                       "SetInput", "SetParameter", "GetReal"},
    "event": {"SetTime", "GetContinuousStates", "GetDerivatives", "GetEventIndicators",
              "GetNominalsOfContinuousStates", "NewDiscreteStates", "EnterEventMode", "EnterContinuousTimeMode",
              "SetInput", "GetReal"},
    "continuous": {"SetTime", "SetContinuousStates", "GetContinuousStates", "GetDerivatives", "GetEventIndicators",
                   "GetNominalsOfContinuousStates", "EnterEventMode", "CompletedIntegratorStep", "SetInput",
                   "GetReal"},
    "terminated": {"GetContinuousStates", "GetDerivatives", "GetEventIndicators", "GetNominalsOfContinuousStates",
                   "GetReal"},
    "error": {"GetContinuousStates", "GetNominalsOfContinuousStates", "GetReal", "GetEventIndicators"},
}


@pytest.mark.parametrize("phase", PHASES)
def test_every_model_exchange_call_in_every_phase(new, phase):
    """Each call on a fresh instance in the phase: fmi2OK where FMI 2.0 allows it, else
    fmi2Error with a message; Co-Simulation calls and FMU states are errors on Model Exchange.
    (In the error phase the derivatives are refused: the ground still falls faster than g.)"""
    statuses = {}
    for name, call in CALLS.items():
        r = _in_phase(new(), phase)
        n = len(r.messages)
        statuses[name] = call(r)
        if statuses[name] != OK:
            assert r.messages[n:], f"{name} in {phase}: no message"
    assert {n for n, st in statuses.items() if st == OK} == ALLOWED[phase], statuses
    assert all(st == ERROR for n, st in statuses.items() if n not in ALLOWED[phase]), statuses


def test_array_arguments_are_checked_and_nothing_is_written_past_them(new):
    r = new()
    r.start({"block1.theta0": 0.1})
    r.to_continuous()
    for fn in ("fmi2GetContinuousStates", "fmi2GetDerivatives", "fmi2GetNominalsOfContinuousStates",
               "fmi2GetEventIndicators"):
        want = 6 if fn == "fmi2GetEventIndicators" else 2
        for n in (0, 1, want - 1, want + 1, 2**62):
            buf = (c_double * 8)(*[123.0] * 8)
            assert r.call(fn, buf, n) == ERROR, (fn, n)
            assert list(buf) == [123.0] * 8, (fn, n)
        assert r.call(fn, None, want) == ERROR
        assert r.said("NULL array")
    for n in (0, 1, 3, 2**62):
        assert r.call("fmi2SetContinuousStates", (c_double * 4)(0.3, 0.3, 0.3, 0.3), n) == ERROR
    assert r.call("fmi2SetContinuousStates", None, 2) == ERROR
    for bad in ([math.nan, 0.0], [0.0, math.inf], [-math.inf, 0.0]):
        assert r.set_x(bad) == ERROR
    assert r.x() == [0.1, 0.0]  # nothing of the refused calls arrived
    assert r.call("fmi2NewDiscreteStates", None) == ERROR
    assert r.call("fmi2CompletedIntegratorStep", 1, None, None) == ERROR
    assert r.call("fmi2SetReal", None, 1, None) == ERROR


def test_times_non_finite_refused_backward_and_huge_accepted(new):
    """Non-finite times are errors; an importer's solver may go back within the step it is
    taking (a rejected trial), but not before the last completed step or event: fmi2SetTime
    accepted -5 after a start at 0, Model Exchange having no FMU state to go back to."""
    r = new()
    r.start({"block1.theta0": 0.1, **PULSE})
    r.to_continuous()
    for t in (math.nan, math.inf, -math.inf):
        assert r.call("fmi2SetTime", t) == ERROR
    assert r.call("fmi2SetTime", 0.3) == OK
    at_03 = r.dx()
    assert r.call("fmi2SetTime", 0.1) == OK  # back within the step from 0
    n = len(r.messages)
    for t in (-5.0, math.nextafter(0.0, -1.0)):
        assert r.call("fmi2SetTime", t) == ERROR and r.said("goes back before 0, the last completed", n)
    assert r.call("fmi2SetTime", 0.3) == OK
    assert r.dx() == at_03
    assert r.completed()[:2] == (OK, 0)  # the step to 0.3 is accepted
    assert r.call("fmi2SetTime", 0.2) == ERROR and r.said("before 0.29999999999999999")
    assert r.call("fmi2SetTime", 0.3) == OK and r.dx() == at_03
    r.call("fmi2EnterEventMode")
    assert r.call("fmi2SetTime", 0.35) == OK and r.nds()[0] == OK  # an event at 0.35
    assert r.call("fmi2SetTime", 0.32) == ERROR
    for t in (1e15, 1e300):  # at rest under an endless harmonic: the uplift search ends at once
        h = new()
        h.start({"excitation.kind": 3, "excitation.displacement": 0.001, "excitation.frequency": 1.0,
                 "excitation.cycles": 0})
        h.to_continuous()
        assert h.call("fmi2SetTime", t) == OK
        assert h.call("fmi2EnterEventMode") == OK
        st, info = h.nds()
        assert st == OK and h.get("atRest") and h.dx() == (OK, [0.0, 0.0])


# ------------------------------------------------------------ the ground

@pytest.mark.parametrize("theta0", [0.1, 0.0], ids=["rocking", "at rest"])
def test_ground_falling_faster_than_g_is_an_error_in_model_exchange(new, theta0):
    """g + av <= 0: the block would leave the ground. Co-Simulation goes on and reports the
    flight with its monitors; Model Exchange, which cannot report it, refuses with fmi2Error
    (its derivatives once went on with gravity reversed and fmi2OK)."""
    r = new()
    r.start({"block1.theta0": theta0})
    r.to_continuous()
    assert r.dx()[0] == OK
    r.set(ground__av=-20.0)
    n = len(r.messages)
    assert r.dx()[0] == ERROR
    assert r.said("<= -g", n)
    r.set(ground__av=-9.0)  # above -g again
    assert r.dx() == (OK, close([0.0, _rhs(0.1, 1, av=-9.0) if theta0 else 0.0]))


def test_derivatives_that_overflow_are_an_error(new):
    """Huge finite inputs: the derivative overflowed to -inf and came back with fmi2OK, as did
    an infinite event indicator."""
    r = new()
    r.start({"block1.theta0": 0.1})
    r.to_continuous()
    r.set(ground__ah=1e308, ground__av=1e308)
    n = len(r.messages)
    assert r.dx()[0] == ERROR
    assert r.said("not finite", n)
    # the uplift indicator (g + av) b/h - |ah| of a flat block at rest: +inf
    flat = new()
    flat.start({"restitution.law": 2, "block1.halfWidth": 10.0, "block1.halfHeight": 1e-5})
    flat.to_continuous()
    assert flat.z()[0] == OK
    flat.set(ground__av=1e308)
    n = len(flat.messages)
    assert flat.z()[0] == ERROR
    assert flat.said("event indicator 2 = inf", n)


def test_a_block_the_ground_tips_at_the_start_rocks_without_an_event_iteration(new):
    """An importer that goes from fmi2ExitInitializationMode straight to continuous-time mode:
    the pulse is above the uplift threshold from the start, so the uplift indicator is
    negative from the start and never changes sign; the block stayed at rest for ever."""
    start = {"excitation.kind": 1, "excitation.amplitude": 8.0, "excitation.frequency": 2.0,
             "excitation.startTime": -0.1}
    r = new()
    r.start(start, iterate=False)
    r.to_continuous()
    assert not r.get("atRest")
    st, dx = r.dx()
    ah = r.get("ground.ahTotal")
    assert ah > THRESHOLD and st == OK
    assert dx == close([0.0, _rhs(0.0, -1, ah=ah)]) and dx[1] < 0  # ah > 0 tips it towards theta < 0
    # the same as with the event iteration
    s = new()
    s.start(start)
    assert not s.get("atRest") and s.dx() == (OK, dx)


def test_inputs_set_in_event_mode_after_the_iteration_tip_the_block(new):
    r = new()
    r.start({})
    r.set(ground__ah=-2 * THRESHOLD)  # after the event iteration, before continuous-time mode
    assert r.get("ground.ahTotal") == -2 * THRESHOLD  # feedthrough at once
    r.to_continuous()
    assert not r.get("atRest")
    assert r.dx() == (OK, close([0.0, _rhs(0.0, 1, ah=-2 * THRESHOLD)]))
    assert r.completed()[1] == 0  # nothing left for an event
    # set in continuous-time mode: the uplift indicator changes sign, and the step ends in an event
    s = new()
    s.start({})
    s.to_continuous()
    assert s.z()[1][2] > 0
    s.set(ground__ah=2 * THRESHOLD)
    assert s.z()[1][2] < 0 and s.completed()[:2] == (OK, 1)
    info = s.event()
    assert not s.get("atRest") and info["changed"] and s.completed()[:2] == (OK, 0)
    assert s.dx() == (OK, close([0.0, _rhs(0.0, -1, ah=2 * THRESHOLD)]))


def test_rocking_flat_on_its_base_with_nothing_lifting_it_rests(new):
    """After an uplift, the input that tipped the block is taken back in event mode: flat on
    its base, it pivoted on a corner it was pushed away from, into the ground (theta's
    indicator stays in its domain z <= 0), until it overturned on the other side."""
    r = new()
    r.start({})
    r.set(ground__ah=2 * THRESHOLD)
    r.to_continuous()
    r.event()  # uplift towards theta < 0
    assert not r.get("atRest")
    assert r.call("fmi2EnterEventMode") == OK
    assert r.nds()[0] == OK
    r.set(ground__ah=0.0)
    r.to_continuous()
    assert r.get("atRest") and r.dx() == (OK, [0.0, 0.0])
    # the same reached through states the importer sets on a rocking block
    s = new()
    s.start({"block1.theta0": 0.1})
    s.to_continuous()
    assert s.set_x([0.0, 0.0]) == OK
    assert s.completed()[:2] == (OK, 1)  # a step event
    s.event()
    assert s.get("atRest") and s.x() == [0.0, 0.0] and s.get("impacts") == 0


# ------------------------------------------------------------ states the importer sets

def test_a_long_euler_step_overturns_the_block_on_the_side_it_reached(new):
    """One Euler step from theta = 0.1 across theta = 0 and beyond -pi/2: the block was
    overturned on the side it started from, theta jumping from -2 to +pi/2."""
    r = new()
    r.start({"block1.theta0": 0.1})
    r.to_continuous()
    assert r.call("fmi2SetTime", 0.5) == OK
    assert r.set_x([-2.0, -3.0]) == OK
    info = r.event()
    assert info["changed"]
    assert r.get("overturned") and r.x() == [-PI2, 0.0] and r.get("block1.theta") == -PI2
    assert r.dx() == (OK, [0.0, 0.0])


@pytest.mark.parametrize("x,overturned", [([0.05, 0.0], False), ([0.0, -0.3], False), ([2.0, 0.0], True),
                                          ([-1.6, 1.0], True)])
def test_states_set_on_a_resting_block_release_it(new, x, overturned):
    """A block at rest kept any states an importer set, with zero derivatives and atRest true:
    it hovered at theta = 2 with a negative energy. Now the step ends with a step event
    (fmi2CompletedIntegratorStep, hence completedIntegratorStepNotNeeded="false") and the
    block moves from the states set, or falls over."""
    r = new()
    assert r.fmu.model_description.modelExchange.needsCompletedIntegratorStep  # fmpy then calls it
    r.start({})
    r.to_continuous()
    assert r.completed()[:2] == (OK, 0)
    assert r.set_x(x) == OK
    assert r.completed()[:2] == (OK, 1)
    r.event()
    assert not r.get("atRest") and r.get("overturned") == overturned
    if overturned:
        assert r.x() == [math.copysign(PI2, x[0]), 0.0]
    else:
        side = 1 if x[0] > 0 else -1 if x[0] < 0 else (1 if x[1] > 0 else -1)
        assert r.x() == x and r.dx() == (OK, close([x[1], _rhs(x[0], side)]))
    assert r.completed()[:2] == (OK, 0)


@pytest.mark.parametrize("x", [[math.nextafter(math.pi, 4.0), 0.0], [-4.0, 0.0], [1e300, 1.0], [0.1, 1e300],
                               [0.1, -1e12]])
def test_states_beyond_the_blocks_range_are_refused(new, x):
    """fmi2SetContinuousStates took theta beyond a half turn and omega of 1e300 rad/s with
    fmi2OK (the event iteration then laid the block on its side, overturned). Now fmi2Error
    with a message naming the state, and the states stay as they were; the limits themselves
    (|theta| = pi, omega = 1e6 sqrt(g / R)) are accepted."""
    r = new()
    r.start({"block1.theta0": 0.1})
    r.to_continuous()
    n = len(r.messages)
    assert r.set_x(x) == ERROR
    assert r.said("block1.theta" if abs(x[0]) > math.pi else "block1.omega", n)
    assert r.x() == [0.1, 0.0]
    limit = 1e6 * math.sqrt(G / math.hypot(B, H))
    assert r.set_x([-math.pi, 0.999999 * limit]) == OK and r.x() == [-math.pi, 0.999999 * limit]


def test_states_set_on_an_overturned_block_go_back_to_its_side(new):
    r = new()
    r.start({"block1.theta0": 0.1})
    r.to_continuous()
    assert r.set_x([1.7, 1.0]) == OK
    r.event()
    assert r.get("overturned") and r.x() == [PI2, 0.0]
    assert r.set_x([0.3, -2.0]) == OK
    assert r.get("block1.theta") == 0.3  # outputs follow the states at once
    assert r.completed()[:2] == (OK, 1)
    info = r.event()
    assert info["changed"] and r.x() == [PI2, 0.0] and r.get("overturned") and r.get("block1.theta") == PI2


def test_one_event_iteration_settles_any_state(new):
    """The FMU never sets newDiscreteStatesNeeded: after one fmi2NewDiscreteStates, whatever
    the states and inputs set before it, a second changes nothing and no step event is due
    (else an importer would loop, or carry an inconsistent mode)."""
    rnd = random.Random(17)
    special = [0.0, -0.0, 5e-324, -5e-324, 0.1, -0.1, PI2, -PI2, 1.6, -2.0]
    scenes = [{}, {"block1.theta0": 0.1}, {**PULSE, "excitation.amplitude": 8.0},
              {"restitution.law": 2, "restitution.eta": 0.0, "block1.theta0": -0.05}]
    for trial in range(40):
        r = new()
        r.start(rnd.choice(scenes))
        r.to_continuous()
        t = 0.0
        for k in range(5):
            t += rnd.uniform(0.0, 0.2)  # forward: the event of the last round is the earliest time allowed
            assert r.call("fmi2SetTime", t) == OK
            x = [rnd.choice(special) if rnd.random() < 0.5 else rnd.uniform(-2, 2) for _ in range(2)]
            assert r.set_x(x) == OK
            if rnd.random() < 0.3:
                r.set(ground__ah=rnd.choice([0.0, 3.3, -3.3, 10.0]))
            assert r.call("fmi2EnterEventMode") == OK
            assert r.nds()[0] == OK
            settled = r.x()
            st, again = r.nds()
            assert st == OK and not again["changed"] and r.x() == settled, (x, settled, r.x())
            r.to_continuous()
            assert r.completed()[:2] == (OK, 0), (x, settled)


def test_new_discrete_states_many_times_after_an_impact_counts_it_once(new):
    r = new()
    r.start({"block1.theta0": 0.1})
    r.to_continuous()
    assert r.call("fmi2SetTime", 0.3) == OK
    assert r.set_x([-1e-9, -1.0]) == OK
    assert r.call("fmi2EnterEventMode") == OK
    results = [r.nds() for _ in range(20)]
    assert results[0][1]["changed"] and not any(info["changed"] for _, info in results[1:])
    assert r.get("impacts") == 1 and r.get("lastImpactTime") == 0.3


# ------------------------------------------------------------ variables and instances

@pytest.mark.parametrize("kind", ["ME", "CS"])
def test_a_refused_value_leaves_the_feedthrough_outputs_current(new, kind):
    """fmi2SetReal([ground.ah, block1.theta]): ground.ah is set, the output block1.theta is
    refused. ground.ahTotal and alpha_dd stayed those of the old input."""
    r = new(kind)
    r.start({"block1.theta0": 0.1})
    if kind == "ME":
        r.to_continuous()
    vr = (c_uint * 2)(r.vr["ground.ah"], r.vr["block1.theta"])
    assert r.call("fmi2SetReal", vr, 2, (c_double * 2)(5.0, 0.0)) == ERROR
    assert r.get("ground.ah") == 5.0
    assert r.get("ground.ahTotal") == 5.0
    assert r.get("block1.alpha_dd") == close(_rhs(0.1, 1, ah=5.0))


def test_model_functions_refuse_two_blocks_set_in_initialization(new):
    """nBlocks = 2 set in initialization mode: fmi2ExitInitializationMode refuses it, but the
    derivatives, indicators and states came back with fmi2OK (zeros and ones of a model
    Model Exchange does not run)."""
    r = new()
    r.setup()
    r.set(block1__theta0=0.0)
    assert r.call("fmi2EnterInitializationMode") == OK
    r.set(nBlocks=2, block2__theta0=0.05)
    for fn, n in (("fmi2GetDerivatives", 2), ("fmi2GetEventIndicators", 6), ("fmi2GetContinuousStates", 2)):
        assert r.array(fn, n)[0] == ERROR
    assert r.said("Model Exchange runs one block")
    assert r.call("fmi2ExitInitializationMode") == ERROR
    r.set(nBlocks=1)
    assert r.call("fmi2ExitInitializationMode") == OK
    assert r.dx() == (OK, [0.0, 0.0])


def test_fmu_state_functions_are_errors_on_model_exchange(new, fmu):
    me = fmu.model_description.modelExchange
    assert not me.canGetAndSetFMUstate and not me.canSerializeFMUstate
    cs = new("CS")
    cs.start({"block1.theta0": 0.1})
    buf, n = cs.serialize(cs.get_state())
    r = new()
    r.start({})
    size, state = c_size_t(0), c_void_p()
    assert r.call("fmi2SerializedFMUstateSize", None, byref(size)) == ERROR and size.value == 0
    assert r.call("fmi2DeSerializeFMUstate", buf, n, byref(state)) == ERROR and state.value is None
    assert r.call("fmi2GetFMUstate", byref(state)) == ERROR and state.value is None
    assert r.said("Co-Simulation only")


def test_reset_and_reuse_a_model_exchange_instance(new):
    r = new()
    r.start({"block1.theta0": 0.1, "solver.stopAtOverturn": True})
    r.to_continuous()
    assert r.set_x([1.7, 1.0]) == OK
    assert r.call("fmi2EnterEventMode") == OK
    st, info = r.nds()
    assert st == OK and info["terminate"]
    assert r.call("fmi2Reset") == OK
    assert r.array("fmi2GetContinuousStates", 2)[0] == ERROR  # instantiated again
    r.start({"block1.theta0": -0.2})
    assert r.x() == [-0.2, 0.0] and not r.get("overturned") and not r.get("solver.stopAtOverturn")
    fresh = new()
    fresh.start({"block1.theta0": -0.2})
    for m in (r, fresh):
        m.to_continuous()
        assert m.call("fmi2SetTime", 0.01) == OK
    assert r.dx() == fresh.dx() and r.z() == fresh.z()


def test_stop_at_overturn_in_model_exchange_terminates_every_time_asked(new):
    r = new()
    r.start({**OVERTURNING, "solver.stopAtOverturn": True})
    r.to_continuous()
    assert r.call("fmi2SetTime", 0.47) == OK
    assert r.set_x([1.6, 3.0]) == OK
    assert r.call("fmi2EnterEventMode") == OK
    for _ in range(3):
        st, info = r.nds()
        assert st == OK and info["terminate"]
    assert r.get("overturnTime") == 0.47 and r.x() == [PI2, 0.0]
    assert r.call("fmi2GetBooleanStatus", TERMINATED, byref(c_int())) == ERROR  # a Co-Simulation function
    assert r.call("fmi2Terminate") == OK


# ------------------------------------------------------------ Co-Simulation

def test_stop_at_overturn_with_states_around_the_terminating_step(new):
    """The state before the step that ends the run: restored, smaller steps end at the same
    overturn; the terminated state, serialized and restored into another instance, stays
    terminated (fmi2Discard for further steps, fmi2Terminated true)."""
    r = new("CS")
    r.start({**OVERTURNING, "solver.stopAtOverturn": True})
    t = 0.0
    while True:
        before = r.get_state()
        st = r.step(t, 0.25)
        if st != OK:
            break
        r.call("fmi2FreeFMUstate", byref(before))
        t += 0.25
    assert st == DISCARD and r.status(TERMINATED) == (OK, True)
    overturn = r.get("overturnTime")
    assert t < overturn < t + 0.25 and r.status(LAST_SUCCESSFUL_TIME) == (OK, overturn)
    assert r.step(overturn, 0.1) == DISCARD and r.said("the run ended at the overturn")
    ended = r.get_state()
    buf, n = r.serialize(ended)
    r.call("fmi2FreeFMUstate", byref(ended))

    assert r.call("fmi2SetFMUstate", before) == OK
    assert r.status(TERMINATED) == (OK, False) and r.status(LAST_SUCCESSFUL_TIME) == (OK, t)
    while r.step(t, 0.01) == OK:
        t += 0.01
    assert r.status(TERMINATED) == (OK, True) and r.get("overturnTime") == overturn
    r.call("fmi2FreeFMUstate", byref(before))

    other = new("CS")
    other.start({})
    state = c_void_p()
    assert other.call("fmi2DeSerializeFMUstate", buf, n, byref(state)) == OK
    assert other.call("fmi2SetFMUstate", state) == OK, other.messages[-1:]
    assert other.status(TERMINATED) == (OK, True) and other.status(LAST_SUCCESSFUL_TIME) == (OK, overturn)
    assert other.step(overturn, 0.1) == DISCARD
    assert other.call("fmi2Terminate") == OK and other.step(overturn, 0.1) == ERROR
    assert other.call("fmi2FreeFMUstate", byref(state)) == OK and state.value is None


@pytest.mark.parametrize("tolerance", [0.0, -1e-6, math.nan, math.inf, -math.inf, math.nextafter(0.1, 1.0), 1.0,
                                       5e-324, 1e-300, math.nextafter(1e-14, 0.0)])
def test_tolerances_outside_the_range_are_refused(new, tolerance):
    """Below 1e-14 no integrator meets the tolerance in double precision (the Taylor series
    stepped by eps^(1/N) and never returned)."""
    r = new("CS")
    assert r.setup(tolerance=tolerance) == ERROR and r.said("must be in [1e-14, 0.1]")
    assert r.setup(tolerance=1e-6) == OK  # nothing was kept of the refused one


@pytest.mark.parametrize("method", [0, 1], ids=["dormand-prince", "taylor"])
@pytest.mark.parametrize("tols", [(1e-300, 1e-300), (1e-300, 1e-12), (1e-10, 1e-300)])
def test_tolerances_no_integrator_meets_are_refused_when_initialization_starts(new, method, tols):
    """solver.relTol = solver.absTol = 1e-300 with the Taylor series: fmi2DoStep(0, 5) never
    returned (Dormand-Prince refused the same at its first step). Now both refuse at
    fmi2EnterInitializationMode, saying the range."""
    r = new("CS")
    assert r.setup() == OK
    r.setp(with_scene_defaults({"block1.theta0": 0.2, "solver.method": method, "solver.relTol": tols[0],
                                "solver.absTol": tols[1]}))
    assert r.call("fmi2EnterInitializationMode") == ERROR
    assert r.said("[1e-14, 0.1]") if tols[0] < 1e-14 else r.said("[1e-20, 1e-3]")


@pytest.mark.parametrize("method", [0, 1], ids=["dormand-prince", "taylor"])
def test_the_tightest_tolerances_allowed_run_to_the_end(new, method):
    """solver.relTol = 1e-14, solver.absTol = 1e-20 (the ends of the ranges) under a pulse
    that rocks the block: the run ends, as one at the default tolerances does."""
    runs = []
    for tols in ((1e-14, 1e-20), (1e-10, 1e-12)):
        r = new("CS")
        r.start({**PULSE, "solver.method": method, "solver.relTol": tols[0], "solver.absTol": tols[1]})
        assert r.step(0.0, 5.0) == OK, r.messages[-1:]
        runs.append((r.get("impacts"), r.get("block1.maxAbsTheta")))
    assert runs[0][0] == runs[1][0] > 5 and runs[0][1] == pytest.approx(runs[1][1], rel=1e-8)


@pytest.mark.parametrize("tolerance", [1e-14, 1e-8, 0.1])
def test_tolerances_in_the_range_run_and_survive_serialization(new, tolerance):
    r = new("CS")
    r.start({"block1.theta0": 0.15, "solver.relTol": 0.1}, tolerance=tolerance)  # the tighter is used
    assert r.get("solver.relTol") == tolerance
    assert r.step(0.0, 0.5) == OK
    buf, n = r.serialize(r.get_state())
    assert r.step(0.5, 0.5) == OK
    expected = r.get("block1.theta")
    other = new("CS")
    other.start({"block1.theta0": 0.15}, tolerance=1e-4)
    state = c_void_p()
    assert other.call("fmi2DeSerializeFMUstate", buf, n, byref(state)) == OK
    assert other.call("fmi2SetFMUstate", state) == OK, other.messages[-1:]
    assert other.get("solver.relTol") == tolerance
    assert other.step(0.5, 0.5) == OK and other.get("block1.theta") == expected
    other.call("fmi2FreeFMUstate", byref(state))


def test_a_state_claiming_a_tolerance_its_parameters_do_not_have_is_refused(new):
    """solver.relTol in use is at most the importer's tolerance: a state whose tolerance is tighter
    than its solver.relTol was not written by the FMU."""
    r = new("CS")
    r.start({"block1.theta0": 0.15, "solver.relTol": 1e-4}, tolerance=1e-6)
    buf, n = r.serialize(r.get_state())
    raw = bytearray(buf)
    mine = c_double(1e-6)
    at = [i for i in range(len(raw) - 7) if raw[i:i + 8] == bytes(mine)]
    assert len(at) >= 2  # solver.relTol and, after it, the tolerance
    raw[at[-1]:at[-1] + 8] = bytes(c_double(1e-7))
    bad = (c_char * len(raw)).from_buffer(raw)
    state = c_void_p()
    assert r.call("fmi2DeSerializeFMUstate", bad, n, byref(state)) == OK
    assert r.call("fmi2SetFMUstate", state) == ERROR
    assert r.get("solver.relTol") == 1e-6 and r.step(0.0, 0.1) == OK
    r.call("fmi2FreeFMUstate", byref(state))


# ------------------------------------------------------------ threads

def _euler(r: Raw, steps=400, h=2e-3):
    """A fixed-step Euler importer with state events by sign change and step events."""
    r.to_continuous()
    t, z = 0.0, r.z()[1]
    for _ in range(steps):
        x, dx = r.x(), r.dx()[1]
        t += h
        r.call("fmi2SetTime", t)
        r.set_x([x[0] + h * dx[0], x[1] + h * dx[1]])
        z1 = r.z()[1]
        st, enter, _ = r.completed()
        if enter or any((a > 0) != (b > 0) for a, b in zip(z, z1)):
            r.event()
            z1 = r.z()[1]
        z = z1
    return r.x(), r.get("impacts"), r.get("peaks"), r.get("block1.maxAbsTheta")


def _co_simulation(r: Raw):
    for k in range(40):
        assert r.step(0.02 * k, 0.02) == OK
    return r.get("block1.theta"), r.get("impacts"), r.get("peaks")


def test_model_exchange_and_co_simulation_instances_in_threads_share_nothing(fmu):
    scenes = [{"block1.theta0": 0.02 * k, **PULSE} for k in range(6)]

    def run(k):
        me, cs = Raw(fmu, "ME", f"me{k}"), Raw(fmu, "CS", f"cs{k}")
        try:
            me.start(scenes[k])
            cs.start(scenes[k])
            return _euler(me), _co_simulation(cs)
        finally:
            me.free()
            cs.free()

    alone = [run(k) for k in range(len(scenes))]
    assert len({a[0][1] for a in alone}) > 1  # the scenes differ
    together: dict[int, list] = {}
    errors = []

    def work(k):
        try:
            together[k] = [run(k) for _ in range(2)]
        except Exception as exc:  # noqa: BLE001 - reported below
            errors.append(exc)

    threads = [threading.Thread(target=work, args=(k,)) for k in range(len(scenes))]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    assert not errors
    for k, results in together.items():
        assert results == [alone[k], alone[k]], k
