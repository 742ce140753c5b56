/* FMI 2.0 Co-Simulation interface of RockingBlock: instance life cycle, call
 * sequence checks, variable access, FMU state and stepping. All physics is in
 * model.c and solver.c; this file holds no global state. */
#if defined(__linux__) && !defined(_POSIX_C_SOURCE)
#define _POSIX_C_SOURCE 200809L /* struct stat's st_mtim */
#endif
#include <ctype.h>
#include <float.h>
#include <locale.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

#include "fmi2Functions.h"
#include "config.h" /* MODEL_GUID, written by fmu_build */
#include "ground.h"
#include "model.h"
#include "record.h"
#include "solver.h"

typedef enum {
    PHASE_INSTANTIATED = 1,
    PHASE_INITIALIZATION = 2,
    PHASE_STEP_COMPLETE = 4,
    PHASE_TERMINATED = 8,
    PHASE_ERROR = 16
} Phase;

#define SNAPSHOT_MAGIC 0x524f434bu /* "ROCK" */

typedef struct {
    unsigned magic;
    unsigned size;
    Model model;
    double tc, startTime, stopTime;
    int stopDefined;
    Phase phase;
    int dirty;
} Snapshot;

/* The file a record was read from, to read it again only when it changed. */
typedef struct {
    char path[STRING_CAPACITY];
    double size, mtime, mtimeNs, inode;
} FileStamp;

typedef struct {
    Snapshot s; /* everything that makes up the FMU state */
    fmi2CallbackFunctions cb;
    char *name;
    char *resourceDir; /* local path of the FMU's resources folder, or NULL */
    char resourceNote[300]; /* why there is none, when the importer gave a location */
    int loggingOn;
    int logEvents;
    Record rec;        /* the record of excitation.kind = 4, read once per file */
    FileStamp recFile;
} Instance;

#define MSG_LEN (STRING_CAPACITY + 512)

/* ---------------------------------------------------------------- logging */

static void log_message(Instance *I, fmi2Status status, const char *category,
                        const char *fmt, ...) {
    char buf[MSG_LEN];
    va_list ap;
    if (!I || !I->cb.logger) return;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof(buf), fmt, ap);
    va_end(ap);
    /* One line, whatever the message quotes (a path with a newline, escape codes);
     * numbers written with '.' whatever the importer's locale (event lines are read
     * by programs, and printf follows LC_NUMERIC: ',' in German); '%' doubled,
     * because the logger treats the message as a format. */
    const struct lconv *lc = localeconv();
    char point = (lc && lc->decimal_point && lc->decimal_point[0]) ? lc->decimal_point[0] : '.';
    char out[2 * MSG_LEN];
    size_t k = 0;
    for (const char *p = buf; *p && k + 2 < sizeof(out); p++) {
        char c = *p;
        if ((unsigned char)c < 0x20 || c == 0x7f) c = '?';
        if (point != '.' && c == point && p > buf && isdigit((unsigned char)p[-1]) && isdigit((unsigned char)p[1]))
            c = '.';
        if (c == '%') out[k++] = '%';
        out[k++] = c;
    }
    out[k] = '\0';
    I->cb.logger(I->cb.componentEnvironment, I->name, status, category, out);
}

#define LOG_ERROR(I, ...) log_message(I, fmi2Error, "logStatusError", __VA_ARGS__)

static void solver_log(void *ctx, int category, const char *message) {
    Instance *I = (Instance *)ctx;
    if (category == 1) LOG_ERROR(I, "%s", message);
    else if (I->loggingOn && I->logEvents) log_message(I, fmi2OK, "logEvents", "%s", message);
}

/* Check that the instance exists and is in one of the allowed phases. */
static int bad_call(Instance *I, int allowed, const char *fn) {
    if (!I) return 1;
    if (!(I->s.phase & allowed)) {
        LOG_ERROR(I, "%s must not be called in the current state (%d)", fn, (int)I->s.phase);
        return 1;
    }
    return 0;
}

#define CHECK(I, allowed, fn)                  \
    do {                                       \
        if (bad_call(I, allowed, fn)) return fmi2Error; \
    } while (0)

#define ANY_PHASE (PHASE_INSTANTIATED | PHASE_INITIALIZATION | PHASE_STEP_COMPLETE | PHASE_TERMINATED | PHASE_ERROR)
#define GET_PHASES (PHASE_INITIALIZATION | PHASE_STEP_COMPLETE | PHASE_TERMINATED | PHASE_ERROR)

/* ---------------------------------------------------------------- records */

static void stamp_of(const struct stat *st, const char *path, FileStamp *f) {
    memset(f, 0, sizeof(*f)); /* compared with memcmp: no stray bytes */
    snprintf(f->path, sizeof(f->path), "%s", path);
    f->size = (double)st->st_size;
    f->mtime = (double)st->st_mtime;
    f->inode = (double)st->st_ino;
#if defined(__linux__)
    f->mtimeNs = (double)st->st_mtim.tv_nsec;
#endif
}

/* A record read for the instance but not yet adopted by it (stage_record). */
typedef struct {
    int fresh;    /* 0: the instance's own record is the one; 1: rec holds a new one */
    Record rec;
    FileStamp stamp;
} StagedRecord;

/* Find the record that `file` (an excitation.file value) names: the instance's own if it
 * read the same file (path, size, modification time) before, else read it into
 * staged->rec. With want, the samples must have want's count and hash (a state saved on
 * other samples is refused). Nothing of the instance changes: the caller adopts the
 * record with adopt_record, or drops it with drop_record. */
static int stage_record(Instance *I, const char *file, const Derived *want, StagedRecord *staged, char *msg,
                        size_t n) {
    char path[STRING_CAPACITY];
    struct stat st;
    memset(staged, 0, sizeof(*staged));
    if (!I->resourceDir && I->resourceNote[0] && file[0] && !record_is_absolute(file)) {
        snprintf(msg, n, "'%s' is a relative path, but the importer's resources location %s", file,
                 I->resourceNote);
        return 1;
    }
    if (record_path(file, I->resourceDir, path, sizeof(path), msg, n)) return 1;
    int known = stat(path, &st) == 0;
    if (known) stamp_of(&st, path, &staged->stamp);
    int cached = known && I->rec.n > 0 && memcmp(&staged->stamp, &I->recFile, sizeof(staged->stamp)) == 0;
    if (!cached && record_read(path, &staged->rec, I->cb.allocateMemory, I->cb.freeMemory, msg, n)) return 1;
    staged->fresh = !cached;
    const Record *r = cached ? &I->rec : &staged->rec;
    if (want && (r->n != want->recN || r->hash != want->recHash)) {
        snprintf(msg, n, "the record file '%s' changed since the state was saved (%d samples then, %d now)",
                 path, want->recN, r->n);
        if (staged->fresh) record_free(&staged->rec, I->cb.freeMemory);
        staged->fresh = 0;
        return 1;
    }
    return 0;
}

static const Record *staged_record(const Instance *I, const StagedRecord *staged) {
    return staged->fresh ? &staged->rec : &I->rec;
}

static void drop_record(Instance *I, StagedRecord *staged) {
    if (staged->fresh) record_free(&staged->rec, I->cb.freeMemory);
    staged->fresh = 0;
}

/* The instance holds the staged record from now on (its previous one is freed). */
static void adopt_record(Instance *I, StagedRecord *staged) {
    if (!staged->fresh) return;
    record_free(&I->rec, I->cb.freeMemory);
    I->rec = staged->rec;
    I->recFile = staged->stamp;
    staged->fresh = 0;
}

/* Validate, derive and initialise if parameters changed; write outputs. */
static fmi2Status ensure_initialized(Instance *I) {
    Model *M = &I->s.model;
    if (!I->s.dirty) return fmi2OK;
    char msg[MSG_LEN];
    if (model_validate(&M->v, msg, sizeof(msg))) {
        LOG_ERROR(I, "invalid parameter: %s", msg);
        return fmi2Error;
    }
    M->rec = NULL;
    if (M->v.kind == KIND_RECORD) {
        StagedRecord staged;
        if (stage_record(I, M->v.file, NULL, &staged, msg, sizeof(msg))) {
            LOG_ERROR(I, "excitation.file: %s", msg);
            return fmi2Error;
        }
        adopt_record(I, &staged);
        M->rec = &I->rec;
        if (ground_validate_record(M, msg, sizeof(msg))) {
            LOG_ERROR(I, "invalid parameter: %s", msg);
            return fmi2Error;
        }
    }
    model_derive(M);
    solver_initialize(M, I->s.startTime);
    I->s.tc = I->s.startTime;
    solver_outputs(M, I->s.tc);
    I->s.dirty = 0;
    return fmi2OK;
}

/* ------------------------------------------------------------- life cycle */

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn,
                               size_t nCategories, const fmi2String categories[]) {
    Instance *I = (Instance *)c;
    CHECK(I, ANY_PHASE, "fmi2SetDebugLogging");
    I->loggingOn = loggingOn;
    if (nCategories == 0) {
        I->logEvents = 1;
        return fmi2OK;
    }
    if (!categories) {
        LOG_ERROR(I, "fmi2SetDebugLogging: categories is NULL");
        return fmi2Error;
    }
    I->logEvents = 0;
    for (size_t i = 0; i < nCategories; i++) {
        if (!categories[i]) continue;
        if (strcmp(categories[i], "logEvents") == 0) I->logEvents = 1;
        else if (strcmp(categories[i], "logStatusError") != 0) {
            LOG_ERROR(I, "fmi2SetDebugLogging: unknown log category '%s'", categories[i]);
            return fmi2Error;
        }
    }
    return fmi2OK;
}

static void reset_instance(Instance *I) {
    memset(&I->s, 0, sizeof(I->s));
    I->s.magic = SNAPSHOT_MAGIC;
    I->s.size = (unsigned)sizeof(Snapshot);
    model_set_defaults(&I->s.model);
    I->s.phase = PHASE_INSTANTIATED;
    I->s.dirty = 1;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType,
                              fmi2String fmuGUID, fmi2String fmuResourceLocation,
                              const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
    (void)visible;
    if (!functions || !functions->allocateMemory || !functions->freeMemory) return NULL;
    Instance tmp;
    memset(&tmp, 0, sizeof(tmp));
    tmp.cb = *functions;
    tmp.name = (char *)(instanceName ? instanceName : "RockingBlock");
    if (!instanceName || !instanceName[0]) {
        LOG_ERROR(&tmp, "fmi2Instantiate: missing instance name");
        return NULL;
    }
    if (fmuType != fmi2CoSimulation) {
        LOG_ERROR(&tmp, "fmi2Instantiate: RockingBlock supports Co-Simulation only");
        return NULL;
    }
    if (!fmuGUID || strcmp(fmuGUID, MODEL_GUID) != 0) {
        LOG_ERROR(&tmp, "fmi2Instantiate: GUID '%s' does not match this binary (%s)",
                  fmuGUID ? fmuGUID : "(null)", MODEL_GUID);
        return NULL;
    }
    Instance *I = (Instance *)functions->allocateMemory(1, sizeof(Instance));
    if (!I) return NULL;
    memset(I, 0, sizeof(*I));
    I->cb = *functions;
    size_t len = strlen(instanceName) + 1;
    I->name = (char *)functions->allocateMemory(len, 1);
    if (!I->name) {
        functions->freeMemory(I);
        return NULL;
    }
    memcpy(I->name, instanceName, len);
    /* record files named by a relative excitation.file live in resources/ */
    char dir[STRING_CAPACITY];
    if (fmuResourceLocation && fmuResourceLocation[0]) {
        if (record_uri_to_path(fmuResourceLocation, dir, sizeof(dir)) == 0) {
            size_t dlen = strlen(dir) + 1;
            I->resourceDir = (char *)functions->allocateMemory(dlen, 1);
            if (I->resourceDir) memcpy(I->resourceDir, dir, dlen);
        }
        if (!I->resourceDir)
            snprintf(I->resourceNote, sizeof(I->resourceNote), "'%.200s%s' is not a local folder this FMU can read",
                     fmuResourceLocation, strlen(fmuResourceLocation) > 200 ? "..." : "");
    }
    I->loggingOn = loggingOn;
    I->logEvents = 1;
    reset_instance(I);
    return I;
}

void fmi2FreeInstance(fmi2Component c) {
    Instance *I = (Instance *)c;
    if (!I) return;
    fmi2CallbackFreeMemory freeMemory = I->cb.freeMemory;
    record_free(&I->rec, freeMemory);
    if (I->resourceDir) freeMemory(I->resourceDir);
    freeMemory(I->name);
    freeMemory(I);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined,
                               fmi2Real tolerance, fmi2Real startTime,
                               fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    Instance *I = (Instance *)c;
    (void)toleranceDefined;
    (void)tolerance; /* the FMU's own solver.relTol governs accuracy */
    CHECK(I, PHASE_INSTANTIATED, "fmi2SetupExperiment");
    if (!isfinite(startTime) || (stopTimeDefined && !(isfinite(stopTime) && stopTime >= startTime))) {
        LOG_ERROR(I, "fmi2SetupExperiment: invalid start time %g or stop time %g", startTime, stopTime);
        return fmi2Error;
    }
    I->s.startTime = startTime;
    I->s.stopTime = stopTimeDefined ? stopTime : 0.0; /* no stray value (NaN) in a saved state */
    I->s.stopDefined = stopTimeDefined ? 1 : 0;
    I->s.tc = startTime;
    I->s.dirty = 1;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    Instance *I = (Instance *)c;
    CHECK(I, PHASE_INSTANTIATED, "fmi2EnterInitializationMode");
    I->s.dirty = 1;
    if (ensure_initialized(I) != fmi2OK) return fmi2Error;
    I->s.phase = PHASE_INITIALIZATION;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    Instance *I = (Instance *)c;
    CHECK(I, PHASE_INITIALIZATION, "fmi2ExitInitializationMode");
    if (ensure_initialized(I) != fmi2OK) return fmi2Error;
    I->s.phase = PHASE_STEP_COMPLETE;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c) {
    Instance *I = (Instance *)c;
    CHECK(I, PHASE_STEP_COMPLETE | PHASE_ERROR, "fmi2Terminate");
    if (I->s.phase == PHASE_STEP_COMPLETE) { /* events the outputs counted that no later step will log */
        Logger log = {solver_log, I, I->loggingOn && I->logEvents};
        solver_log_pending(&I->s.model, I->s.tc, &log);
    }
    I->s.phase = PHASE_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c) {
    Instance *I = (Instance *)c;
    CHECK(I, ANY_PHASE, "fmi2Reset");
    reset_instance(I);
    return fmi2OK;
}

/* -------------------------------------------------------- variable access */

static fmi2Status check_array(Instance *I, const void *vr, size_t nvr, const void *value,
                              const char *fn) {
    if (nvr > 0 && (!vr || !value)) {
        LOG_ERROR(I, "%s: NULL array with nvr = %zu", fn, nvr);
        return fmi2Error;
    }
    return fmi2OK;
}

#define SET_PHASES (PHASE_INSTANTIATED | PHASE_INITIALIZATION | PHASE_STEP_COMPLETE)

/* ---------------------------------------------------- the variable table */

typedef enum { TYPE_REAL, TYPE_INTEGER, TYPE_BOOLEAN, TYPE_STRING } VarType;
#define TYPE_OF_REAL TYPE_REAL
#define TYPE_OF_INTEGER TYPE_INTEGER
#define TYPE_OF_BOOLEAN TYPE_BOOLEAN
#define TYPE_OF_STRING TYPE_STRING
typedef enum { CAUSALITY_parameter, CAUSALITY_input, CAUSALITY_output } Causality;

typedef struct {
    VarType type;
    Causality causality;
    const char *name;
} VarInfo;

/* Address and description of the variable with value reference vr in M, or
 * NULL for an unknown reference. Generated from variables.def. */
static void *var_address(Model *M, fmi2ValueReference vr, VarInfo *info) {
    switch (vr) {
#define VAR(T, ref, field, name_, caus, var, start, unit, desc) \
    case ref:                                                   \
        info->type = TYPE_OF_##T;                               \
        info->causality = CAUSALITY_##caus;                     \
        info->name = name_;                                     \
        return &M->v.field;
#include "variables.def"
#undef VAR
    default:
        return NULL;
    }
}

/* May the variable be set now? */
static fmi2Status settable(Instance *I, const VarInfo *info, const char *fn) {
    if (info->causality == CAUSALITY_output) {
        LOG_ERROR(I, "%s: '%s' is an output and cannot be set", fn, info->name);
        return fmi2Error;
    }
    if (I->s.phase == PHASE_STEP_COMPLETE && info->causality != CAUSALITY_input) {
        LOG_ERROR(I, "%s: '%s' cannot be set after initialization", fn, info->name);
        return fmi2Error;
    }
    return fmi2OK;
}

static const char *const TYPE_NAMES[] = {"Real", "Integer", "Boolean", "String"};

/* Common checks of the getters and setters; returns the variable's address
 * or NULL after logging an error. A parameter about to be set marks the
 * instance for validation and re-initialisation. */
static void *lookup(Instance *I, fmi2ValueReference vr, VarType want, int set, const char *fn,
                    const char **nameOut) {
    VarInfo info = {TYPE_REAL, CAUSALITY_output, ""};
    void *p = var_address(&I->s.model, vr, &info);
    if (nameOut) *nameOut = info.name;
    if (!p || info.type != want) {
        LOG_ERROR(I, "%s: unknown %s value reference %u", fn, TYPE_NAMES[want], vr);
        return NULL;
    }
    if (set) {
        if (settable(I, &info, fn)) return NULL;
        if (info.causality == CAUSALITY_parameter) I->s.dirty = 1;
    }
    return p;
}

static fmi2Status begin_access(Instance *I, int set, const void *vr, size_t nvr, const void *value,
                               const char *fn) {
    if (bad_call(I, set ? SET_PHASES : GET_PHASES, fn)) return fmi2Error;
    if (check_array(I, vr, nvr, value, fn)) return fmi2Error;
    return set ? fmi2OK : ensure_initialized(I);
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[]) {
    Instance *I = (Instance *)c;
    if (begin_access(I, 1, vr, nvr, value, "fmi2SetReal")) return fmi2Error;
    for (size_t i = 0; i < nvr; i++) {
        const char *name;
        double *p = (double *)lookup(I, vr[i], TYPE_REAL, 1, "fmi2SetReal", &name);
        if (!p) return fmi2Error;
        if (!isfinite(value[i])) {
            LOG_ERROR(I, "fmi2SetReal: '%s' = %g is not a finite number", name, value[i]);
            return fmi2Error;
        }
        /* a changed input restarts the integrator at the communication point */
        if (I->s.phase == PHASE_STEP_COMPLETE && *p != value[i]) solver_rollback(&I->s.model, I->s.tc);
        *p = value[i];
    }
    return fmi2OK;
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Integer value[]) {
    Instance *I = (Instance *)c;
    if (begin_access(I, 1, vr, nvr, value, "fmi2SetInteger")) return fmi2Error;
    for (size_t i = 0; i < nvr; i++) {
        int *p = (int *)lookup(I, vr[i], TYPE_INTEGER, 1, "fmi2SetInteger", NULL);
        if (!p) return fmi2Error;
        *p = value[i];
    }
    return fmi2OK;
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Boolean value[]) {
    Instance *I = (Instance *)c;
    if (begin_access(I, 1, vr, nvr, value, "fmi2SetBoolean")) return fmi2Error;
    for (size_t i = 0; i < nvr; i++) {
        int *p = (int *)lookup(I, vr[i], TYPE_BOOLEAN, 1, "fmi2SetBoolean", NULL);
        if (!p) return fmi2Error;
        *p = value[i] ? 1 : 0;
    }
    return fmi2OK;
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         const fmi2String value[]) {
    Instance *I = (Instance *)c;
    if (begin_access(I, 1, vr, nvr, value, "fmi2SetString")) return fmi2Error;
    for (size_t i = 0; i < nvr; i++) {
        const char *name;
        char *p = (char *)lookup(I, vr[i], TYPE_STRING, 1, "fmi2SetString", &name);
        if (!p) return fmi2Error;
        if (!value[i]) {
            LOG_ERROR(I, "fmi2SetString: '%s' = NULL (give an empty string instead)", name);
            return fmi2Error;
        }
        size_t len = strlen(value[i]);
        if (len >= STRING_CAPACITY) {
            LOG_ERROR(I, "fmi2SetString: '%s' is %zu bytes long, at most %d are allowed", name, len,
                      STRING_CAPACITY - 1);
            return fmi2Error;
        }
        memcpy(p, value[i], len + 1);
    }
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[]) {
    Instance *I = (Instance *)c;
    if (begin_access(I, 0, vr, nvr, value, "fmi2GetReal")) return fmi2Error;
    for (size_t i = 0; i < nvr; i++) {
        const double *p = (const double *)lookup(I, vr[i], TYPE_REAL, 0, "fmi2GetReal", NULL);
        if (!p) return fmi2Error;
        value[i] = *p;
    }
    return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Integer value[]) {
    Instance *I = (Instance *)c;
    if (begin_access(I, 0, vr, nvr, value, "fmi2GetInteger")) return fmi2Error;
    for (size_t i = 0; i < nvr; i++) {
        const int *p = (const int *)lookup(I, vr[i], TYPE_INTEGER, 0, "fmi2GetInteger", NULL);
        if (!p) return fmi2Error;
        value[i] = *p;
    }
    return fmi2OK;
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Boolean value[]) {
    Instance *I = (Instance *)c;
    if (begin_access(I, 0, vr, nvr, value, "fmi2GetBoolean")) return fmi2Error;
    for (size_t i = 0; i < nvr; i++) {
        const int *p = (const int *)lookup(I, vr[i], TYPE_BOOLEAN, 0, "fmi2GetBoolean", NULL);
        if (!p) return fmi2Error;
        value[i] = *p ? fmi2True : fmi2False;
    }
    return fmi2OK;
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         fmi2String value[]) {
    Instance *I = (Instance *)c;
    if (begin_access(I, 0, vr, nvr, value, "fmi2GetString")) return fmi2Error;
    for (size_t i = 0; i < nvr; i++) {
        const char *p = (const char *)lookup(I, vr[i], TYPE_STRING, 0, "fmi2GetString", NULL);
        if (!p) return fmi2Error;
        value[i] = p; /* valid until the variable is set again or the instance is freed */
    }
    return fmi2OK;
}

/* -------------------------------------------------------------- FMU state */

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *state) {
    Instance *I = (Instance *)c;
    CHECK(I, GET_PHASES | PHASE_INSTANTIATED, "fmi2GetFMUstate");
    if (!state) {
        LOG_ERROR(I, "fmi2GetFMUstate: state pointer is NULL");
        return fmi2Error;
    }
    Snapshot *snap = (Snapshot *)*state;
    if (!snap) {
        snap = (Snapshot *)I->cb.allocateMemory(1, sizeof(Snapshot));
        if (!snap) {
            LOG_ERROR(I, "fmi2GetFMUstate: out of memory");
            return fmi2Error;
        }
    } else if (snap->magic != SNAPSHOT_MAGIC) {
        LOG_ERROR(I, "fmi2GetFMUstate: the state to overwrite was not made by this FMU");
        return fmi2Error;
    }
    *snap = I->s;
    snap->model.rec = NULL; /* the instance's, re-attached by fmi2SetFMUstate; no address in saved bytes */
    *state = snap;
    return fmi2OK;
}

/* The FMI part of a state to restore: phase, flags and times. */
static int snapshot_check(const Snapshot *snap, char *msg, size_t n) {
    int phase = (int)snap->phase;
    if (!(phase == PHASE_INSTANTIATED || phase == PHASE_INITIALIZATION || phase == PHASE_STEP_COMPLETE ||
          phase == PHASE_TERMINATED || phase == PHASE_ERROR)) {
        snprintf(msg, n, "unknown phase %d", phase);
        return 1;
    }
    /* parameters set since the last initialisation are checked, and the state rebuilt, before
     * they are used: possible until fmi2ExitInitializationMode, and always so before it */
    if (!(snap->dirty == 0 || snap->dirty == 1) || (snap->dirty && phase > PHASE_INITIALIZATION) ||
        (!snap->dirty && phase == PHASE_INSTANTIATED)) {
        snprintf(msg, n, "the flag of changed parameters (%d) does not fit phase %d", snap->dirty, phase);
        return 1;
    }
    if (!isfinite(snap->startTime) || !(snap->stopDefined == 0 || snap->stopDefined == 1) ||
        !isfinite(snap->stopTime) || (snap->stopDefined && !(snap->stopTime >= snap->startTime))) {
        snprintf(msg, n, "start time %g, stop time %g (defined: %d) are not an experiment's", snap->startTime,
                 snap->stopTime, snap->stopDefined);
        return 1;
    }
    /* fmi2DoStep accepts a communication point within 1e-9 (relative) of the FMU's time */
    if (!(isfinite(snap->tc) && snap->tc >= snap->startTime - 1e-9 * fmax(1.0, fabs(snap->startTime))) ||
        (phase <= PHASE_INITIALIZATION && snap->tc != snap->startTime)) {
        snprintf(msg, n, "time %.17g is not a time after the start %.17g (the start itself before stepping)", snap->tc,
                 snap->startTime);
        return 1;
    }
    if (snap->model.rec) {
        snprintf(msg, n, "a record address where a saved state has none");
        return 1;
    }
    return 0;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state) {
    Instance *I = (Instance *)c;
    CHECK(I, GET_PHASES | PHASE_INSTANTIATED, "fmi2SetFMUstate");
    const Snapshot *snap = (const Snapshot *)state;
    if (!snap || snap->magic != SNAPSHOT_MAGIC || snap->size != sizeof(Snapshot)) {
        LOG_ERROR(I, "fmi2SetFMUstate: not a state of this FMU");
        return fmi2Error;
    }
    char msg[MSG_LEN];
    if (snapshot_check(snap, msg, sizeof(msg))) {
        LOG_ERROR(I, "fmi2SetFMUstate: invalid state (corrupted?): %s", msg);
        return fmi2Error;
    }
    const Model *sm = &snap->model;
    StagedRecord staged = {0};
    if (!snap->dirty) {
        /* the state's parameters must be valid, its derived values exactly those they give
         * (with its record, which must have the same samples), and its integrator and
         * discrete state one a run of these parameters leaves. Until every check passed,
         * nothing of the instance changes (its record neither). */
        if (model_validate(&sm->v, msg, sizeof(msg))) {
            LOG_ERROR(I, "fmi2SetFMUstate: the state's parameters are invalid: %s", msg);
            return fmi2Error;
        }
        if (sm->v.kind == KIND_RECORD && stage_record(I, sm->v.file, &sm->d, &staged, msg, sizeof(msg))) {
            LOG_ERROR(I, "fmi2SetFMUstate: excitation.file: %s", msg);
            return fmi2Error;
        }
        Model check = *sm;
        check.rec = sm->v.kind == KIND_RECORD ? staged_record(I, &staged) : NULL;
        model_derive(&check);
        if (memcmp(&check.d, &sm->d, sizeof(Derived)) != 0) {
            drop_record(I, &staged);
            LOG_ERROR(I, "fmi2SetFMUstate: the state does not match its own parameters (a corrupted state?)");
            return fmi2Error;
        }
        StateUse use = snap->phase == PHASE_INITIALIZATION  ? STATE_INITIAL
                       : snap->phase == PHASE_STEP_COMPLETE ? STATE_RUNNING
                                                            : STATE_INERT;
        if (state_validate(&check, snap->startTime, snap->tc, use, msg, sizeof(msg))) {
            drop_record(I, &staged);
            LOG_ERROR(I, "fmi2SetFMUstate: invalid state (corrupted?): %s", msg);
            return fmi2Error;
        }
        adopt_record(I, &staged);
    }
    I->s = *snap;
    I->s.model.rec = (!snap->dirty && sm->v.kind == KIND_RECORD) ? &I->rec : NULL;
    return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *state) {
    Instance *I = (Instance *)c;
    CHECK(I, ANY_PHASE, "fmi2FreeFMUstate");
    if (!state || !*state) return fmi2OK;
    I->cb.freeMemory(*state);
    *state = NULL;
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate state, size_t *size) {
    Instance *I = (Instance *)c;
    CHECK(I, ANY_PHASE, "fmi2SerializedFMUstateSize");
    (void)state;
    if (!size) {
        LOG_ERROR(I, "fmi2SerializedFMUstateSize: size pointer is NULL");
        return fmi2Error;
    }
    *size = sizeof(Snapshot);
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate state, fmi2Byte bytes[],
                                 size_t size) {
    Instance *I = (Instance *)c;
    CHECK(I, ANY_PHASE, "fmi2SerializeFMUstate");
    const Snapshot *snap = (const Snapshot *)state;
    if (!snap || snap->magic != SNAPSHOT_MAGIC || !bytes || size < sizeof(Snapshot)) {
        LOG_ERROR(I, "fmi2SerializeFMUstate: invalid state or buffer of %zu bytes (need %zu)",
                  size, sizeof(Snapshot));
        return fmi2Error;
    }
    memcpy(bytes, snap, sizeof(Snapshot));
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[], size_t size,
                                   fmi2FMUstate *state) {
    Instance *I = (Instance *)c;
    CHECK(I, ANY_PHASE, "fmi2DeSerializeFMUstate");
    Snapshot tmp;
    if (!bytes || !state || size != sizeof(Snapshot)) {
        LOG_ERROR(I, "fmi2DeSerializeFMUstate: expected %zu bytes, got %zu", sizeof(Snapshot), size);
        return fmi2Error;
    }
    memcpy(&tmp, bytes, sizeof(Snapshot));
    if (tmp.magic != SNAPSHOT_MAGIC || tmp.size != sizeof(Snapshot)) {
        LOG_ERROR(I, "fmi2DeSerializeFMUstate: bytes are not a state of this FMU");
        return fmi2Error;
    }
    Snapshot *snap = (Snapshot *)*state;
    if (!snap) {
        snap = (Snapshot *)I->cb.allocateMemory(1, sizeof(Snapshot));
        if (!snap) {
            LOG_ERROR(I, "fmi2DeSerializeFMUstate: out of memory");
            return fmi2Error;
        }
    }
    *snap = tmp;
    *state = snap;
    return fmi2OK;
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[],
                                        size_t nUnknown, const fmi2ValueReference vKnown_ref[],
                                        size_t nKnown, const fmi2Real dvKnown[],
                                        fmi2Real dvUnknown[]) {
    Instance *I = (Instance *)c;
    (void)vUnknown_ref, (void)nUnknown, (void)vKnown_ref, (void)nKnown, (void)dvKnown, (void)dvUnknown;
    CHECK(I, ANY_PHASE, "fmi2GetDirectionalDerivative");
    LOG_ERROR(I, "fmi2GetDirectionalDerivative is not supported");
    return fmi2Error;
}

/* -------------------------------------------------------- co-simulation */

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    Instance *I = (Instance *)c;
    (void)vr, (void)nvr, (void)order, (void)value;
    CHECK(I, ANY_PHASE, "fmi2SetRealInputDerivatives");
    LOG_ERROR(I, "fmi2SetRealInputDerivatives is not supported (inputs are held constant over a step)");
    return fmi2Error;
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
    Instance *I = (Instance *)c;
    (void)vr, (void)nvr, (void)order, (void)value;
    CHECK(I, ANY_PHASE, "fmi2GetRealOutputDerivatives");
    LOG_ERROR(I, "fmi2GetRealOutputDerivatives is not supported");
    return fmi2Error;
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint,
                      fmi2Real communicationStepSize, fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    Instance *I = (Instance *)c;
    (void)noSetFMUStatePriorToCurrentPoint;
    CHECK(I, PHASE_STEP_COMPLETE, "fmi2DoStep");
    if (ensure_initialized(I) != fmi2OK) return fmi2Error;
    double tc = I->s.tc;
    if (!isfinite(currentCommunicationPoint) || !isfinite(communicationStepSize) ||
        communicationStepSize < 0) {
        LOG_ERROR(I, "fmi2DoStep: invalid communication point %g or step size %g",
                  currentCommunicationPoint, communicationStepSize);
        return fmi2Error;
    }
    if (fabs(currentCommunicationPoint - tc) > 1e-9 * fmax(1.0, fabs(tc))) {
        LOG_ERROR(I, "fmi2DoStep: communication point %.17g does not match the FMU time %.17g",
                  currentCommunicationPoint, tc);
        return fmi2Error;
    }
    double target = currentCommunicationPoint + communicationStepSize;
    /* FMI 2.0 (fmi2SetupExperiment): with a stop time defined, no step may end after it
     * (within the 1e-9 relative slack the communication point has) */
    if (I->s.stopDefined && target > I->s.stopTime + 1e-9 * fmax(1.0, fabs(I->s.stopTime))) {
        LOG_ERROR(I, "fmi2DoStep: the step to %.17g ends after the stop time %.17g set by fmi2SetupExperiment",
                  target, I->s.stopTime);
        return fmi2Error;
    }
    Logger log = {solver_log, I, I->loggingOn && I->logEvents};
    if (solver_advance(&I->s.model, target, &log)) {
        I->s.phase = PHASE_ERROR;
        return fmi2Error;
    }
    I->s.tc = target;
    solver_outputs(&I->s.model, target);
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
    LOG_ERROR(I, "fmi2GetStatus: no asynchronous status available");
    return fmi2Discard;
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    Instance *I = (Instance *)c;
    CHECK(I, ANY_PHASE, "fmi2GetRealStatus");
    if (s == fmi2LastSuccessfulTime && value) {
        *value = I->s.tc;
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
        *value = fmi2False;
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
