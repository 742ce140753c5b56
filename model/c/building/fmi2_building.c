/* FMI 2.0 Co-Simulation layer of ShearBuilding: the instance, its life cycle and call
 * sequence, variable access by value reference (variables.def), the record file and the
 * communication step. The model itself is building.c. No global state: every instance is
 * self-contained. canGetAndSetFMUstate is false; Model Exchange is not offered. */
#include <ctype.h>
#include <locale.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "fmi2Functions.h"
#include "config.h" /* MODEL_GUID, written by fmu_build */
#include "building.h"
#include "record.h"

#define MSG_LEN 1024

/* Where an instance is in its life cycle (one bit each: sets of allowed phases are masks). */
typedef enum {
    PHASE_INSTANTIATED = 1,
    PHASE_INITIALIZATION = 2,
    PHASE_STEP_COMPLETE = 4,
    PHASE_TERMINATED = 8,
    PHASE_ERROR = 16
} Phase;
#define ANY_PHASE 31
#define SET_PHASES (PHASE_INSTANTIATED | PHASE_INITIALIZATION | PHASE_STEP_COMPLETE)
#define GET_PHASES (PHASE_INITIALIZATION | PHASE_STEP_COMPLETE | PHASE_TERMINATED | PHASE_ERROR)

typedef struct {
    Building b;
    Phase phase;
    int dirty; /* parameters set since the last initialisation */
    double tc, startTime, stopTime;
    int stopDefined, toleranceDefined;
    double tolerance;
    Record rec; /* the record of excitation.file, read at initialisation */
    char *name;
    char *resourceDir;      /* local path of resources/, or NULL */
    char resourceNote[300]; /* why there is none, when the importer gave a location */
    fmi2CallbackFunctions cb;
    int loggingOn;
} Instance;

/* ---------------------------------------------------------------- logging */

/* One line (control characters replaced, '.' as the decimal point, '%' doubled for FMI 2.0's
 * printf-style logger). Errors are always logged. */
static void log_msg(const Instance *I, fmi2Status status, const char *category, const char *fmt, ...) {
    char buf[MSG_LEN], text[2 * MSG_LEN];
    va_list ap;
    if (!I || !I->cb.logger) return;
    if (status == fmi2OK && !I->loggingOn) return;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof(buf), fmt, ap);
    va_end(ap);
    const struct lconv *lc = localeconv();
    char point = (lc && lc->decimal_point && lc->decimal_point[0]) ? lc->decimal_point[0] : '.';
    size_t k = 0;
    for (char *p = buf; *p && k + 2 < sizeof(text); p++) {
        if ((unsigned char)*p < 0x20 || *p == 0x7f) *p = '?';
        if (point != '.' && *p == point && p > buf && isdigit((unsigned char)p[-1]) && isdigit((unsigned char)p[1]))
            *p = '.';
        if (*p == '%') text[k++] = '%';
        text[k++] = *p;
    }
    text[k] = '\0';
    I->cb.logger(I->cb.componentEnvironment, I->name, status, category, text);
}
#define LOG_ERROR(I, ...) log_msg(I, fmi2Error, "logStatusError", __VA_ARGS__)

static int bad_call(Instance *I, int allowed, const char *fn) {
    if (!I) return 1;
    if (!(I->phase & allowed)) {
        LOG_ERROR(I, "%s must not be called in the current state (%d)", fn, (int)I->phase);
        return 1;
    }
    return 0;
}

#define CHECK(I, allowed, fn)                            \
    do {                                                 \
        if (bad_call(I, allowed, fn)) return fmi2Error;  \
    } while (0)

/* --------------------------------------------------------- initialisation */

/* Read excitation.file into I->rec (freeing the previous record); 0, or 1 after logging. */
static int load_record(Instance *I) {
    char path[BUILDING_FILE_CAPACITY + 512], msg[MSG_LEN];
    const char *file = I->b.v.file;
    record_free(&I->rec, I->cb.freeMemory);
    if (!file[0]) { /* none, unless this copy of the FMU carries its base record */
        FILE *f = I->resourceDir && record_path(BUILDING_BASE_RECORD, I->resourceDir, path, sizeof(path), msg,
                                                sizeof(msg)) == 0 ? fopen(path, "rb") : NULL;
        if (!f) return 0;
        fclose(f);
        file = BUILDING_BASE_RECORD;
    }
    if (!I->resourceDir && I->resourceNote[0] && !record_is_absolute(file)) {
        LOG_ERROR(I, "invalid parameter: excitation.file: '%s' is a relative path, but the importer's resources "
                     "location %s", file, I->resourceNote);
        return 1;
    }
    if (record_path(file, I->resourceDir, path, sizeof(path), msg, sizeof(msg)) ||
        record_read(path, &I->rec, I->cb.allocateMemory, I->cb.freeMemory, msg, sizeof(msg))) {
        LOG_ERROR(I, "invalid parameter: excitation.file: %s", msg);
        return 1;
    }
    return 0;
}

/* Validate, read the record and put the building at rest at the start time, if parameters
 * changed; 0, or 1 after logging. */
static int initialize(Instance *I) {
    char msg[MSG_LEN];
    if (!I->dirty) return 0;
    /* the tighter of solver.relTol and the importer's tolerance (as RockingBlock, docs/model.md):
     * an importer's coarse default (OMSimulator's 1e-4) must not loosen what the user set */
    if (I->toleranceDefined && I->tolerance < I->b.v.relTol) I->b.v.relTol = I->tolerance;
    if (building_validate(&I->b.v, msg, sizeof(msg))) {
        LOG_ERROR(I, "invalid parameter: %s", msg);
        return 1;
    }
    if (load_record(I)) return 1;
    const Record *rec = I->rec.n > 0 ? &I->rec : NULL;
    if (building_validate_record(&I->b.v, rec, msg, sizeof(msg))) {
        LOG_ERROR(I, "invalid parameter: record file '%s': %s", I->b.v.file, msg);
        return 1;
    }
    building_start(&I->b, rec, I->startTime);
    I->tc = I->startTime;
    I->dirty = 0;
    return 0;
}

/* ------------------------------------------------------------- life cycle */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    Instance *I = (Instance *)c;
    CHECK(I, ANY_PHASE, "fmi2SetDebugLogging");
    if (nCategories > 0 && !categories) {
        LOG_ERROR(I, "fmi2SetDebugLogging: categories is NULL");
        return fmi2Error;
    }
    for (size_t i = 0; i < nCategories; i++)
        if (categories[i] && strcmp(categories[i], "logStatusError") != 0) {
            LOG_ERROR(I, "fmi2SetDebugLogging: unknown log category '%s'", categories[i]);
            return fmi2Error;
        }
    I->loggingOn = loggingOn ? 1 : 0;
    return fmi2OK;
}

static char *copy_string(const Instance *I, const char *s) {
    size_t len = strlen(s) + 1;
    char *p = (char *)I->cb.allocateMemory(len, 1);
    if (p) memcpy(p, s, len);
    return p;
}

static void reset(Instance *I) {
    record_free(&I->rec, I->cb.freeMemory);
    memset(&I->b, 0, sizeof(I->b));
    building_defaults(&I->b.v);
    I->phase = PHASE_INSTANTIATED;
    I->dirty = 1;
    I->tc = I->startTime = I->stopTime = I->tolerance = 0.0;
    I->stopDefined = I->toleranceDefined = 0;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
    (void)visible;
    if (!functions || !functions->allocateMemory || !functions->freeMemory) return NULL;
    Instance tmp; /* a stand-in, to log why there will be no instance */
    memset(&tmp, 0, sizeof(tmp));
    tmp.cb = *functions;
    tmp.name = (char *)(instanceName ? instanceName : "ShearBuilding");
    if (!instanceName || !instanceName[0]) {
        LOG_ERROR(&tmp, "fmi2Instantiate: missing instance name");
        return NULL;
    }
    if (fmuType != fmi2CoSimulation) {
        LOG_ERROR(&tmp, "fmi2Instantiate: ShearBuilding is a Co-Simulation FMU (fmuType %d requested)", (int)fmuType);
        return NULL;
    }
    if (!fmuGUID || strcmp(fmuGUID, MODEL_GUID) != 0) {
        LOG_ERROR(&tmp, "fmi2Instantiate: GUID '%s' does not match this binary (%s)", fmuGUID ? fmuGUID : "(null)",
              MODEL_GUID);
        return NULL;
    }
    Instance *I = (Instance *)functions->allocateMemory(1, sizeof(Instance));
    if (!I) {
        LOG_ERROR(&tmp, "fmi2Instantiate: out of memory");
        return NULL;
    }
    memset(I, 0, sizeof(*I));
    I->cb = *functions;
    I->loggingOn = loggingOn ? 1 : 0;
    I->name = copy_string(I, instanceName);
    if (!I->name) {
        functions->freeMemory(I);
        LOG_ERROR(&tmp, "fmi2Instantiate: out of memory");
        return NULL;
    }
    /* record files named by a relative excitation.file live in resources/ */
    if (fmuResourceLocation && fmuResourceLocation[0]) {
        char dir[BUILDING_FILE_CAPACITY];
        if (record_uri_to_path(fmuResourceLocation, dir, sizeof(dir)) == 0) I->resourceDir = copy_string(I, dir);
        if (!I->resourceDir)
            snprintf(I->resourceNote, sizeof(I->resourceNote), "'%.200s%s' is not a local folder this FMU can read",
                     fmuResourceLocation, strlen(fmuResourceLocation) > 200 ? "..." : "");
    }
    reset(I);
    return I;
}

void fmi2FreeInstance(fmi2Component c) {
    Instance *I = (Instance *)c;
    if (!I) return;
    fmi2CallbackFreeMemory release = I->cb.freeMemory;
    record_free(&I->rec, release);
    if (I->resourceDir) release(I->resourceDir);
    release(I->name);
    release(I);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    Instance *I = (Instance *)c;
    CHECK(I, PHASE_INSTANTIATED, "fmi2SetupExperiment");
    if (!isfinite(startTime) || (stopTimeDefined && !(isfinite(stopTime) && stopTime >= startTime))) {
        LOG_ERROR(I, "fmi2SetupExperiment: invalid start time %g or stop time %g", startTime, stopTime);
        return fmi2Error;
    }
    if (toleranceDefined && !(tolerance >= BUILDING_REL_TOL_MIN && tolerance <= BUILDING_REL_TOL_MAX)) {
        LOG_ERROR(I, "fmi2SetupExperiment: tolerance %g must be in [%g, %g] (the tighter of it and solver.relTol is used)", tolerance,
              BUILDING_REL_TOL_MIN, BUILDING_REL_TOL_MAX);
        return fmi2Error;
    }
    I->startTime = startTime;
    I->stopDefined = stopTimeDefined ? 1 : 0;
    I->stopTime = stopTimeDefined ? stopTime : 0.0;
    I->toleranceDefined = toleranceDefined ? 1 : 0;
    I->tolerance = toleranceDefined ? tolerance : 0.0;
    I->tc = startTime;
    I->dirty = 1;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    Instance *I = (Instance *)c;
    CHECK(I, PHASE_INSTANTIATED, "fmi2EnterInitializationMode");
    I->dirty = 1; /* parameters may still change: validated when read or at the exit */
    I->phase = PHASE_INITIALIZATION;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    Instance *I = (Instance *)c;
    CHECK(I, PHASE_INITIALIZATION, "fmi2ExitInitializationMode");
    if (initialize(I)) return fmi2Error;
    I->phase = PHASE_STEP_COMPLETE;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c) {
    Instance *I = (Instance *)c;
    CHECK(I, PHASE_STEP_COMPLETE | PHASE_ERROR, "fmi2Terminate");
    I->phase = PHASE_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c) {
    Instance *I = (Instance *)c;
    CHECK(I, ANY_PHASE, "fmi2Reset");
    reset(I);
    return fmi2OK;
}

/* -------------------------------------------------------- variable access */

typedef enum { TYPE_REAL, TYPE_INTEGER, TYPE_STRING } VarType;
typedef enum { CAUSALITY_parameter, CAUSALITY_calculatedParameter, CAUSALITY_input, CAUSALITY_output } Causality;
static const char *const TYPE_NAMES[] = {"Real", "Integer", "String"};

typedef struct {
    VarType type;
    Causality causality;
    char name[64];
    unsigned storey; /* i of a storey[i] variable, else 0 */
} VarInfo;

/* Address of the variable with value reference vr, and what it is; NULL when unknown. */
static void *var_address(BuildingVars *v, unsigned vr, VarInfo *info) {
    switch (vr) {
#define VAR(T, ref, field, name_, caus, var, start, unit, desc) \
    case ref:                                                   \
        info->type = TYPE_##T;                                  \
        info->causality = CAUSALITY_##caus;                     \
        info->storey = 0;                                       \
        snprintf(info->name, sizeof(info->name), "%s", name_);  \
        return &v->field;
#define STOREY(T, base, field, member, caus, var, start, unit, desc)
#include "variables.def"
#undef VAR
#undef STOREY
    default:
        break;
    }
#define VAR(T, ref, field, name_, caus, var, start, unit, desc)
#define STOREY(T, base, field, member, caus, var, start, unit, desc)                       \
    if (vr > (base) && vr <= (base) + BUILDING_MAX_STOREYS) {                              \
        info->type = TYPE_##T;                                                             \
        info->causality = CAUSALITY_##caus;                                                \
        info->storey = vr - (base);                                                        \
        snprintf(info->name, sizeof(info->name), "storey[%u].%s", vr - (base), member);    \
        return &v->field[vr - (base) - 1];                                                 \
    }
#include "variables.def"
#undef VAR
#undef STOREY
    return NULL;
}

/* Common checks of a getter or setter; returns the variable's address or NULL after logging. */
static void *lookup(Instance *I, unsigned vr, VarType want, int set, const char *fn, VarInfo *info) {
    void *p = var_address(&I->b.v, vr, info);
    if (!p || info->type != want) {
        LOG_ERROR(I, "%s: unknown %s value reference %u", fn, TYPE_NAMES[want], vr);
        return NULL;
    }
    if (set) {
        if (info->causality == CAUSALITY_output || info->causality == CAUSALITY_calculatedParameter) {
            LOG_ERROR(I, "%s: '%s' is calculated and cannot be set", fn, info->name);
            return NULL;
        }
        if (info->causality == CAUSALITY_parameter && !(I->phase & (PHASE_INSTANTIATED | PHASE_INITIALIZATION))) {
            LOG_ERROR(I, "%s: '%s' cannot be set after initialization", fn, info->name);
            return NULL;
        }
        if (info->causality == CAUSALITY_parameter) I->dirty = 1;
    }
    return p;
}

/* Phase and array checks; a getter also initialises when parameters changed. */
static int begin_access(Instance *I, int set, const void *vr, size_t nvr, const void *value, const char *fn) {
    if (bad_call(I, set ? SET_PHASES : GET_PHASES, fn)) return 1;
    if (nvr > 0 && (!vr || !value)) {
        LOG_ERROR(I, "%s: NULL array with nvr = %zu", fn, nvr);
        return 1;
    }
    if (!set && I->phase == PHASE_INITIALIZATION) return initialize(I);
    return 0;
}

/* Direct feedthrough: after inputs changed, the outputs at the current time follow. */
static void inputs_changed(Instance *I) {
    if (!I->dirty && (I->phase & (PHASE_INITIALIZATION | PHASE_STEP_COMPLETE))) building_outputs(&I->b);
}

/* 1 after logging when an input other than 0 is set on a storey above nStoreys after initialisation.
 * Before, nStoreys may still change: initialisation checks it (building_validate). */
static int absent_storey(Instance *I, const VarInfo *info, double value, const char *fn) {
    int n = I->b.v.nStoreys;
    if (info->causality != CAUSALITY_input || info->storey == 0 || value == 0.0 || (int)info->storey <= n) return 0;
    if (I->phase != PHASE_STEP_COMPLETE) {
        I->dirty = 1; /* validated again when initialisation ends or an output is read */
        return 0;
    }
    LOG_ERROR(I, "%s: %s = %g N acts on a storey the building does not have (nStoreys = %d)", fn, info->name,
              value, n);
    return 1;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    Instance *I = (Instance *)c;
    VarInfo info;
    if (begin_access(I, 1, vr, nvr, value, "fmi2SetReal")) return fmi2Error;
    for (size_t i = 0; i < nvr; i++) {
        double *p = (double *)lookup(I, vr[i], TYPE_REAL, 1, "fmi2SetReal", &info);
        if (!p || !isfinite(value[i]) || absent_storey(I, &info, value[i], "fmi2SetReal")) {
            if (p && !isfinite(value[i]))
                LOG_ERROR(I, "fmi2SetReal: '%s' = %g is not a finite number", info.name, value[i]);
            inputs_changed(I); /* the values before the refused one are set */
            return fmi2Error;
        }
        *p = value[i];
        int k = (int)info.storey - 1; /* a force set at a later communication point than its derivative: held */
        if (k >= 0 && p == &I->b.v.force[k] && I->b.forceT0[k] != I->tc) I->b.dForce[k] = 0.0;
    }
    inputs_changed(I);
    return fmi2OK;
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[]) {
    Instance *I = (Instance *)c;
    VarInfo info;
    if (begin_access(I, 1, vr, nvr, value, "fmi2SetInteger")) return fmi2Error;
    for (size_t i = 0; i < nvr; i++) {
        int *p = (int *)lookup(I, vr[i], TYPE_INTEGER, 1, "fmi2SetInteger", &info);
        if (!p) return fmi2Error;
        *p = value[i];
    }
    return fmi2OK;
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[]) {
    Instance *I = (Instance *)c;
    if (begin_access(I, 1, vr, nvr, value, "fmi2SetBoolean")) return fmi2Error;
    if (nvr > 0) {
        LOG_ERROR(I, "fmi2SetBoolean: unknown Boolean value reference %u (ShearBuilding has no Boolean variables)",
                  vr[0]);
        return fmi2Error;
    }
    return fmi2OK;
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[]) {
    Instance *I = (Instance *)c;
    VarInfo info;
    if (begin_access(I, 1, vr, nvr, value, "fmi2SetString")) return fmi2Error;
    for (size_t i = 0; i < nvr; i++) {
        char *p = (char *)lookup(I, vr[i], TYPE_STRING, 1, "fmi2SetString", &info);
        if (!p) return fmi2Error;
        if (!value[i]) {
            LOG_ERROR(I, "fmi2SetString: '%s' = NULL (give an empty string instead)", info.name);
            return fmi2Error;
        }
        size_t len = strlen(value[i]);
        if (len >= BUILDING_FILE_CAPACITY) {
            LOG_ERROR(I, "fmi2SetString: '%s' is %zu bytes long, at most %d are allowed", info.name, len,
                  BUILDING_FILE_CAPACITY - 1);
            return fmi2Error;
        }
        memcpy(p, value[i], len + 1);
    }
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    Instance *I = (Instance *)c;
    VarInfo info;
    if (begin_access(I, 0, vr, nvr, value, "fmi2GetReal")) return fmi2Error;
    for (size_t i = 0; i < nvr; i++) {
        const double *p = (const double *)lookup(I, vr[i], TYPE_REAL, 0, "fmi2GetReal", &info);
        if (!p) return fmi2Error;
        value[i] = *p;
    }
    return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[]) {
    Instance *I = (Instance *)c;
    VarInfo info;
    if (begin_access(I, 0, vr, nvr, value, "fmi2GetInteger")) return fmi2Error;
    for (size_t i = 0; i < nvr; i++) {
        const int *p = (const int *)lookup(I, vr[i], TYPE_INTEGER, 0, "fmi2GetInteger", &info);
        if (!p) return fmi2Error;
        value[i] = *p;
    }
    return fmi2OK;
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[]) {
    Instance *I = (Instance *)c;
    if (begin_access(I, 0, vr, nvr, value, "fmi2GetBoolean")) return fmi2Error;
    if (nvr > 0) {
        LOG_ERROR(I, "fmi2GetBoolean: unknown Boolean value reference %u (ShearBuilding has no Boolean variables)",
                  vr[0]);
        return fmi2Error;
    }
    return fmi2OK;
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[]) {
    Instance *I = (Instance *)c;
    VarInfo info;
    if (begin_access(I, 0, vr, nvr, value, "fmi2GetString")) return fmi2Error;
    for (size_t i = 0; i < nvr; i++) {
        const char *p = (const char *)lookup(I, vr[i], TYPE_STRING, 0, "fmi2GetString", &info);
        if (!p) return fmi2Error;
        value[i] = p; /* valid until the variable is set again or the instance is freed */
    }
    return fmi2OK;
}

/* ------------------------------------------------------------- FMU state */

/* A saved state: the building (its record re-attached on restore: the instance owns it), the phase, the
 * communication point, and the record it ran on (a state is restored only onto the same record). */
#define STATE_MAGIC 0x53425354u /* "SBST" */
typedef struct {
    unsigned magic;
    Building b;
    Phase phase;
    int dirty;
    double tc;
    int recN;
} Snapshot;

#define STATE_PHASES (PHASE_INITIALIZATION | PHASE_STEP_COMPLETE | PHASE_TERMINATED)

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *state) {
    Instance *I = (Instance *)c;
    const char *fn = "fmi2GetFMUstate";
    CHECK(I, STATE_PHASES, fn);
    if (!state) {
        LOG_ERROR(I, "%s: NULL state pointer", fn);
        return fmi2Error;
    }
    Snapshot *s = (Snapshot *)*state;
    if (!s) s = (Snapshot *)I->cb.allocateMemory(1, sizeof(Snapshot));
    else if (s->magic != STATE_MAGIC) {
        LOG_ERROR(I, "%s: *state is not a ShearBuilding state (give NULL for a new one)", fn);
        return fmi2Error;
    }
    if (!s) {
        LOG_ERROR(I, "%s: out of memory", fn);
        return fmi2Error;
    }
    s->magic = STATE_MAGIC;
    s->b = I->b;
    s->b.rec = NULL;
    s->phase = I->phase;
    s->dirty = I->dirty;
    s->tc = I->tc;
    s->recN = I->rec.n;
    *state = s;
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state) {
    Instance *I = (Instance *)c;
    const char *fn = "fmi2SetFMUstate";
    CHECK(I, STATE_PHASES, fn);
    const Snapshot *s = (const Snapshot *)state;
    if (!s || s->magic != STATE_MAGIC) {
        LOG_ERROR(I, "%s: not a ShearBuilding state", fn);
        return fmi2Error;
    }
    if (s->recN != I->rec.n || strcmp(s->b.v.file, I->b.v.file) != 0) {
        LOG_ERROR(I, "%s: the state ran on another record ('%s', %d samples; this instance: '%s', %d)", fn,
                  s->b.v.file, s->recN, I->b.v.file, I->rec.n);
        return fmi2Error;
    }
    I->b = s->b;
    I->b.rec = I->rec.n > 0 ? &I->rec : NULL;
    I->phase = s->phase;
    I->dirty = s->dirty;
    I->tc = s->tc;
    return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *state) {
    Instance *I = (Instance *)c;
    CHECK(I, ANY_PHASE, "fmi2FreeFMUstate");
    if (state && *state) {
        I->cb.freeMemory(*state);
        *state = NULL;
    }
    return fmi2OK;
}

static fmi2Status no_states(fmi2Component c, const char *fn) {
    Instance *I = (Instance *)c;
    CHECK(I, ANY_PHASE, fn);
    LOG_ERROR(I, "%s: ShearBuilding cannot serialize FMU states (canSerializeFMUstate is false)", fn);
    return fmi2Error;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate state, size_t *size) {
    (void)state, (void)size;
    return no_states(c, "fmi2SerializedFMUstateSize");
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate state, fmi2Byte bytes[], size_t size) {
    (void)state, (void)bytes, (void)size;
    return no_states(c, "fmi2SerializeFMUstate");
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[], size_t size, fmi2FMUstate *state) {
    (void)bytes, (void)size, (void)state;
    return no_states(c, "fmi2DeSerializeFMUstate");
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
    Instance *I = (Instance *)c;
    (void)vUnknown_ref, (void)nUnknown, (void)vKnown_ref, (void)nKnown, (void)dvKnown, (void)dvUnknown;
    CHECK(I, ANY_PHASE, "fmi2GetDirectionalDerivative");
    LOG_ERROR(I, "fmi2GetDirectionalDerivative is not supported");
    return fmi2Error;
}

/* ---------------------------------------------------------- co-simulation */

/* The first derivative of a floor's force (storey[i].force): the force is then a straight line from the
 * communication point over the step (building_force); a value set at a later communication point ends it. */
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    Instance *I = (Instance *)c;
    VarInfo info;
    const char *fn = "fmi2SetRealInputDerivatives";
    if (begin_access(I, 1, vr, nvr, value, fn)) return fmi2Error;
    if (nvr > 0 && !order) {
        LOG_ERROR(I, "%s: NULL order array with nvr = %zu", fn, nvr);
        return fmi2Error;
    }
    for (size_t i = 0; i < nvr; i++) {
        const double *p = (const double *)lookup(I, vr[i], TYPE_REAL, 1, fn, &info);
        if (!p) return fmi2Error;
        int k = (int)info.storey - 1;
        if (info.causality != CAUSALITY_input || k < 0 || p != &I->b.v.force[k]) {
            LOG_ERROR(I, "%s: '%s' takes no derivatives (the floors' storey[i].force do)", fn, info.name);
            return fmi2Error;
        }
        if (order[i] != 1) {
            LOG_ERROR(I, "%s: derivative of order %d of '%s' (the FMU takes the first)", fn, (int)order[i], info.name);
            return fmi2Error;
        }
        if (!isfinite(value[i])) {
            LOG_ERROR(I, "%s: derivative 1 of '%s' = %g is not a finite number", fn, info.name, value[i]);
            return fmi2Error;
        }
        if (absent_storey(I, &info, value[i], fn)) return fmi2Error;
        I->b.dForce[k] = value[i];
        I->b.forceT0[k] = I->tc;
    }
    inputs_changed(I);
    return fmi2OK;
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
    Instance *I = (Instance *)c;
    VarInfo info;
    const char *fn = "fmi2GetRealOutputDerivatives";
    if (begin_access(I, 0, vr, nvr, value, fn)) return fmi2Error;
    if (nvr > 0 && !order) {
        LOG_ERROR(I, "%s: NULL order array with nvr = %zu", fn, nvr);
        return fmi2Error;
    }
    for (size_t i = 0; i < nvr; i++) {
        const double *p = (const double *)lookup(I, vr[i], TYPE_REAL, 0, fn, &info);
        if (!p) return fmi2Error;
        if (order[i] != 1) {
            LOG_ERROR(I, "%s: derivative of order %d of '%s' (maxOutputDerivativeOrder is 1)", fn, (int)order[i],
                      info.name);
            return fmi2Error;
        }
        if (building_output_derivative(&I->b, p, &value[i])) {
            LOG_ERROR(I, "%s: '%s' has no derivative output (the floors' storey[i].u, .v, .a and .structureForce have)", fn, info.name);
            return fmi2Error;
        }
    }
    return fmi2OK;
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    Instance *I = (Instance *)c;
    (void)noSetFMUStatePriorToCurrentPoint;
    CHECK(I, PHASE_STEP_COMPLETE, "fmi2DoStep");
    double tc = I->tc, h = communicationStepSize;
    if (!isfinite(currentCommunicationPoint) || !isfinite(h) || h < 0) {
        LOG_ERROR(I, "fmi2DoStep: invalid communication point %g or step size %g", currentCommunicationPoint, h);
        return fmi2Error;
    }
    if (fabs(currentCommunicationPoint - tc) > 1e-9 * fmax(1.0, fabs(tc))) {
        LOG_ERROR(I, "fmi2DoStep: communication point %.17g does not match the FMU time %.17g",
                  currentCommunicationPoint, tc);
        return fmi2Error;
    }
    double target = currentCommunicationPoint + h;
    if (I->stopDefined && target > I->stopTime + 1e-9 * fmax(1.0, fabs(I->stopTime))) {
        LOG_ERROR(I, "fmi2DoStep: the step to %.17g ends after the stop time %.17g", target, I->stopTime);
        return fmi2Error;
    }
    char msg[MSG_LEN];
    if (target > I->b.t && building_advance(&I->b, target, msg, sizeof(msg))) {
        LOG_ERROR(I, "fmi2DoStep: %s", msg);
        I->phase = PHASE_ERROR;
        return fmi2Error;
    }
    I->tc = fmax(target, I->b.t);
    building_outputs(&I->b);
    return fmi2OK;
}

fmi2Status fmi2CancelStep(fmi2Component c) {
    Instance *I = (Instance *)c;
    CHECK(I, ANY_PHASE, "fmi2CancelStep");
    LOG_ERROR(I, "fmi2CancelStep: fmi2DoStep is synchronous, there is nothing to cancel");
    return fmi2Error;
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    Instance *I = (Instance *)c;
    (void)s, (void)value;
    CHECK(I, ANY_PHASE, "fmi2GetStatus");
    return fmi2Discard;
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    Instance *I = (Instance *)c;
    CHECK(I, ANY_PHASE, "fmi2GetRealStatus");
    if (s == fmi2LastSuccessfulTime && value) {
        *value = I->tc;
        return fmi2OK;
    }
    return fmi2Discard;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    Instance *I = (Instance *)c;
    (void)s, (void)value;
    CHECK(I, ANY_PHASE, "fmi2GetIntegerStatus");
    return fmi2Discard;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    Instance *I = (Instance *)c;
    CHECK(I, ANY_PHASE, "fmi2GetBooleanStatus");
    if (s == fmi2Terminated && value) {
        *value = fmi2False; /* the building never ends a run by itself */
        return fmi2OK;
    }
    return fmi2Discard;
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    Instance *I = (Instance *)c;
    (void)s, (void)value;
    CHECK(I, ANY_PHASE, "fmi2GetStringStatus");
    return fmi2Discard;
}
