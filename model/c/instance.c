/* An instance of RockingBlock whatever FMI version uses it (instance.h):
 * life cycle, records, variable access, FMU states and the communication
 * step. No global state. */
#if defined(__linux__) && !defined(_POSIX_C_SOURCE)
#define _POSIX_C_SOURCE 200809L /* struct stat's st_mtim */
#endif
#include "instance.h"

#include "coupling.h"
#include "support.h"

#include <ctype.h>
#include <locale.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

#include "ground.h"
#include "solver.h"

/* ---------------------------------------------------------------- logging */

void instance_log(const Instance *I, int status, const char *category, const char *fmt, ...) {
    char buf[MSG_LEN];
    va_list ap;
    if (!I || !I->emit) return;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof(buf), fmt, ap);
    va_end(ap);
    /* One line, whatever the message quotes (a path with a newline, escape codes);
     * numbers written with '.' whatever the importer's locale (event lines are read
     * by programs, and printf follows LC_NUMERIC: ',' in German). */
    const struct lconv *lc = localeconv();
    char point = (lc && lc->decimal_point && lc->decimal_point[0]) ? lc->decimal_point[0] : '.';
    for (char *p = buf; *p; p++) {
        if ((unsigned char)*p < 0x20 || *p == 0x7f) *p = '?';
        if (point != '.' && *p == point && p > buf && isdigit((unsigned char)p[-1]) && isdigit((unsigned char)p[1]))
            *p = '.';
    }
    I->emit(I, status, category, buf);
}

static void solver_log(void *ctx, int category, const char *message) {
    Instance *I = (Instance *)ctx;
    if (category == 1) INSTANCE_ERROR(I, "%s", message);
    else if (I->loggingOn && I->logEvents) instance_log(I, STATUS_OK, "logEvents", "%s", message);
}

Logger instance_solver_logger(Instance *I) {
    Logger log = {solver_log, I, I->loggingOn && I->logEvents};
    return log;
}

int instance_bad_call(Instance *I, int allowed, const char *fn) {
    if (!I) return 1;
    if (!(I->s.phase & allowed)) {
        INSTANCE_ERROR(I, "%s must not be called in the current state (%d)", fn, (int)I->s.phase);
        return 1;
    }
    return 0;
}

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
    if (!cached && record_read(path, &staged->rec, I->alloc, I->release, msg, n)) return 1;
    staged->fresh = !cached;
    const Record *r = cached ? &I->rec : &staged->rec;
    if (want && (r->n != want->recN || r->hash != want->recHash)) {
        snprintf(msg, n, "the record file '%s' changed since the state was saved (%d samples then, %d now)",
                 path, want->recN, r->n);
        if (staged->fresh) record_free(&staged->rec, I->release);
        staged->fresh = 0;
        return 1;
    }
    return 0;
}

static const Record *staged_record(const Instance *I, const StagedRecord *staged) {
    return staged->fresh ? &staged->rec : &I->rec;
}

static void drop_record(Instance *I, StagedRecord *staged) {
    if (staged->fresh) record_free(&staged->rec, I->release);
    staged->fresh = 0;
}

/* The instance holds the staged record from now on (its previous one is freed). */
static void adopt_record(Instance *I, StagedRecord *staged) {
    if (!staged->fresh) return;
    record_free(&I->rec, I->release);
    I->rec = staged->rec;
    I->recFile = staged->stamp;
    staged->fresh = 0;
}


/* Validate, derive and initialise if parameters changed; write outputs. */
Status instance_initialize(Instance *I) {
    Model *M = &I->s.model;
    if (!I->s.dirty) return STATUS_OK;
    char msg[MSG_LEN];
    /* the tighter of solver.relTol and the importer's tolerance governs (docs/model.md, FMI
     * behaviour): an importer's default (OMSimulator's 1e-4) never loosens the model's own */
    if (I->s.toleranceDefined && I->s.tolerance < M->v.relTol) M->v.relTol = I->s.tolerance;
    if (model_validate(&M->v, msg, sizeof(msg))) {
        INSTANCE_ERROR(I, "invalid parameter: %s", msg);
        return STATUS_ERROR;
    }
    M->rec = NULL;
    if (M->v.kind == KIND_RECORD) {
        StagedRecord staged;
        if (stage_record(I, M->v.file, NULL, &staged, msg, sizeof(msg))) {
            INSTANCE_ERROR(I, "excitation.file: %s", msg);
            return STATUS_ERROR;
        }
        adopt_record(I, &staged);
        M->rec = &I->rec;
        if (ground_validate_record(M, msg, sizeof(msg))) {
            INSTANCE_ERROR(I, "invalid parameter: %s", msg);
            return STATUS_ERROR;
        }
    }
    model_derive(M);
    M->sup = NULL;
    if (M->d.sup.twoWay) { /* integrated with the blocks: its table only gives the peak floor acceleration, built
                            * when that is first read (instance_get_real) */
        support_free(&I->sup, I->release);
    } else if (support_attach(M, &I->sup, I->alloc, I->release, msg, sizeof(msg))) {
        INSTANCE_ERROR(I, "support: %s", msg);
        return STATUS_ERROR;
    }
    if (I->sup.data) M->sup = &I->sup;
    if (support_rest_attach(M, &I->supRest, I->alloc, I->release, msg, sizeof(msg))) {
        INSTANCE_ERROR(I, "support: %s", msg);
        return STATUS_ERROR;
    }
    M->restTable = I->supRest.data ? &I->supRest : NULL;
    solver_initialize(M, I->s.startTime);
    I->s.tc = I->s.startTime;
    solver_outputs(M, I->s.tc);
    I->s.dirty = 0;
    return STATUS_OK;
}


/* ------------------------------------------------------------- life cycle */

/* The snapshot's defaults, on a zeroed snapshot. */
static void snapshot_defaults(Instance *I) {
    I->s.magic = SNAPSHOT_MAGIC;
    I->s.size = (unsigned)sizeof(Snapshot);
    model_set_defaults(&I->s.model);
    I->s.phase = PHASE_INSTANTIATED;
    I->s.dirty = 1;
}

void instance_reset(Instance *I) {
    memset(&I->s, 0, sizeof(I->s));
    snapshot_defaults(I);
}

static char *copy_string(const char *s, RecordAlloc alloc) {
    size_t len = strlen(s) + 1;
    char *p = (char *)alloc(len, 1);
    if (p) memcpy(p, s, len);
    return p;
}

Instance *instance_new(const char *name, InterfaceType type, const char *resourceLocation, EmitFn emit, void *env,
                       void (*logger)(void), RecordAlloc alloc, RecordFree release, int loggingOn) {
    Instance *I = (Instance *)alloc(1, sizeof(Instance));
    if (!I) return NULL;
    memset(I, 0, sizeof(*I));
    I->emit = emit;
    I->env = env;
    I->logger = logger;
    I->alloc = alloc;
    I->release = release;
    I->name = copy_string(name, alloc);
    if (!I->name) {
        release(I);
        return NULL;
    }
    /* record files named by a relative excitation.file live in resources/ */
    char dir[STRING_CAPACITY];
    if (resourceLocation && resourceLocation[0]) {
        if (record_uri_to_path(resourceLocation, dir, sizeof(dir)) == 0) I->resourceDir = copy_string(dir, alloc);
        if (!I->resourceDir)
            snprintf(I->resourceNote, sizeof(I->resourceNote), "'%.200s%s' is not a local folder this FMU can read",
                     resourceLocation, strlen(resourceLocation) > 200 ? "..." : "");
    }
    I->loggingOn = loggingOn;
    I->logEvents = 1;
    snapshot_defaults(I); /* (zeroed with the instance above) */
    I->s.type = type;
    return I;
}

void instance_free(Instance *I) {
    if (!I) return;
    RecordFree release = I->release;
    record_free(&I->rec, release);
    support_free(&I->sup, release);
    support_free(&I->supRest, release);
    if (I->resourceDir) release(I->resourceDir);
    release(I->name);
    release(I);
}

Status instance_set_logging(Instance *I, int loggingOn, size_t n, const char *const categories[], const char *fn) {
    if (instance_bad_call(I, ANY_PHASE, fn)) return STATUS_ERROR;
    I->loggingOn = loggingOn;
    if (n == 0) {
        I->logEvents = 1;
        return STATUS_OK;
    }
    if (!categories) {
        INSTANCE_ERROR(I, "%s: categories is NULL", fn);
        return STATUS_ERROR;
    }
    I->logEvents = 0;
    for (size_t i = 0; i < n; i++) {
        if (!categories[i]) continue;
        if (strcmp(categories[i], "logEvents") == 0) I->logEvents = 1;
        else if (strcmp(categories[i], "logStatusError") != 0) {
            INSTANCE_ERROR(I, "%s: unknown log category '%s'", fn, categories[i]);
            return STATUS_ERROR;
        }
    }
    return STATUS_OK;
}

Status instance_setup_experiment(Instance *I, int toleranceDefined, double tolerance, double startTime,
                                 int stopTimeDefined, double stopTime, const char *fn) {
    if (!isfinite(startTime) || (stopTimeDefined && !(isfinite(stopTime) && stopTime >= startTime))) {
        INSTANCE_ERROR(I, "%s: invalid start time %g or stop time %g", fn, startTime, stopTime);
        return STATUS_ERROR;
    }
    if (toleranceDefined && !(tolerance >= REL_TOL_MIN && tolerance <= 0.1)) {
        INSTANCE_ERROR(I, "%s: tolerance %g must be in [1e-14, 0.1] (the integrator uses the tighter of it and solver.relTol)",
                       fn, tolerance);
        return STATUS_ERROR;
    }
    I->s.startTime = startTime;
    I->s.stopTime = stopTimeDefined ? stopTime : 0.0; /* no stray value (NaN) in a saved state */
    I->s.stopDefined = stopTimeDefined ? 1 : 0;
    I->s.toleranceDefined = toleranceDefined ? 1 : 0;
    I->s.tolerance = toleranceDefined ? tolerance : 0.0;
    I->s.tc = startTime;
    I->s.dirty = 1;
    return STATUS_OK;
}

/* ---------------------------------------------------- the variable table */

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
static void *var_address(Model *M, unsigned vr, VarInfo *info) {
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
static Status settable(Instance *I, const VarInfo *info, const char *fn) {
    if (info->causality == CAUSALITY_output) {
        INSTANCE_ERROR(I, "%s: '%s' is an output and cannot be set", fn, info->name);
        return STATUS_ERROR;
    }
    if ((I->s.phase & RUNNING_PHASES) && info->causality != CAUSALITY_input) {
        INSTANCE_ERROR(I, "%s: '%s' cannot be set after initialization", fn, info->name);
        return STATUS_ERROR;
    }
    return STATUS_OK;
}

static const char *const TYPE_NAMES[] = {"Real", "Integer", "Boolean", "String"};

/* Which continuous input p is (0 ground.ah, 1 ground.av, 2 support.force), -1 if none. */
static int input_index(const Model *M, const double *p) {
    return p == &M->v.ahIn ? 0 : p == &M->v.avIn ? 1 : p == &M->v.supportForce ? 2 : -1;
}

/* support.force acts on a two-way support alone (its floor is in the state; coupling_on, as the restored state's
 * check): 1 after logging an error elsewhere. Running phases only, where the derived support is set. */
static int force_refused(Instance *I, const char *fn) {
    const Variables *v = &I->s.model.v;
    if (coupling_on(&I->s.model)) return 0;
    INSTANCE_ERROR(I, "%s: 'support.force' acts on a two-way support (support.kind 1 or 2 with support.coupling = 1), "
                      "not with support.kind = %d, support.coupling = %d", fn, v->supportKind, v->supportCoupling);
    return 1;
}

/* Common checks of the getters and setters; returns the variable's address
 * or NULL after logging an error. A parameter about to be set marks the
 * instance for validation and re-initialisation. */
static void *lookup(Instance *I, unsigned vr, VarType want, int set, const char *fn,
                    const char **nameOut) {
    VarInfo info = {TYPE_REAL, CAUSALITY_output, ""};
    void *p = var_address(&I->s.model, vr, &info);
    if (nameOut) *nameOut = info.name;
    if (!p || info.type != want) {
        INSTANCE_ERROR(I, "%s: unknown %s value reference %u", fn, TYPE_NAMES[want], vr);
        return NULL;
    }
    if (set) {
        if (settable(I, &info, fn)) return NULL;
        if (info.causality == CAUSALITY_parameter) I->s.dirty = 1;
    }
    return p;
}

Status instance_begin_access(Instance *I, int set, const void *vr, size_t nvr, const void *value, const char *fn) {
    if (instance_bad_call(I, set ? SET_PHASES : GET_PHASES, fn)) return STATUS_ERROR;
    if (nvr > 0 && (!vr || !value)) {
        INSTANCE_ERROR(I, "%s: NULL array with nvr = %zu", fn, nvr);
        return STATUS_ERROR;
    }
    return set ? STATUS_OK : instance_initialize(I);
}

void instance_update_outputs(Instance *I) {
    if (I->s.dirty || !(I->s.phase & (PHASE_INITIALIZATION | RUNNING_PHASES))) return;
    solver_outputs(&I->s.model, I->s.tc);
}

Status instance_set_real(Instance *I, unsigned vr, double value, const char *fn) {
    const char *name;
    double *p = (double *)lookup(I, vr, TYPE_REAL, 1, fn, &name);
    if (!p) return STATUS_ERROR;
    if (!isfinite(value)) {
        INSTANCE_ERROR(I, "%s: '%s' = %g is not a finite number", fn, name, value);
        return STATUS_ERROR;
    }
    /* a changed input restarts the integrator at the communication point; a value set at a later communication point
     * than the input's derivatives ends their polynomial (instance_set_real_derivative) */
    State *S = &I->s.model.s;
    int which = input_index(&I->s.model, p);
    if (which == 2 && value != 0.0 && (I->s.phase & RUNNING_PHASES) && force_refused(I, fn)) return STATUS_ERROR;
    int dropped = which >= 0 && S->inT0[which] != I->s.tc && (S->inD[which][0] != 0.0 || S->inD[which][1] != 0.0);
    if ((I->s.phase & RUNNING_PHASES) && (*p != value || dropped)) solver_rollback(&I->s.model, I->s.tc);
    *p = value;
    if (dropped) S->inD[which][0] = S->inD[which][1] = 0.0;
    return STATUS_OK;
}

Status instance_set_real_derivative(Instance *I, unsigned vr, int order, double value, const char *fn) {
    const char *name;
    double *p = (double *)lookup(I, vr, TYPE_REAL, 0, fn, &name);
    if (!p) return STATUS_ERROR;
    Model *M = &I->s.model;
    State *S = &M->s;
    int which = input_index(M, p);
    if (which < 0) {
        INSTANCE_ERROR(I, "%s: '%s' takes no derivatives (the continuous inputs ground.ah, ground.av and support.force do)",
                       fn, name);
        return STATUS_ERROR;
    }
    if (!lookup(I, vr, TYPE_REAL, 1, fn, NULL)) return STATUS_ERROR; /* (settable now, as by fmi2SetReal) */
    if (order != 1 && order != 2) {
        INSTANCE_ERROR(I, "%s: '%s': derivative of order %d (the FMU takes the first and second derivatives)", fn, name,
                       order);
        return STATUS_ERROR;
    }
    if (which == 2 && (I->s.phase & RUNNING_PHASES) && force_refused(I, fn)) return STATUS_ERROR;
    /* (a second derivative bends the input: the cells on which the ground's acceleration is monotone are then cut at
     * the total's vertex, ground.c, which holds for the horizontal input on the ground; support.force only enters the
     * support's equations of motion: both orders) */
    if (order == 2 && which != 2 && (which != 0 || M->v.supportKind != 0)) {
        INSTANCE_ERROR(I, "%s: '%s': a second derivative is taken for ground.ah of blocks on the ground (support.kind "
                       "= 0) and for support.force: give the first derivative alone", fn, name);
        return STATUS_ERROR;
    }
    if (M->v.kind != KIND_NONE && M->v.kind != KIND_RECORD) {
        INSTANCE_ERROR(I, "%s: '%s': input derivatives drive the blocks with excitation.kind none or record (a built-in "
                       "waveform's cells would not stay monotone with a sloped input)", fn, name);
        return STATUS_ERROR;
    }
    if (!isfinite(value)) {
        INSTANCE_ERROR(I, "%s: derivative %d of '%s' = %g is not a finite number", fn, order, name, value);
        return STATUS_ERROR;
    }
    /* at a new communication point a new polynomial: the other order's derivative from before is dropped */
    double d[2] = {S->inD[which][0], S->inD[which][1]};
    int moved = S->inT0[which] != I->s.tc;
    if (moved) d[0] = d[1] = 0.0;
    d[order - 1] = value;
    int changed = d[0] != S->inD[which][0] || d[1] != S->inD[which][1] || (moved && (d[0] != 0.0 || d[1] != 0.0));
    if ((I->s.phase & RUNNING_PHASES) && changed) solver_rollback(M, I->s.tc);
    S->inD[which][0] = d[0];
    S->inD[which][1] = d[1];
    S->inT0[which] = I->s.tc;
    return STATUS_OK;
}

Status instance_set_integer(Instance *I, unsigned vr, int value, const char *fn) {
    int *p = (int *)lookup(I, vr, TYPE_INTEGER, 1, fn, NULL);
    if (!p) return STATUS_ERROR;
    *p = value;
    return STATUS_OK;
}

Status instance_set_boolean(Instance *I, unsigned vr, int value, const char *fn) {
    int *p = (int *)lookup(I, vr, TYPE_BOOLEAN, 1, fn, NULL);
    if (!p) return STATUS_ERROR;
    *p = value ? 1 : 0;
    return STATUS_OK;
}

Status instance_set_string(Instance *I, unsigned vr, const char *value, const char *fn) {
    const char *name;
    char *p = (char *)lookup(I, vr, TYPE_STRING, 1, fn, &name);
    if (!p) return STATUS_ERROR;
    if (!value) {
        INSTANCE_ERROR(I, "%s: '%s' = NULL (give an empty string instead)", fn, name);
        return STATUS_ERROR;
    }
    size_t len = strlen(value);
    if (len >= STRING_CAPACITY) {
        INSTANCE_ERROR(I, "%s: '%s' is %zu bytes long, at most %d are allowed", fn, name, len, STRING_CAPACITY - 1);
        return STATUS_ERROR;
    }
    memcpy(p, value, len + 1);
    return STATUS_OK;
}

Status instance_get_real(Instance *I, unsigned vr, double *value, const char *fn) {
    const double *p = (const double *)lookup(I, vr, TYPE_REAL, 0, fn, NULL);
    if (!p) return STATUS_ERROR;
    *value = *p;
    if (p == &I->s.model.v.supportPfa) { /* (computed when first read: support_peak; two-way, its table too) */
        const Model *M = &I->s.model;
        char msg[256];
        if (!I->sup.data && M->rec && support_needed(M) &&
            support_attach(M, &I->sup, I->alloc, I->release, msg, sizeof(msg))) {
            INSTANCE_ERROR(I, "%s: support.peakFloorAcceleration: %s", fn, msg);
            return STATUS_ERROR;
        }
        *value = I->sup.data ? fabs(M->d.accAmp) * support_peak(M, &I->sup) : 0.0;
    }
    return STATUS_OK;
}

Status instance_get_integer(Instance *I, unsigned vr, int *value, const char *fn) {
    const int *p = (const int *)lookup(I, vr, TYPE_INTEGER, 0, fn, NULL);
    if (!p) return STATUS_ERROR;
    *value = *p;
    return STATUS_OK;
}

Status instance_get_boolean(Instance *I, unsigned vr, int *value, const char *fn) {
    const int *p = (const int *)lookup(I, vr, TYPE_BOOLEAN, 0, fn, NULL);
    if (!p) return STATUS_ERROR;
    *value = *p ? 1 : 0;
    return STATUS_OK;
}

Status instance_get_string(Instance *I, unsigned vr, const char **value, const char *fn) {
    const char *p = (const char *)lookup(I, vr, TYPE_STRING, 0, fn, NULL);
    if (!p) return STATUS_ERROR;
    *value = p; /* valid until the variable is set again or the instance is freed */
    return STATUS_OK;
}

/* -------------------------------------------------------------- FMU state */

/* The FMI part of a state to restore: phase, flags and times. */
static int snapshot_check(const Snapshot *snap, char *msg, size_t n) {
    int phase = (int)snap->phase;
    /* PHASE_EVENT: FMI 3.0 Co-Simulation's event mode, between two steps like PHASE_STEP_COMPLETE */
    if (!(phase == PHASE_INSTANTIATED || phase == PHASE_INITIALIZATION || phase == PHASE_STEP_COMPLETE ||
          phase == PHASE_EVENT || phase == PHASE_TERMINATED || phase == PHASE_ERROR)) {
        snprintf(msg, n, "unknown phase %d", phase);
        return 1;
    }
    if (snap->type != INTERFACE_CS) {
        snprintf(msg, n, "interface type %d is not Co-Simulation", (int)snap->type);
        return 1;
    }
    if (!(snap->terminated == 0 || snap->terminated == 1) || (snap->terminated && phase < PHASE_STEP_COMPLETE) ||
        !(snap->toleranceDefined == 0 || snap->toleranceDefined == 1) ||
        (snap->toleranceDefined ? !(snap->tolerance > 0 && snap->tolerance <= 0.1) : snap->tolerance != 0.0)) {
        snprintf(msg, n, "flags terminated %d, toleranceDefined %d or tolerance %g out of range", snap->terminated,
                 snap->toleranceDefined, snap->tolerance);
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
    if (snap->model.rec || snap->model.sup) {
        snprintf(msg, n, "a record or support address where a saved state has none");
        return 1;
    }
    return 0;
}



/* The memory of a state: the importer's `state`, or new memory when it is NULL (NULL after
 * logging when out of memory). */
static Snapshot *state_memory(Instance *I, void *state, const char *fn) {
    Snapshot *snap = state ? (Snapshot *)state : (Snapshot *)I->alloc(1, sizeof(Snapshot));
    if (!snap) INSTANCE_ERROR(I, "%s: out of memory", fn);
    return snap;
}

Status instance_get_state(Instance *I, void **state, const char *fn) {
    if (instance_bad_call(I, GET_PHASES | PHASE_INSTANTIATED, fn)) return STATUS_ERROR;
    if (I->s.type != INTERFACE_CS) {
        INSTANCE_ERROR(I, "%s: FMU states are available in Co-Simulation only", fn);
        return STATUS_ERROR;
    }
    if (!state) {
        INSTANCE_ERROR(I, "%s: state pointer is NULL", fn);
        return STATUS_ERROR;
    }
    Snapshot *snap = state_memory(I, *state, fn);
    if (!snap) return STATUS_ERROR;
    if (*state && snap->magic != SNAPSHOT_MAGIC) {
        INSTANCE_ERROR(I, "%s: the state to overwrite was not made by this FMU", fn);
        return STATUS_ERROR;
    }
    *snap = I->s;
    snap->model.rec = NULL; /* the instance's, re-attached by set_state; no address in saved bytes */
    snap->model.sup = NULL;
    *state = snap;
    return STATUS_OK;
}

Status instance_set_state(Instance *I, const void *state, const char *fn) {
    if (instance_bad_call(I, GET_PHASES | PHASE_INSTANTIATED, fn)) return STATUS_ERROR;
    if (I->s.type != INTERFACE_CS) {
        INSTANCE_ERROR(I, "%s: FMU states are available in Co-Simulation only", fn);
        return STATUS_ERROR;
    }
    const Snapshot *snap = (const Snapshot *)state;
    if (!snap || snap->magic != SNAPSHOT_MAGIC || snap->size != sizeof(Snapshot)) {
        INSTANCE_ERROR(I, "%s: not a state of this FMU", fn);
        return STATUS_ERROR;
    }
    char msg[MSG_LEN];
    if (snapshot_check(snap, msg, sizeof(msg))) {
        INSTANCE_ERROR(I, "%s: invalid state (corrupted?): %s", fn, msg);
        return STATUS_ERROR;
    }
    const Model *sm = &snap->model;
    StagedRecord staged = {0};
    SupportTable fresh = {0}, freshRest = {0};
    int moves = 0, rests = 0;
    if (!snap->dirty) {
        /* the state's parameters must be valid, its derived values exactly those they give
         * (with its record, which must have the same samples), and its integrator and
         * discrete state one a run of these parameters leaves. Until every check passed,
         * nothing of the instance changes (its record neither). */
        if (model_validate(&sm->v, msg, sizeof(msg))) {
            INSTANCE_ERROR(I, "%s: the state's parameters are invalid: %s", fn, msg);
            return STATUS_ERROR;
        }
        if (snap->toleranceDefined && !(sm->v.relTol <= snap->tolerance)) {
            INSTANCE_ERROR(I, "%s: invalid state (corrupted?): solver.relTol %g is looser than the importer's tolerance %g",
                      fn, sm->v.relTol, snap->tolerance);
            return STATUS_ERROR;
        }
        if (sm->v.kind == KIND_RECORD && stage_record(I, sm->v.file, &sm->d, &staged, msg, sizeof(msg))) {
            INSTANCE_ERROR(I, "%s: excitation.file: %s", fn, msg);
            return STATUS_ERROR;
        }
        Model check = *sm;
        check.rec = sm->v.kind == KIND_RECORD ? staged_record(I, &staged) : NULL;
        model_derive(&check);
        /* the support's table of these parameters and record: the instance's own when it was built for
         * them, else a new one, adopted with the state */
        if (memcmp(&check.d, &sm->d, sizeof(Derived)) == 0 && support_needed(&check) && !check.d.sup.twoWay) {
            if (support_matches(&check, &I->sup)) {
                check.sup = &I->sup;
            } else if (support_attach(&check, &fresh, I->alloc, I->release, msg, sizeof(msg))) {
                drop_record(I, &staged);
                INSTANCE_ERROR(I, "%s: support: %s", fn, msg);
                return STATUS_ERROR;
            } else {
                check.sup = &fresh;
            }
        }
        /* and the table of the support with the blocks at rest on it (two-way) */
        check.restTable = NULL;
        if (memcmp(&check.d, &sm->d, sizeof(Derived)) == 0 && support_rest_needed(&check)) {
            SupportTable *own = &I->supRest;
            int kept = support_rest_matches(&check, own);
            if (!kept && support_rest_attach(&check, &freshRest, I->alloc, I->release, msg, sizeof(msg))) {
                drop_record(I, &staged);
                support_free(&fresh, I->release);
                INSTANCE_ERROR(I, "%s: support: %s", fn, msg);
                return STATUS_ERROR;
            }
            check.restTable = kept ? own : &freshRest;
        }
        if (check.s.rest.on) check.sup = check.restTable;
        if (memcmp(&check.d, &sm->d, sizeof(Derived)) != 0 || (check.s.rest.on && !check.restTable)) {
            drop_record(I, &staged);
            support_free(&fresh, I->release);
            support_free(&freshRest, I->release);
            INSTANCE_ERROR(I, "%s: the state does not match its own parameters (a corrupted state?)", fn);
            return STATUS_ERROR;
        }
        StateUse use = snap->phase == PHASE_INITIALIZATION ? STATE_INITIAL
                       : ((snap->phase & (PHASE_STEP_COMPLETE | PHASE_EVENT)) && !snap->terminated) ? STATE_RUNNING
                                                                                                 : STATE_INERT;
        if (state_validate(&check, snap->startTime, snap->tc, use, msg, sizeof(msg))) {
            drop_record(I, &staged);
            support_free(&fresh, I->release);
            support_free(&freshRest, I->release);
            INSTANCE_ERROR(I, "%s: invalid state (corrupted?): %s", fn, msg);
            return STATUS_ERROR;
        }
        adopt_record(I, &staged);
        if (fresh.data) {
            support_free(&I->sup, I->release);
            I->sup = fresh;
        }
        if (freshRest.data) {
            support_free(&I->supRest, I->release);
            I->supRest = freshRest;
        }
        moves = check.sup != NULL && !check.s.rest.on;
        rests = check.restTable != NULL;
    }
    I->s = *snap;
    I->s.model.rec = (!snap->dirty && sm->v.kind == KIND_RECORD) ? &I->rec : NULL;
    I->s.model.restTable = rests ? &I->supRest : NULL;
    I->s.model.sup = moves ? &I->sup : (rests && snap->model.s.rest.on) ? &I->supRest : NULL;
    return STATUS_OK;
}

Status instance_free_state(Instance *I, void **state) {
    if (!state || !*state) return STATUS_OK;
    I->release(*state);
    *state = NULL;
    return STATUS_OK;
}

size_t instance_state_size(void) { return sizeof(Snapshot); }

Status instance_serialize_state(Instance *I, const void *state, unsigned char *bytes, size_t size, const char *fn) {
    const Snapshot *snap = (const Snapshot *)state;
    if (!snap || snap->magic != SNAPSHOT_MAGIC || !bytes || size < sizeof(Snapshot)) {
        INSTANCE_ERROR(I, "%s: invalid state or buffer of %zu bytes (need %zu)", fn, size, sizeof(Snapshot));
        return STATUS_ERROR;
    }
    memcpy(bytes, snap, sizeof(Snapshot));
    return STATUS_OK;
}

Status instance_deserialize_state(Instance *I, const unsigned char *bytes, size_t size, void **state,
                                  const char *fn) {
    Snapshot tmp;
    if (!bytes || !state || size != sizeof(Snapshot)) {
        INSTANCE_ERROR(I, "%s: expected %zu bytes, got %zu", fn, sizeof(Snapshot), size);
        return STATUS_ERROR;
    }
    memcpy(&tmp, bytes, sizeof(Snapshot));
    if (tmp.magic != SNAPSHOT_MAGIC || tmp.size != sizeof(Snapshot)) {
        INSTANCE_ERROR(I, "%s: bytes are not a state of this FMU", fn);
        return STATUS_ERROR;
    }
    Snapshot *snap = state_memory(I, *state, fn);
    if (!snap) return STATUS_ERROR;
    *snap = tmp;
    *state = snap;
    return STATUS_OK;
}

/* ------------------------------------------------------ co-simulation step */

Status instance_do_step(Instance *I, double currentPoint, double h, int earlyReturn, StepResult *r, const char *fn) {
    if (instance_initialize(I) != STATUS_OK) return STATUS_ERROR;
    double tc = I->s.tc;
    r->time = tc;
    r->event = r->earlyReturn = 0;
    r->terminate = I->s.terminated;
    if (!isfinite(currentPoint) || !isfinite(h) || h < 0) {
        INSTANCE_ERROR(I, "%s: invalid communication point %g or step size %g", fn, currentPoint, h);
        return STATUS_ERROR;
    }
    if (fabs(currentPoint - tc) > 1e-9 * fmax(1.0, fabs(tc))) {
        INSTANCE_ERROR(I, "%s: communication point %.17g does not match the FMU time %.17g", fn, currentPoint, tc);
        return STATUS_ERROR;
    }
    double target = currentPoint + h;
    /* with a stop time defined, no step may end after it (within the 1e-9 relative slack the
     * communication point has): fmi2SetupExperiment, fmi3EnterInitializationMode */
    if (I->s.stopDefined && target > I->s.stopTime + 1e-9 * fmax(1.0, fabs(I->s.stopTime))) {
        INSTANCE_ERROR(I, "%s: the step to %.17g ends after the stop time %.17g", fn, target, I->s.stopTime);
        return STATUS_ERROR;
    }
    if (I->s.terminated) {
        INSTANCE_ERROR(I, "%s: the run ended at the overturn at t = %.17g (solver.stopAtOverturn)", fn, tc);
        return STATUS_DISCARD;
    }
    Model *M = &I->s.model;
    Logger log = instance_solver_logger(I);
    EventStop stop = {earlyReturn, M->v.stopAtOverturn, tc, 0, 0.0};
    double momentum0 = M->v.momentum, moment0 = M->s.massMoment;
    if (solver_advance(M, target, &log, &stop)) {
        I->s.phase = PHASE_ERROR;
        return STATUS_ERROR;
    }
    double reached = stop.stopped ? stop.time : target;
    I->s.tc = reached;
    /* the mean load over the step, impacts' impulses included: what the ground gave the blocks' momentum */
    M->s.loadValid = 0;
    solver_outputs(M, reached);
    if (reached > tc) {
        /* and its first moment, the integral of (t - tc) load dt = -dt p1 + (q1 - q0) (p the momentum, q the mass
         * moment whose rate it is): the slope of the line with both, 12 (q1 - q0 - dt (p0 + p1) / 2) / dt^3 */
        double dt = reached - tc;
        M->s.loadMean = -(M->v.momentum - momentum0) / dt;
        M->s.loadSlope = 12.0 * (M->s.massMoment - moment0 - 0.5 * dt * (momentum0 + M->v.momentum)) / (dt * dt * dt);
        M->s.loadValid = 1;
        M->v.groundLoad = M->s.loadMean;
        M->v.groundLoadSlope = M->s.loadSlope;
    }
    r->time = reached;
    r->event = stop.stopped;
    r->earlyReturn = stop.stopped && reached < target;
    if (M->v.stopAtOverturn && M->s.mode == MODE_OVERTURNED) {
        I->s.terminated = 1;
        r->terminate = 1;
        return STATUS_DISCARD;
    }
    return STATUS_OK;
}
