/* FMI 3.0 layer of RockingBlock: Co-Simulation with event mode, early return
 * and intermediate update, over the same instance as the FMI 2.0 layer
 * (instance.c: life cycle, variables, states, the communication step). It
 * checks FMI 3.0's call sequence and arguments, converts types and calls the
 * instance. Model Exchange and Scheduled Execution are not offered. No global
 * state: each fmi3Instance owns its Instance.
 *
 * Early return: every event of the built-in solver (impact, uplift, overturn,
 * a pattern change of two blocks) can end a step. With earlyReturnAllowed and
 * no intermediateUpdate callback the step ends at the first event after the
 * communication point; with a callback, the callback is called at each event
 * inside the step and the step ends there only if it asks to. Events are
 * applied inside the step, so the event mode that follows has nothing left
 * to update. */
#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <ctype.h>
#include <string.h>

#include "fmi3Functions.h"
#include "codes.h"
#include "config.h" /* MODEL_GUID (the instantiationToken), written by fmu_build */
#include "instance.h"
#include "solver.h"

/* The independent variable "time" (fmu_build/model_description3.py declares it). */
#define TIME_VR 0u

typedef struct {
    Instance *I;
    int eventModeUsed;
    int earlyReturnAllowed;
    fmi3IntermediateUpdateCallback intermediateUpdate; /* NULL: none */
    int inCallback; /* inside intermediateUpdate: getters only */
} Fmu3;

/* FMI 3.0 messages are plain text. */
static void emit(const Instance *I, int status, const char *category, const char *message) {
    fmi3LogMessageCallback log = (fmi3LogMessageCallback)I->logger;
    if (log) log(I->env, (fmi3Status)status, category, message);
}

/* Nonzero (after logging) unless the call is allowed now. */
static int bad_call(Fmu3 *W, int allowed, const char *fn) {
    if (!W) return 1;
    if (W->inCallback) {
        INSTANCE_ERROR(W->I, "%s must not be called from the intermediateUpdate callback", fn);
        return 1;
    }
    return instance_bad_call(W->I, allowed, fn);
}

#define CHECK(W, allowed, fn)                                   \
    do {                                                        \
        if (bad_call(W, allowed, fn)) return fmi3Error;         \
    } while (0)

#define UNSUPPORTED(instance, fn, why)                          \
    do {                                                        \
        Fmu3 *W_ = (Fmu3 *)(instance);                          \
        if (!W_) return fmi3Error;                              \
        INSTANCE_ERROR(W_->I, "%s is not supported: %s", fn, why); \
        return fmi3Error;                                       \
    } while (0)

/* ------------------------------------------------------------- life cycle */

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[]) {
    Fmu3 *W = (Fmu3 *)instance;
    if (!W) return fmi3Error;
    return (fmi3Status)instance_set_logging(W->I, loggingOn, nCategories, categories, "fmi3SetDebugLogging");
}

/* The outputs (causality output) may be read in intermediate update mode. */
#define IS_OUTPUT_parameter 0
#define IS_OUTPUT_input 0
#define IS_OUTPUT_output 1
static int intermediate_variable(fmi3ValueReference vr) {
    switch (vr) {
#define VAR(T, ref, field, name, caus, var, start, unit, desc) \
    case ref:                                                  \
        return IS_OUTPUT_##caus;
#include "variables.def"
#undef VAR
    default:
        return 0;
    }
}

/* Nonzero for an Enumeration variable (one an ITEM line of variables.def names): FMI 3.0
 * reads and sets those with fmi3GetInt64 and fmi3SetInt64 only (the C type of an
 * Enumeration is fmi3Int64), its Int32 functions serve the Int32 variables only. */
static int item_names(const char *pattern, const char *name) {
    /* "block*.member" (an ITEM line of the blocks' families) names blockK.member for every K */
    const char *star = strchr(pattern, '*');
    if (!star) return strcmp(pattern, name) == 0;
    size_t head = (size_t)(star - pattern);
    if (strncmp(pattern, name, head) != 0 || !isdigit((unsigned char)name[head])) return 0;
    return strcmp(star + 1, name + head + 1) == 0;
}
static int is_enumeration(fmi3ValueReference vr) {
    const char *name;
    switch (vr) {
#define VAR(T, ref, field, name_, caus, var, start, unit, desc) \
    case ref:                                                   \
        name = name_;                                           \
        break;
#include "variables.def"
#undef VAR
    default:
        return 0;
    }
#define VAR(T, ref, field, name_, caus, var, start, unit, desc)
#define RANGE(...)
#define CODE(code, field, codeName, enumName)
#define ITEM(var, type, value, item, desc) \
    if (item_names(var, name)) return 1;
#include "variables.def"
#undef ITEM
#undef CODE
#undef RANGE
#undef VAR
    return 0;
}

/* Nonzero (after logging) if vr is (enumeration) or is not (!enumeration) an Enumeration. */
static int wrong_integer_type(Fmu3 *W, fmi3ValueReference vr, int enumeration, const char *fn) {
    if (is_enumeration(vr) == enumeration) return 0;
    if (enumeration)
        INSTANCE_ERROR(W->I, "%s: unknown Int64 value reference %u (the FMU's Int64 variables are its Enumerations)",
                       fn, (unsigned)vr);
    else
        INSTANCE_ERROR(W->I, "%s: value reference %u is an Enumeration: FMI 3.0 reads and sets it with "
                       "fmi3GetInt64 and fmi3SetInt64", fn, (unsigned)vr);
    return 1;
}

/* FMI 3.0 gives the resources folder as a local path ending in a separator;
 * the instance reads a file URI (record_uri_to_path), in which '%' must be
 * escaped. Returns a new string, or NULL when out of memory. */
static char *path_to_uri(const char *path) {
    size_t n = strlen(path), k = 0;
    char *uri = (char *)calloc(3 * n + 16, 1);
    if (!uri) return NULL;
    const char *scheme = "";
    if (path[0] == '/') scheme = "file://";
    else if (((path[0] | 0x20) >= 'a' && (path[0] | 0x20) <= 'z') && path[1] == ':') scheme = "file:///"; /* C:\ */
    k = strlen(scheme);
    memcpy(uri, scheme, k);
    for (const char *p = path; *p; p++) {
        if (*p == '%') {
            memcpy(uri + k, "%25", 3);
            k += 3;
        } else {
            uri[k++] = *p;
        }
    }
    uri[k] = '\0';
    return uri;
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment,
                                         fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate) {
    const char *fn = "fmi3InstantiateCoSimulation";
    (void)visible;
    /* a stand-in, to log why there will be no instance */
    Instance tmp;
    memset(&tmp, 0, sizeof(tmp));
    tmp.emit = emit;
    tmp.env = instanceEnvironment;
    tmp.logger = (void (*)(void))logMessage;
    tmp.name = (char *)(instanceName ? instanceName : "RockingBlock");
    if (!instanceName || !instanceName[0]) {
        INSTANCE_ERROR(&tmp, "%s: missing instance name", fn);
        return NULL;
    }
    if (!instantiationToken || strcmp(instantiationToken, MODEL_GUID) != 0) {
        INSTANCE_ERROR(&tmp, "%s: instantiationToken '%s' does not match this binary (%s)", fn,
                       instantiationToken ? instantiationToken : "(null)", MODEL_GUID);
        return NULL;
    }
    if (nRequiredIntermediateVariables > 0 && !requiredIntermediateVariables) {
        INSTANCE_ERROR(&tmp, "%s: requiredIntermediateVariables is NULL with nRequiredIntermediateVariables = %zu",
                       fn, nRequiredIntermediateVariables);
        return NULL;
    }
    for (size_t i = 0; i < nRequiredIntermediateVariables; i++)
        if (!intermediate_variable(requiredIntermediateVariables[i])) {
            INSTANCE_ERROR(&tmp, "%s: value reference %u is not an intermediate variable (the outputs are)", fn,
                           (unsigned)requiredIntermediateVariables[i]);
            return NULL;
        }
    Fmu3 *W = (Fmu3 *)calloc(1, sizeof(Fmu3));
    char *uri = resourcePath && resourcePath[0] ? path_to_uri(resourcePath) : NULL;
    if (!W || (resourcePath && resourcePath[0] && !uri)) {
        free(W);
        free(uri);
        INSTANCE_ERROR(&tmp, "%s: out of memory", fn);
        return NULL;
    }
    W->I = instance_new(instanceName, INTERFACE_CS, uri, emit, instanceEnvironment, (void (*)(void))logMessage,
                        calloc, free, loggingOn);
    free(uri);
    if (!W->I) {
        free(W);
        INSTANCE_ERROR(&tmp, "%s: out of memory", fn);
        return NULL;
    }
    W->eventModeUsed = eventModeUsed ? 1 : 0;
    W->earlyReturnAllowed = earlyReturnAllowed ? 1 : 0;
    W->intermediateUpdate = intermediateUpdate;
    return W;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage) {
    Instance tmp;
    (void)instantiationToken, (void)resourcePath, (void)visible, (void)loggingOn;
    memset(&tmp, 0, sizeof(tmp));
    tmp.emit = emit;
    tmp.env = instanceEnvironment;
    tmp.logger = (void (*)(void))logMessage;
    tmp.name = (char *)(instanceName ? instanceName : "RockingBlock");
    INSTANCE_ERROR(&tmp, "fmi3InstantiateModelExchange: this FMU offers FMI 3.0 Co-Simulation only");
    return NULL;
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
                                               fmi3String resourcePath, fmi3Boolean visible,
                                               fmi3Boolean loggingOn, fmi3InstanceEnvironment instanceEnvironment,
                                               fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
                                               fmi3LockPreemptionCallback lockPreemption,
                                               fmi3UnlockPreemptionCallback unlockPreemption) {
    Instance tmp;
    (void)instantiationToken, (void)resourcePath, (void)visible, (void)loggingOn, (void)clockUpdate;
    (void)lockPreemption, (void)unlockPreemption;
    memset(&tmp, 0, sizeof(tmp));
    tmp.emit = emit;
    tmp.env = instanceEnvironment;
    tmp.logger = (void (*)(void))logMessage;
    tmp.name = (char *)(instanceName ? instanceName : "RockingBlock");
    INSTANCE_ERROR(&tmp, "fmi3InstantiateScheduledExecution: this FMU offers FMI 3.0 Co-Simulation only");
    return NULL;
}

void fmi3FreeInstance(fmi3Instance instance) {
    Fmu3 *W = (Fmu3 *)instance;
    if (!W) return;
    if (W->inCallback) { /* the instance is in use further up the stack: refuse */
        INSTANCE_ERROR(W->I, "fmi3FreeInstance must not be called from the intermediateUpdate callback");
        return;
    }
    instance_free(W->I);
    free(W);
}

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
    Fmu3 *W = (Fmu3 *)instance;
    const char *fn = "fmi3EnterInitializationMode";
    CHECK(W, PHASE_INSTANTIATED, fn);
    Instance *I = W->I;
    if (instance_setup_experiment(I, toleranceDefined, tolerance, startTime, stopTimeDefined, stopTime, fn))
        return fmi3Error;
    I->s.dirty = 1;
    if (codes_apply(I, fn) || instance_initialize(I) != STATUS_OK) return fmi3Error;
    I->s.phase = PHASE_INITIALIZATION;
    return fmi3OK;
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) {
    Fmu3 *W = (Fmu3 *)instance;
    CHECK(W, PHASE_INITIALIZATION, "fmi3ExitInitializationMode");
    if (codes_apply(W->I, "fmi3ExitInitializationMode") || instance_initialize(W->I) != STATUS_OK) return fmi3Error;
    /* FMI 3.0: with eventModeUsed, Co-Simulation starts in event mode */
    W->I->s.phase = W->eventModeUsed ? PHASE_EVENT : PHASE_STEP_COMPLETE;
    return fmi3OK;
}

fmi3Status fmi3EnterEventMode(fmi3Instance instance) {
    Fmu3 *W = (Fmu3 *)instance;
    CHECK(W, PHASE_STEP_COMPLETE, "fmi3EnterEventMode");
    if (!W->eventModeUsed) {
        INSTANCE_ERROR(W->I, "fmi3EnterEventMode: the instance was instantiated with eventModeUsed = false");
        return fmi3Error;
    }
    W->I->s.phase = PHASE_EVENT;
    return fmi3OK;
}

fmi3Status fmi3Terminate(fmi3Instance instance) {
    Fmu3 *W = (Fmu3 *)instance;
    CHECK(W, RUNNING_PHASES | PHASE_ERROR, "fmi3Terminate");
    Instance *I = W->I;
    if (I->s.phase & (PHASE_STEP_COMPLETE | PHASE_EVENT)) { /* peaks the outputs counted that no later step will log */
        Logger log = instance_solver_logger(I);
        solver_log_pending(&I->s.model, I->s.tc, &log);
    }
    I->s.phase = PHASE_TERMINATED;
    return fmi3OK;
}

fmi3Status fmi3Reset(fmi3Instance instance) {
    Fmu3 *W = (Fmu3 *)instance;
    CHECK(W, ANY_PHASE, "fmi3Reset");
    instance_reset(W->I);
    W->I->s.type = INTERFACE_CS;
    return fmi3OK;
}

/* -------------------------------------------------------- variable access */

/* Common checks of a getter or setter: call sequence (getters may be called
 * from the intermediateUpdate callback), arrays, and nValues, which equals
 * nValueReferences since every variable is a scalar. */
static int begin_access(Fmu3 *W, int set, const fmi3ValueReference vr[], size_t nvr, const void *values,
                        size_t nValues, const char *fn) {
    if (!W) return 1;
    if (W->inCallback && set) {
        INSTANCE_ERROR(W->I, "%s: no variable may be set from the intermediateUpdate callback", fn);
        return 1;
    }
    if (instance_begin_access(W->I, set, vr, nvr, values, fn)) return 1;
    if (nValues != nvr) {
        INSTANCE_ERROR(W->I, "%s: nValues = %zu, but the %zu variables are scalars (nValues must equal %zu)", fn,
                       nValues, nvr, nvr);
        return 1;
    }
    return 0;
}

/* A type this FMU has no variables of: any value reference is unknown. */
static fmi3Status no_variables(fmi3Instance instance, int set, const fmi3ValueReference vr[], size_t nvr,
                               const void *values, size_t nValues, const char *type, const char *fn) {
    Fmu3 *W = (Fmu3 *)instance;
    if (begin_access(W, set, vr, nvr, values, nValues, fn)) return fmi3Error;
    if (nvr == 0) return fmi3OK;
    INSTANCE_ERROR(W->I, "%s: unknown %s value reference %u (the FMU has no %s variables)", fn, type,
                   (unsigned)vr[0], type);
    return fmi3Error;
}

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, fmi3Float64 values[],
                          size_t nValues) {
    Fmu3 *W = (Fmu3 *)instance;
    const char *fn = "fmi3GetFloat64";
    if (begin_access(W, 0, vr, nvr, values, nValues, fn)) return fmi3Error;
    for (size_t i = 0; i < nvr; i++) {
        if (vr[i] == TIME_VR) values[i] = W->I->s.tc;
        else if (instance_get_real(W->I, vr[i], &values[i], fn)) return fmi3Error;
    }
    return fmi3OK;
}

fmi3Status fmi3GetInt32(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, fmi3Int32 values[],
                        size_t nValues) {
    Fmu3 *W = (Fmu3 *)instance;
    const char *fn = "fmi3GetInt32";
    if (begin_access(W, 0, vr, nvr, values, nValues, fn)) return fmi3Error;
    for (size_t i = 0; i < nvr; i++) {
        int v;
        if (wrong_integer_type(W, vr[i], 0, fn) || instance_get_integer(W->I, vr[i], &v, fn)) return fmi3Error;
        values[i] = (fmi3Int32)v;
    }
    return fmi3OK;
}

fmi3Status fmi3GetInt64(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, fmi3Int64 values[],
                        size_t nValues) {
    Fmu3 *W = (Fmu3 *)instance;
    const char *fn = "fmi3GetInt64";
    if (begin_access(W, 0, vr, nvr, values, nValues, fn)) return fmi3Error;
    for (size_t i = 0; i < nvr; i++) {
        int v;
        if (wrong_integer_type(W, vr[i], 1, fn) || instance_get_integer(W->I, vr[i], &v, fn)) return fmi3Error;
        values[i] = (fmi3Int64)v;
    }
    return fmi3OK;
}

fmi3Status fmi3GetBoolean(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, fmi3Boolean values[],
                          size_t nValues) {
    Fmu3 *W = (Fmu3 *)instance;
    const char *fn = "fmi3GetBoolean";
    if (begin_access(W, 0, vr, nvr, values, nValues, fn)) return fmi3Error;
    for (size_t i = 0; i < nvr; i++) {
        int b;
        if (instance_get_boolean(W->I, vr[i], &b, fn)) return fmi3Error;
        values[i] = b ? fmi3True : fmi3False;
    }
    return fmi3OK;
}

fmi3Status fmi3GetString(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, fmi3String values[],
                         size_t nValues) {
    Fmu3 *W = (Fmu3 *)instance;
    const char *fn = "fmi3GetString";
    if (begin_access(W, 0, vr, nvr, values, nValues, fn)) return fmi3Error;
    for (size_t i = 0; i < nvr; i++)
        if (instance_get_string(W->I, vr[i], &values[i], fn)) return fmi3Error;
    return fmi3OK;
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                          const fmi3Float64 values[], size_t nValues) {
    Fmu3 *W = (Fmu3 *)instance;
    const char *fn = "fmi3SetFloat64";
    if (begin_access(W, 1, vr, nvr, values, nValues, fn)) return fmi3Error;
    for (size_t i = 0; i < nvr; i++) {
        if (vr[i] == TIME_VR) {
            INSTANCE_ERROR(W->I, "%s: 'time' is the independent variable and cannot be set", fn);
            return fmi3Error;
        }
        if (instance_set_real(W->I, vr[i], values[i], fn)) return fmi3Error;
    }
    instance_update_outputs(W->I); /* direct feedthrough of the inputs */
    return fmi3OK;
}

fmi3Status fmi3SetInt32(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, const fmi3Int32 values[],
                        size_t nValues) {
    Fmu3 *W = (Fmu3 *)instance;
    const char *fn = "fmi3SetInt32";
    if (begin_access(W, 1, vr, nvr, values, nValues, fn)) return fmi3Error;
    for (size_t i = 0; i < nvr; i++)
        if (wrong_integer_type(W, vr[i], 0, fn) || instance_set_integer(W->I, vr[i], (int)values[i], fn))
            return fmi3Error;
    return fmi3OK;
}

fmi3Status fmi3SetInt64(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, const fmi3Int64 values[],
                        size_t nValues) {
    Fmu3 *W = (Fmu3 *)instance;
    const char *fn = "fmi3SetInt64";
    if (begin_access(W, 1, vr, nvr, values, nValues, fn)) return fmi3Error;
    for (size_t i = 0; i < nvr; i++) {
        if (wrong_integer_type(W, vr[i], 1, fn)) return fmi3Error;
        if (values[i] < INT_MIN || values[i] > INT_MAX) {  /* no item is that far out */
            INSTANCE_ERROR(W->I, "%s: value %lld of value reference %u is not a value of its Enumeration", fn,
                           (long long)values[i], (unsigned)vr[i]);
            return fmi3Error;
        }
        if (instance_set_integer(W->I, vr[i], (int)values[i], fn)) return fmi3Error;
    }
    return fmi3OK;
}

fmi3Status fmi3SetBoolean(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                          const fmi3Boolean values[], size_t nValues) {
    Fmu3 *W = (Fmu3 *)instance;
    const char *fn = "fmi3SetBoolean";
    if (begin_access(W, 1, vr, nvr, values, nValues, fn)) return fmi3Error;
    for (size_t i = 0; i < nvr; i++)
        if (instance_set_boolean(W->I, vr[i], values[i] ? 1 : 0, fn)) return fmi3Error;
    return fmi3OK;
}

fmi3Status fmi3SetString(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, const fmi3String values[],
                         size_t nValues) {
    Fmu3 *W = (Fmu3 *)instance;
    const char *fn = "fmi3SetString";
    if (begin_access(W, 1, vr, nvr, values, nValues, fn)) return fmi3Error;
    for (size_t i = 0; i < nvr; i++)
        if (instance_set_string(W->I, vr[i], values[i], fn)) return fmi3Error;
    return fmi3OK;
}

#define NO_VARIABLES(Type, CType, set, constness)                                                                \
    fmi3Status fmi3##set##Type(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,                  \
                               constness CType values[], size_t nValues) {                                       \
        return no_variables(instance, #set[0] == 'S', vr, nvr, values, nValues, #Type, "fmi3" #set #Type);         \
    }

NO_VARIABLES(Float32, fmi3Float32, Get, )
NO_VARIABLES(Int8, fmi3Int8, Get, )
NO_VARIABLES(UInt8, fmi3UInt8, Get, )
NO_VARIABLES(Int16, fmi3Int16, Get, )
NO_VARIABLES(UInt16, fmi3UInt16, Get, )
NO_VARIABLES(UInt32, fmi3UInt32, Get, )
NO_VARIABLES(UInt64, fmi3UInt64, Get, )
NO_VARIABLES(Float32, fmi3Float32, Set, const)
NO_VARIABLES(Int8, fmi3Int8, Set, const)
NO_VARIABLES(UInt8, fmi3UInt8, Set, const)
NO_VARIABLES(Int16, fmi3Int16, Set, const)
NO_VARIABLES(UInt16, fmi3UInt16, Set, const)
NO_VARIABLES(UInt32, fmi3UInt32, Set, const)
NO_VARIABLES(UInt64, fmi3UInt64, Set, const)

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, size_t valueSizes[],
                         fmi3Binary values[], size_t nValues) {
    (void)valueSizes;
    return no_variables(instance, 0, vr, nvr, values, nValues, "Binary", "fmi3GetBinary");
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                         const size_t valueSizes[], const fmi3Binary values[], size_t nValues) {
    (void)valueSizes;
    return no_variables(instance, 1, vr, nvr, values, nValues, "Binary", "fmi3SetBinary");
}

fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, fmi3Clock values[]) {
    return no_variables(instance, 0, vr, nvr, values, nvr, "Clock", "fmi3GetClock");
}

fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, const fmi3Clock values[]) {
    return no_variables(instance, 1, vr, nvr, values, nvr, "Clock", "fmi3SetClock");
}

/* ---------------------------------------------------- variable dependencies */

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance, fmi3ValueReference valueReference,
                                               size_t *nDependencies) {
    (void)valueReference, (void)nDependencies;
    UNSUPPORTED(instance, "fmi3GetNumberOfVariableDependencies", "the FMU gives no dependency information");
}

fmi3Status fmi3GetVariableDependencies(fmi3Instance instance, fmi3ValueReference dependent,
                                       size_t elementIndicesOfDependent[], fmi3ValueReference independents[],
                                       size_t elementIndicesOfIndependents[], fmi3DependencyKind dependencyKinds[],
                                       size_t nDependencies) {
    (void)dependent, (void)elementIndicesOfDependent, (void)independents, (void)elementIndicesOfIndependents;
    (void)dependencyKinds, (void)nDependencies;
    UNSUPPORTED(instance, "fmi3GetVariableDependencies", "the FMU gives no dependency information");
}

/* -------------------------------------------------------------- FMU state */

fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *state) {
    Fmu3 *W = (Fmu3 *)instance;
    CHECK(W, ANY_PHASE, "fmi3GetFMUState");
    return (fmi3Status)instance_get_state(W->I, (void **)state, "fmi3GetFMUState");
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState state) {
    Fmu3 *W = (Fmu3 *)instance;
    CHECK(W, ANY_PHASE, "fmi3SetFMUState");
    return (fmi3Status)instance_set_state(W->I, state, "fmi3SetFMUState");
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *state) {
    Fmu3 *W = (Fmu3 *)instance;
    CHECK(W, ANY_PHASE, "fmi3FreeFMUState");
    return (fmi3Status)instance_free_state(W->I, (void **)state);
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState state, size_t *size) {
    Fmu3 *W = (Fmu3 *)instance;
    (void)state;
    CHECK(W, ANY_PHASE, "fmi3SerializedFMUStateSize");
    if (!size) {
        INSTANCE_ERROR(W->I, "fmi3SerializedFMUStateSize: size pointer is NULL");
        return fmi3Error;
    }
    *size = instance_state_size();
    return fmi3OK;
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState state, fmi3Byte serializedState[],
                                 size_t size) {
    Fmu3 *W = (Fmu3 *)instance;
    CHECK(W, ANY_PHASE, "fmi3SerializeFMUState");
    return (fmi3Status)instance_serialize_state(W->I, state, serializedState, size, "fmi3SerializeFMUState");
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[], size_t size,
                                   fmi3FMUState *state) {
    Fmu3 *W = (Fmu3 *)instance;
    CHECK(W, ANY_PHASE, "fmi3DeserializeFMUState");
    return (fmi3Status)instance_deserialize_state(W->I, serializedState, size, (void **)state,
                                                  "fmi3DeserializeFMUState");
}

/* ------------------------------------------------------ partial derivatives */

fmi3Status fmi3GetDirectionalDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[],
                                        size_t nUnknowns, const fmi3ValueReference knowns[], size_t nKnowns,
                                        const fmi3Float64 seed[], size_t nSeed, fmi3Float64 sensitivity[],
                                        size_t nSensitivity) {
    (void)unknowns, (void)nUnknowns, (void)knowns, (void)nKnowns, (void)seed, (void)nSeed, (void)sensitivity;
    (void)nSensitivity;
    UNSUPPORTED(instance, "fmi3GetDirectionalDerivative", "providesDirectionalDerivatives is false");
}

fmi3Status fmi3GetAdjointDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                    const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                    size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity) {
    (void)unknowns, (void)nUnknowns, (void)knowns, (void)nKnowns, (void)seed, (void)nSeed, (void)sensitivity;
    (void)nSensitivity;
    UNSUPPORTED(instance, "fmi3GetAdjointDerivative", "providesAdjointDerivatives is false");
}

/* ------------------------------------------------- configuration and clocks */

fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance) {
    UNSUPPORTED(instance, "fmi3EnterConfigurationMode", "the FMU has no structural parameters");
}

fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance) {
    UNSUPPORTED(instance, "fmi3ExitConfigurationMode", "the FMU has no structural parameters");
}

fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                  fmi3Float64 intervals[], fmi3IntervalQualifier qualifiers[]) {
    (void)vr, (void)nvr, (void)intervals, (void)qualifiers;
    UNSUPPORTED(instance, "fmi3GetIntervalDecimal", "the FMU has no clocks");
}

fmi3Status fmi3GetIntervalFraction(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                   fmi3UInt64 counters[], fmi3UInt64 resolutions[],
                                   fmi3IntervalQualifier qualifiers[]) {
    (void)vr, (void)nvr, (void)counters, (void)resolutions, (void)qualifiers;
    UNSUPPORTED(instance, "fmi3GetIntervalFraction", "the FMU has no clocks");
}

fmi3Status fmi3GetShiftDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                               fmi3Float64 shifts[]) {
    (void)vr, (void)nvr, (void)shifts;
    UNSUPPORTED(instance, "fmi3GetShiftDecimal", "the FMU has no clocks");
}

fmi3Status fmi3GetShiftFraction(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                fmi3UInt64 counters[], fmi3UInt64 resolutions[]) {
    (void)vr, (void)nvr, (void)counters, (void)resolutions;
    UNSUPPORTED(instance, "fmi3GetShiftFraction", "the FMU has no clocks");
}

fmi3Status fmi3SetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                  const fmi3Float64 intervals[]) {
    (void)vr, (void)nvr, (void)intervals;
    UNSUPPORTED(instance, "fmi3SetIntervalDecimal", "the FMU has no clocks");
}

fmi3Status fmi3SetIntervalFraction(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                   const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]) {
    (void)vr, (void)nvr, (void)counters, (void)resolutions;
    UNSUPPORTED(instance, "fmi3SetIntervalFraction", "the FMU has no clocks");
}

fmi3Status fmi3SetShiftDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                               const fmi3Float64 shifts[]) {
    (void)vr, (void)nvr, (void)shifts;
    UNSUPPORTED(instance, "fmi3SetShiftDecimal", "the FMU has no clocks");
}

fmi3Status fmi3SetShiftFraction(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]) {
    (void)vr, (void)nvr, (void)counters, (void)resolutions;
    UNSUPPORTED(instance, "fmi3SetShiftFraction", "the FMU has no clocks");
}

fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime) {
    (void)clockReference, (void)activationTime;
    UNSUPPORTED(instance, "fmi3ActivateModelPartition", "Scheduled Execution is not offered");
}

/* ------------------------------------------------------------- event mode */

fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance) {
    UNSUPPORTED(instance, "fmi3EvaluateDiscreteStates", "providesEvaluateDiscreteStates is false");
}

/* The events a step ends at were applied inside the step: nothing is left to
 * update, and no time event is announced. NULL outputs are skipped. */
fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation, fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged, fmi3Boolean *nextEventTimeDefined,
                                    fmi3Float64 *nextEventTime) {
    Fmu3 *W = (Fmu3 *)instance;
    CHECK(W, PHASE_EVENT, "fmi3UpdateDiscreteStates");
    if (discreteStatesNeedUpdate) *discreteStatesNeedUpdate = fmi3False;
    if (terminateSimulation) *terminateSimulation = W->I->s.terminated ? fmi3True : fmi3False;
    if (nominalsOfContinuousStatesChanged) *nominalsOfContinuousStatesChanged = fmi3False;
    if (valuesOfContinuousStatesChanged) *valuesOfContinuousStatesChanged = fmi3False;
    if (nextEventTimeDefined) *nextEventTimeDefined = fmi3False;
    if (nextEventTime) *nextEventTime = 0.0;
    return fmi3OK;
}

/* ------------------------------------------------------- model exchange */

#define NOT_ME(fn) UNSUPPORTED(instance, fn, "it is a Model Exchange function, and this FMU offers Co-Simulation")

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance) { NOT_ME("fmi3EnterContinuousTimeMode"); }

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation) {
    (void)noSetFMUStatePriorToCurrentPoint, (void)enterEventMode, (void)terminateSimulation;
    NOT_ME("fmi3CompletedIntegratorStep");
}

fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time) {
    (void)time;
    NOT_ME("fmi3SetTime");
}

fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 x[], size_t nx) {
    (void)x, (void)nx;
    NOT_ME("fmi3SetContinuousStates");
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 derivatives[], size_t nx) {
    (void)derivatives, (void)nx;
    NOT_ME("fmi3GetContinuousStateDerivatives");
}

fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 eventIndicators[], size_t ni) {
    (void)eventIndicators, (void)ni;
    NOT_ME("fmi3GetEventIndicators");
}

fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 x[], size_t nx) {
    (void)x, (void)nx;
    NOT_ME("fmi3GetContinuousStates");
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 nominals[], size_t nx) {
    (void)nominals, (void)nx;
    NOT_ME("fmi3GetNominalsOfContinuousStates");
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t *nEventIndicators) {
    (void)nEventIndicators;
    NOT_ME("fmi3GetNumberOfEventIndicators");
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t *nContinuousStates) {
    (void)nContinuousStates;
    NOT_ME("fmi3GetNumberOfContinuousStates");
}

/* -------------------------------------------------------- co-simulation */

fmi3Status fmi3EnterStepMode(fmi3Instance instance) {
    Fmu3 *W = (Fmu3 *)instance;
    CHECK(W, PHASE_EVENT, "fmi3EnterStepMode");
    W->I->s.phase = PHASE_STEP_COMPLETE;
    return fmi3OK;
}

fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                    const fmi3Int32 orders[], fmi3Float64 values[], size_t nValues) {
    (void)vr, (void)nvr, (void)orders, (void)values, (void)nValues;
    UNSUPPORTED(instance, "fmi3GetOutputDerivatives", "maxOutputDerivativeOrder is 0");
}

/* The step size that takes t exactly to target, when a double can do so. */
static double remaining(double t, double target) {
    double h = target - t;
    for (int i = 0; i < 4 && t + h != target; i++) h = nextafter(h, t + h < target ? INFINITY : -INFINITY);
    return h;
}

/* Asks the importer's callback at an event at time t inside the step; returns
 * the time to end the step at: t, or the later earlyReturnTime the importer
 * asked for (at most stopAt, which means going on). */
static double ask_importer(Fmu3 *W, double t, double stopAt) {
    fmi3Boolean requested = fmi3False;
    fmi3Float64 when = t;
    W->inCallback = 1;
    W->intermediateUpdate(W->I->env, t, fmi3False, fmi3True, fmi3True, W->earlyReturnAllowed ? fmi3True : fmi3False,
                          &requested, &when);
    W->inCallback = 0;
    if (!W->earlyReturnAllowed || !requested) return stopAt;
    if (!(when > t)) return t; /* at the event (also for a NaN) */
    return when < stopAt ? when : stopAt;
}

/* One communication step. The instance advances with early return at every
 * event (it ends right after an event, which it has applied), and the layer
 * decides whether the step ends there; resuming from an event continues the
 * integrator's own step sequence, so the trajectory does not depend on it. */
fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint,
                      fmi3Float64 communicationStepSize, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                      fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn,
                      fmi3Float64 *lastSuccessfulTime) {
    Fmu3 *W = (Fmu3 *)instance;
    const char *fn = "fmi3DoStep";
    (void)noSetFMUStatePriorToCurrentPoint;
    CHECK(W, PHASE_STEP_COMPLETE, fn);
    Instance *I = W->I;
    fmi3Boolean dummyB;
    fmi3Float64 dummyT;
    if (!eventHandlingNeeded) eventHandlingNeeded = &dummyB;
    if (!terminateSimulation) terminateSimulation = &dummyB;
    if (!earlyReturn) earlyReturn = &dummyB;
    if (!lastSuccessfulTime) lastSuccessfulTime = &dummyT;
    *eventHandlingNeeded = *terminateSimulation = *earlyReturn = fmi3False;
    *lastSuccessfulTime = I->s.tc;
    if (!(communicationStepSize > 0)) {
        INSTANCE_ERROR(I, "%s: communicationStepSize %g must be > 0", fn, communicationStepSize);
        return fmi3Error;
    }
    if (I->s.terminated) {
        *terminateSimulation = fmi3True;
        INSTANCE_ERROR(I, "%s: the run ended at the overturn at t = %.17g (solver.stopAtOverturn): call fmi3Terminate",
                       fn, I->s.tc);
        return fmi3Error;
    }
    double target = currentCommunicationPoint + communicationStepSize, stopAt = target;
    double t = currentCommunicationPoint, h = communicationStepSize;
    int early = 0;
    StepResult r;
    for (;;) {
        Status st = instance_do_step(I, t, h, 1, &r, fn);
        *lastSuccessfulTime = I->s.tc;
        if (st == STATUS_ERROR) return fmi3Error;
        if (r.terminate) { /* the block overturned with solver.stopAtOverturn: the run ends here */
            *terminateSimulation = fmi3True;
            *eventHandlingNeeded = W->eventModeUsed ? fmi3True : fmi3False;
            if (r.time < target && !W->earlyReturnAllowed) {
                /* only part of the step was computed, and early return is not allowed */
                if (I->loggingOn && I->logEvents)
                    instance_log(I, STATUS_DISCARD, "logEvents",
                                 "%s: the run ended at the overturn at t=%.17g (solver.stopAtOverturn), before the "
                                 "step's end %.17g",
                                 fn, r.time, target);
                return fmi3Discard;
            }
            *earlyReturn = r.time < target ? fmi3True : fmi3False;
            return fmi3OK;
        }
        if (!r.earlyReturn) break; /* at stopAt, possibly at an event right there */
        /* an event at r.time inside the step */
        double end = stopAt;
        if (W->intermediateUpdate) end = ask_importer(W, r.time, stopAt);
        else if (W->earlyReturnAllowed) end = r.time;
        if (end < target) early = 1;
        if (end == r.time) break;
        stopAt = end;
        t = r.time;
        h = remaining(t, stopAt);
    }
    *eventHandlingNeeded = (W->eventModeUsed && r.event) ? fmi3True : fmi3False;
    *earlyReturn = early ? fmi3True : fmi3False;
    return fmi3OK;
}
