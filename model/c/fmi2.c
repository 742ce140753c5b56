/* FMI 2.0 layer of RockingBlock: Co-Simulation and Model Exchange in one
 * binary. It checks FMI 2.0's call sequence, converts types and calls the
 * instance (instance.c: life cycle, variables, states, the communication
 * step) and the Model Exchange interface of the model (me.c). No global
 * state. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "fmi2Functions.h"
#include "codes.h"
#include "config.h" /* MODEL_GUID, written by fmu_build */
#include "instance.h"
#include "me.h"
#include "solver.h"

#define CHECK(I, allowed, fn)                                      \
    do {                                                           \
        if (instance_bad_call(I, allowed, fn)) return fmi2Error;   \
    } while (0)

/* FMI 2.0's logger treats the message as a printf format: '%' doubled. */
static void emit(const Instance *I, int status, const char *category, const char *message) {
    fmi2CallbackLogger logger = (fmi2CallbackLogger)I->logger;
    char text[2 * MSG_LEN];
    size_t k = 0;
    if (!logger) return;
    for (const char *p = message; *p && k + 2 < sizeof(text); p++) {
        if (*p == '%') text[k++] = '%';
        text[k++] = *p;
    }
    text[k] = '\0';
    logger(I->env, I->name, (fmi2Status)status, category, text);
}

/* ------------------------------------------------------------- life cycle */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    return (fmi2Status)instance_set_logging((Instance *)c, loggingOn, nCategories, categories,
                                            "fmi2SetDebugLogging");
}

/* Log why there will be no instance, through a stand-in (zeroed here only, on this path: an Instance is
 * large, and instantiation is on the path of every short simulation). */
static void refuse_instance(const fmi2CallbackFunctions *functions, fmi2String instanceName, const char *why) {
    Instance tmp;
    memset(&tmp, 0, sizeof(tmp));
    tmp.emit = emit;
    tmp.env = functions->componentEnvironment;
    tmp.logger = (void (*)(void))functions->logger;
    tmp.name = (char *)(instanceName && instanceName[0] ? instanceName : "RockingBlock");
    INSTANCE_ERROR(&tmp, "%s", why);
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
    (void)visible;
    if (!functions || !functions->allocateMemory || !functions->freeMemory) return NULL;
    char why[MSG_LEN];
    if (!instanceName || !instanceName[0]) {
        refuse_instance(functions, instanceName, "fmi2Instantiate: missing instance name");
        return NULL;
    }
    if (fmuType != fmi2CoSimulation && fmuType != fmi2ModelExchange) {
        snprintf(why, sizeof(why), "fmi2Instantiate: unknown FMU type %d", (int)fmuType);
        refuse_instance(functions, instanceName, why);
        return NULL;
    }
    if (!fmuGUID || strcmp(fmuGUID, MODEL_GUID) != 0) {
        snprintf(why, sizeof(why), "fmi2Instantiate: GUID '%s' does not match this binary (%s)",
                 fmuGUID ? fmuGUID : "(null)", MODEL_GUID);
        refuse_instance(functions, instanceName, why);
        return NULL;
    }
    Instance *I = instance_new(instanceName, fmuType == fmi2CoSimulation ? INTERFACE_CS : INTERFACE_ME,
                               fmuResourceLocation, emit, functions->componentEnvironment,
                               (void (*)(void))functions->logger, functions->allocateMemory, functions->freeMemory,
                               loggingOn);
    if (!I) refuse_instance(functions, instanceName, "fmi2Instantiate: out of memory");
    return I;
}

void fmi2FreeInstance(fmi2Component c) { instance_free((Instance *)c); }

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    Instance *I = (Instance *)c;
    CHECK(I, PHASE_INSTANTIATED, "fmi2SetupExperiment");
    return (fmi2Status)instance_setup_experiment(I, toleranceDefined, tolerance, startTime, stopTimeDefined,
                                                 stopTime, "fmi2SetupExperiment");
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    Instance *I = (Instance *)c;
    CHECK(I, PHASE_INSTANTIATED, "fmi2EnterInitializationMode");
    I->s.dirty = 1;
    if (codes_apply(I, "fmi2EnterInitializationMode") || instance_initialize(I) != STATUS_OK) return fmi2Error;
    if (I->s.type == INTERFACE_ME && me_check(I)) return fmi2Error;
    I->s.phase = PHASE_INITIALIZATION;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    Instance *I = (Instance *)c;
    CHECK(I, PHASE_INITIALIZATION, "fmi2ExitInitializationMode");
    if (codes_apply(I, "fmi2ExitInitializationMode") || instance_initialize(I) != STATUS_OK) return fmi2Error;
    if (I->s.type == INTERFACE_ME) {
        if (me_check(I)) return fmi2Error;
        me_start(I);
        I->s.phase = PHASE_EVENT;
    } else {
        I->s.phase = PHASE_STEP_COMPLETE;
    }
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c) {
    Instance *I = (Instance *)c;
    CHECK(I, RUNNING_PHASES | PHASE_ERROR, "fmi2Terminate");
    if (I->s.phase == PHASE_STEP_COMPLETE) { /* events the outputs counted that no later step will log */
        Logger log = instance_solver_logger(I);
        solver_log_pending(&I->s.model, I->s.tc, &log);
    }
    I->s.phase = PHASE_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c) {
    Instance *I = (Instance *)c;
    CHECK(I, ANY_PHASE, "fmi2Reset");
    InterfaceType type = I->s.type;
    instance_reset(I);
    I->s.type = type;
    return fmi2OK;
}

/* -------------------------------------------------------- variable access */

/* After inputs changed, outputs at the current time (direct feedthrough). */
static void inputs_changed(Instance *I) {
    if (I->s.type == INTERFACE_ME) me_update_outputs(I);
    else instance_update_outputs(I);
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    Instance *I = (Instance *)c;
    if (instance_begin_access(I, 1, vr, nvr, value, "fmi2SetReal")) return fmi2Error;
    for (size_t i = 0; i < nvr; i++)
        if (instance_set_real(I, vr[i], value[i], "fmi2SetReal")) {
            /* the values before the refused one are set: outputs that depend on them follow */
            if (i > 0) inputs_changed(I);
            return fmi2Error;
        }
    inputs_changed(I);
    return fmi2OK;
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[]) {
    Instance *I = (Instance *)c;
    if (instance_begin_access(I, 1, vr, nvr, value, "fmi2SetInteger")) return fmi2Error;
    for (size_t i = 0; i < nvr; i++)
        if (instance_set_integer(I, vr[i], value[i], "fmi2SetInteger")) return fmi2Error;
    return fmi2OK;
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[]) {
    Instance *I = (Instance *)c;
    if (instance_begin_access(I, 1, vr, nvr, value, "fmi2SetBoolean")) return fmi2Error;
    for (size_t i = 0; i < nvr; i++)
        if (instance_set_boolean(I, vr[i], value[i], "fmi2SetBoolean")) return fmi2Error;
    return fmi2OK;
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[]) {
    Instance *I = (Instance *)c;
    if (instance_begin_access(I, 1, vr, nvr, value, "fmi2SetString")) return fmi2Error;
    for (size_t i = 0; i < nvr; i++)
        if (instance_set_string(I, vr[i], value[i], "fmi2SetString")) return fmi2Error;
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    Instance *I = (Instance *)c;
    if (instance_begin_access(I, 0, vr, nvr, value, "fmi2GetReal")) return fmi2Error;
    for (size_t i = 0; i < nvr; i++)
        if (instance_get_real(I, vr[i], &value[i], "fmi2GetReal")) return fmi2Error;
    return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[]) {
    Instance *I = (Instance *)c;
    if (instance_begin_access(I, 0, vr, nvr, value, "fmi2GetInteger")) return fmi2Error;
    for (size_t i = 0; i < nvr; i++)
        if (instance_get_integer(I, vr[i], &value[i], "fmi2GetInteger")) return fmi2Error;
    return fmi2OK;
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[]) {
    Instance *I = (Instance *)c;
    if (instance_begin_access(I, 0, vr, nvr, value, "fmi2GetBoolean")) return fmi2Error;
    for (size_t i = 0; i < nvr; i++) {
        int b;
        if (instance_get_boolean(I, vr[i], &b, "fmi2GetBoolean")) return fmi2Error;
        value[i] = b ? fmi2True : fmi2False;
    }
    return fmi2OK;
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[]) {
    Instance *I = (Instance *)c;
    if (instance_begin_access(I, 0, vr, nvr, value, "fmi2GetString")) return fmi2Error;
    for (size_t i = 0; i < nvr; i++)
        if (instance_get_string(I, vr[i], &value[i], "fmi2GetString")) return fmi2Error;
    return fmi2OK;
}

/* -------------------------------------------------------------- FMU state */

/* Model Exchange declares canGetAndSetFMUstate and canSerializeFMUstate false: the state
 * functions are errors there (instance_get_state and instance_set_state refuse too). */
static int no_states(Instance *I, const char *fn) {
    if (I->s.type == INTERFACE_CS) return 0;
    INSTANCE_ERROR(I, "%s: FMU states are available in Co-Simulation only", fn);
    return 1;
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *state) {
    return (fmi2Status)instance_get_state((Instance *)c, (void **)state, "fmi2GetFMUstate");
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state) {
    return (fmi2Status)instance_set_state((Instance *)c, state, "fmi2SetFMUstate");
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *state) {
    Instance *I = (Instance *)c;
    CHECK(I, ANY_PHASE, "fmi2FreeFMUstate");
    return (fmi2Status)instance_free_state(I, (void **)state);
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate state, size_t *size) {
    Instance *I = (Instance *)c;
    CHECK(I, ANY_PHASE, "fmi2SerializedFMUstateSize");
    if (no_states(I, "fmi2SerializedFMUstateSize")) return fmi2Error;
    (void)state;
    if (!size) {
        INSTANCE_ERROR(I, "fmi2SerializedFMUstateSize: size pointer is NULL");
        return fmi2Error;
    }
    *size = instance_state_size();
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate state, fmi2Byte bytes[], size_t size) {
    Instance *I = (Instance *)c;
    CHECK(I, ANY_PHASE, "fmi2SerializeFMUstate");
    if (no_states(I, "fmi2SerializeFMUstate")) return fmi2Error;
    return (fmi2Status)instance_serialize_state(I, state, (unsigned char *)bytes, size, "fmi2SerializeFMUstate");
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[], size_t size, fmi2FMUstate *state) {
    Instance *I = (Instance *)c;
    CHECK(I, ANY_PHASE, "fmi2DeSerializeFMUstate");
    if (no_states(I, "fmi2DeSerializeFMUstate")) return fmi2Error;
    return (fmi2Status)instance_deserialize_state(I, (const unsigned char *)bytes, size, (void **)state,
                                                  "fmi2DeSerializeFMUstate");
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
    Instance *I = (Instance *)c;
    (void)vUnknown_ref, (void)nUnknown, (void)vKnown_ref, (void)nKnown, (void)dvKnown, (void)dvUnknown;
    CHECK(I, ANY_PHASE, "fmi2GetDirectionalDerivative");
    INSTANCE_ERROR(I, "fmi2GetDirectionalDerivative is not supported");
    return fmi2Error;
}

/* -------------------------------------------------------- co-simulation */

/* Co-Simulation functions must not be called on a Model Exchange instance, and back. */
static int wrong_type(Instance *I, InterfaceType want, const char *fn) {
    if (!I) return 1;
    if (I->s.type == want) return 0;
    INSTANCE_ERROR(I, "%s is a %s function, and this instance was instantiated for %s", fn,
              want == INTERFACE_CS ? "Co-Simulation" : "Model Exchange",
              want == INTERFACE_CS ? "Model Exchange" : "Co-Simulation");
    return 1;
}

#define CHECK_CS(I, allowed, fn)                                                        \
    do {                                                                                \
        if (wrong_type(I, INTERFACE_CS, fn) || instance_bad_call(I, allowed, fn)) return fmi2Error; \
    } while (0)

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    Instance *I = (Instance *)c;
    const char *fn = "fmi2SetRealInputDerivatives";
    CHECK_CS(I, ANY_PHASE, fn);
    if (instance_begin_access(I, 1, vr, nvr, value, fn)) return fmi2Error;
    if (nvr > 0 && !order) {
        INSTANCE_ERROR(I, "%s: NULL order array with nvr = %zu", fn, nvr);
        return fmi2Error;
    }
    for (size_t i = 0; i < nvr; i++)
        if (instance_set_real_derivative(I, vr[i], order[i], value[i], fn)) {
            if (i > 0) inputs_changed(I);
            return fmi2Error;
        }
    inputs_changed(I);
    return fmi2OK;
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
    Instance *I = (Instance *)c;
    (void)vr, (void)nvr, (void)order, (void)value;
    CHECK_CS(I, ANY_PHASE, "fmi2GetRealOutputDerivatives");
    INSTANCE_ERROR(I, "fmi2GetRealOutputDerivatives is not supported");
    return fmi2Error;
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    Instance *I = (Instance *)c;
    (void)noSetFMUStatePriorToCurrentPoint;
    CHECK_CS(I, PHASE_STEP_COMPLETE, "fmi2DoStep");
    StepResult r;
    return (fmi2Status)instance_do_step(I, currentCommunicationPoint, communicationStepSize, 0, &r, "fmi2DoStep");
}

fmi2Status fmi2CancelStep(fmi2Component c) {
    Instance *I = (Instance *)c;
    CHECK_CS(I, ANY_PHASE, "fmi2CancelStep");
    INSTANCE_ERROR(I, "fmi2CancelStep: fmi2DoStep is synchronous, there is nothing to cancel");
    return fmi2Error;
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    Instance *I = (Instance *)c;
    (void)s, (void)value;
    CHECK_CS(I, ANY_PHASE, "fmi2GetStatus");
    INSTANCE_ERROR(I, "fmi2GetStatus: no asynchronous status available");
    return fmi2Discard;
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    Instance *I = (Instance *)c;
    CHECK_CS(I, ANY_PHASE, "fmi2GetRealStatus");
    if (s == fmi2LastSuccessfulTime && value) {
        *value = I->s.tc;
        return fmi2OK;
    }
    return fmi2Discard;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    Instance *I = (Instance *)c;
    (void)s, (void)value;
    CHECK_CS(I, ANY_PHASE, "fmi2GetIntegerStatus");
    return fmi2Discard;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    Instance *I = (Instance *)c;
    CHECK_CS(I, ANY_PHASE, "fmi2GetBooleanStatus");
    if (s == fmi2Terminated && value) {
        /* true once a step ended the run at an overturn (solver.stopAtOverturn) */
        *value = I->s.terminated ? fmi2True : fmi2False;
        return fmi2OK;
    }
    return fmi2Discard;
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    Instance *I = (Instance *)c;
    (void)s, (void)value;
    CHECK_CS(I, ANY_PHASE, "fmi2GetStringStatus");
    return fmi2Discard;
}

/* -------------------------------------------------------- model exchange */

#define CHECK_ME(I, allowed, fn)                                                        \
    do {                                                                                \
        if (wrong_type(I, INTERFACE_ME, fn) || instance_bad_call(I, allowed, fn)) return fmi2Error; \
    } while (0)

fmi2Status fmi2EnterEventMode(fmi2Component c) {
    Instance *I = (Instance *)c;
    CHECK_ME(I, PHASE_EVENT | PHASE_CONTINUOUS, "fmi2EnterEventMode");
    I->s.phase = PHASE_EVENT;
    return fmi2OK;
}

fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *info) {
    Instance *I = (Instance *)c;
    CHECK_ME(I, PHASE_EVENT, "fmi2NewDiscreteStates");
    if (!info) {
        INSTANCE_ERROR(I, "fmi2NewDiscreteStates: eventInfo is NULL");
        return fmi2Error;
    }
    MeEventInfo e;
    if (me_event_update(I, &e)) {
        I->s.phase = PHASE_ERROR;
        return fmi2Error;
    }
    info->newDiscreteStatesNeeded = e.newDiscreteStatesNeeded ? fmi2True : fmi2False;
    info->terminateSimulation = e.terminate ? fmi2True : fmi2False;
    info->nominalsOfContinuousStatesChanged = fmi2False;
    info->valuesOfContinuousStatesChanged = e.statesChanged ? fmi2True : fmi2False;
    info->nextEventTimeDefined = e.nextTimeDefined ? fmi2True : fmi2False;
    info->nextEventTime = e.nextTimeDefined ? e.nextTime : 0.0;
    return fmi2OK;
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) {
    Instance *I = (Instance *)c;
    CHECK_ME(I, PHASE_EVENT, "fmi2EnterContinuousTimeMode");
    me_enter_continuous(I);
    I->s.phase = PHASE_CONTINUOUS;
    return fmi2OK;
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode, fmi2Boolean *terminateSimulation) {
    Instance *I = (Instance *)c;
    (void)noSetFMUStatePriorToCurrentPoint;
    CHECK_ME(I, PHASE_CONTINUOUS, "fmi2CompletedIntegratorStep");
    if (!enterEventMode || !terminateSimulation) {
        INSTANCE_ERROR(I, "fmi2CompletedIntegratorStep: NULL output argument");
        return fmi2Error;
    }
    int enter = 0;
    if (me_completed_step(I, &enter)) {
        I->s.phase = PHASE_ERROR;
        return fmi2Error;
    }
    *enterEventMode = enter ? fmi2True : fmi2False;
    *terminateSimulation = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time) {
    Instance *I = (Instance *)c;
    CHECK_ME(I, PHASE_EVENT | PHASE_CONTINUOUS, "fmi2SetTime");
    return (fmi2Status)me_set_time(I, time, "fmi2SetTime");
}

fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx) {
    Instance *I = (Instance *)c;
    CHECK_ME(I, PHASE_CONTINUOUS, "fmi2SetContinuousStates");
    return (fmi2Status)me_set_states(I, x, nx, "fmi2SetContinuousStates");
}

fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives[], size_t nx) {
    Instance *I = (Instance *)c;
    CHECK_ME(I, PHASE_INITIALIZATION | PHASE_EVENT | PHASE_CONTINUOUS | PHASE_TERMINATED | PHASE_ERROR,
             "fmi2GetDerivatives");
    return (fmi2Status)me_get_derivatives(I, derivatives, nx, "fmi2GetDerivatives");
}

fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni) {
    Instance *I = (Instance *)c;
    CHECK_ME(I, PHASE_INITIALIZATION | PHASE_EVENT | PHASE_CONTINUOUS | PHASE_TERMINATED | PHASE_ERROR,
             "fmi2GetEventIndicators");
    return (fmi2Status)me_get_event_indicators(I, eventIndicators, ni, "fmi2GetEventIndicators");
}

fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx) {
    Instance *I = (Instance *)c;
    CHECK_ME(I, PHASE_INITIALIZATION | PHASE_EVENT | PHASE_CONTINUOUS | PHASE_TERMINATED | PHASE_ERROR,
             "fmi2GetContinuousStates");
    return (fmi2Status)me_get_states(I, x, nx, "fmi2GetContinuousStates");
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x_nominal[], size_t nx) {
    Instance *I = (Instance *)c;
    CHECK_ME(I, ANY_PHASE, "fmi2GetNominalsOfContinuousStates");
    return (fmi2Status)me_get_nominals(I, x_nominal, nx, "fmi2GetNominalsOfContinuousStates");
}
