/* An instance of RockingBlock, whatever FMI version or interface uses it.
 *
 * The FMI layers (fmi2.c: FMI 2.0 Co-Simulation and Model Exchange; fmi3.c:
 * FMI 3.0) are thin: they check their own call sequence, translate types and
 * call these functions, which hold the instance's life cycle, variable
 * access by value reference, the record of a record excitation, FMU states
 * and the communication step. Nothing here is global: every instance is
 * self-contained, so several run side by side in threads.
 *
 * Status values are those of fmi2Status and fmi3Status (equal numbers).
 */
#ifndef ROCKING_INSTANCE_H
#define ROCKING_INSTANCE_H

#include <stddef.h>

#include "model.h"
#include "record.h"

typedef enum { STATUS_OK = 0, STATUS_WARNING = 1, STATUS_DISCARD = 2, STATUS_ERROR = 3 } Status;

/* Where an instance is in its life cycle (one bit each, so that a set of
 * allowed phases is a mask). STEP_COMPLETE is Co-Simulation's step mode;
 * EVENT and CONTINUOUS are Model Exchange's (and FMI 3.0's event mode). */
typedef enum {
    PHASE_INSTANTIATED = 1,
    PHASE_INITIALIZATION = 2,
    PHASE_STEP_COMPLETE = 4,
    PHASE_TERMINATED = 8,
    PHASE_ERROR = 16,
    PHASE_EVENT = 32,
    PHASE_CONTINUOUS = 64
} Phase;

#define ANY_PHASE                                                                                             \
    (PHASE_INSTANTIATED | PHASE_INITIALIZATION | PHASE_STEP_COMPLETE | PHASE_TERMINATED | PHASE_ERROR |       \
     PHASE_EVENT | PHASE_CONTINUOUS)
#define RUNNING_PHASES (PHASE_STEP_COMPLETE | PHASE_EVENT | PHASE_CONTINUOUS)
#define GET_PHASES (PHASE_INITIALIZATION | RUNNING_PHASES | PHASE_TERMINATED | PHASE_ERROR)
#define SET_PHASES (PHASE_INSTANTIATED | PHASE_INITIALIZATION | RUNNING_PHASES)

typedef enum { INTERFACE_CS = 0, INTERFACE_ME = 1 } InterfaceType;

#define SNAPSHOT_MAGIC 0x524f434bu /* "ROCK" */

/* Everything that makes up the FMU state (copied byte for byte). */
typedef struct {
    unsigned magic;
    unsigned size;
    Model model;
    double tc, startTime, stopTime;
    int stopDefined;
    int toleranceDefined; /* the importer's tolerance: solver.relTol is at most it */
    double tolerance;
    Phase phase;
    int dirty; /* parameters set since the last initialisation */
    int terminated; /* the run ended at an overturn (solver.stopAtOverturn) */
    InterfaceType type;
    /* Model Exchange: the running extremes (block1.maxAbsTheta, block2.maxAbsTheta,
     * friction.demandMaxGround/Interface, contact.normalMinGround/Interface) as the last
     * event left them, the outputs between events (discrete variables; me.c) */
    int meHeld;
    double meExtremes[6];
} Snapshot;

/* The file a record was read from, to read it again only when it changed. */
typedef struct {
    char path[STRING_CAPACITY];
    double size, mtime, mtimeNs, inode;
} FileStamp;

struct Instance;
/* Writes one message to the importer's logger (status: a Status value). */
typedef void (*EmitFn)(const struct Instance *I, int status, const char *category, const char *message);

typedef struct Instance {
    Snapshot s;
    EmitFn emit;
    void *env;           /* the importer's environment pointer, for emit */
    void (*logger)(void); /* the importer's logger, cast back by emit */
    RecordAlloc alloc;
    RecordFree release;
    char *name;
    char *resourceDir;      /* local path of the FMU's resources folder, or NULL */
    char resourceNote[300]; /* why there is none, when the importer gave a location */
    int loggingOn;
    int logEvents;
    Record rec; /* the record of excitation.kind = 4, read once per file */
    FileStamp recFile;
    SupportTable sup; /* a moving support's table of the record's segments (support.h), built once per parameters */
    SupportTable supRest; /* two-way: the support's with the blocks at rest on it (support_rest_attach) */
    double meTimeFloor; /* Model Exchange: the last event's or completed step's time, which
                           fmi2SetTime may not go back past (no FMU states to restore) */
} Instance;

#define MSG_LEN (STRING_CAPACITY + 512)

/* Log a one-line message (control characters replaced, '.' as the decimal point). */
void instance_log(const Instance *I, int status, const char *category, const char *fmt, ...);
#define INSTANCE_ERROR(I, ...) instance_log(I, STATUS_ERROR, "logStatusError", __VA_ARGS__)

/* The logger the solver writes events and errors to. */
Logger instance_solver_logger(Instance *I);

/* A new instance in PHASE_INSTANTIATED with every variable at its start value, or
 * NULL (after logging why, through a temporary instance) when out of memory. */
Instance *instance_new(const char *name, InterfaceType type, const char *resourceLocation, EmitFn emit, void *env,
                       void (*logger)(void), RecordAlloc alloc, RecordFree release, int loggingOn);
void instance_free(Instance *I);
/* Back to PHASE_INSTANTIATED with start values (fmi2Reset, fmi3Reset). */
void instance_reset(Instance *I);

/* Nonzero (after logging) unless I exists and is in one of the allowed phases. */
int instance_bad_call(Instance *I, int allowed, const char *fn);

/* Categories "logEvents" and "logStatusError"; none given: all. */
Status instance_set_logging(Instance *I, int loggingOn, size_t n, const char *const categories[], const char *fn);

/* The experiment: start and stop time; an importer's tolerance (toleranceDefined)
 * tightens the integrator's relative tolerance (solver.relTol) when it is the smaller. */
Status instance_setup_experiment(Instance *I, int toleranceDefined, double tolerance, double startTime,
                                 int stopTimeDefined, double stopTime, const char *fn);

/* Validate, derive and initialise if parameters changed; write outputs. */
Status instance_initialize(Instance *I);

/* ------------------------------------------------------- variable access */

typedef enum { TYPE_REAL, TYPE_INTEGER, TYPE_BOOLEAN, TYPE_STRING } VarType;

/* Set or get one scalar; a getter first brings the outputs up to date. */
Status instance_set_real(Instance *I, unsigned vr, double value, const char *fn);
/* The order-th time derivative (1 or 2; 2 for ground.ah on the ground alone) of the continuous input vr (ground.ah, ground.av) from the communication point
 * on (Co-Simulation, fmi2SetRealInputDerivatives; State's inD). Derivatives set at an earlier communication point are
 * dropped by the first derivative or value set for that input at a later one. */
Status instance_set_real_derivative(Instance *I, unsigned vr, int order, double value, const char *fn);
Status instance_set_integer(Instance *I, unsigned vr, int value, const char *fn);
Status instance_set_boolean(Instance *I, unsigned vr, int value, const char *fn);
Status instance_set_string(Instance *I, unsigned vr, const char *value, const char *fn);
Status instance_get_real(Instance *I, unsigned vr, double *value, const char *fn);
Status instance_get_integer(Instance *I, unsigned vr, int *value, const char *fn);
Status instance_get_boolean(Instance *I, unsigned vr, int *value, const char *fn);
Status instance_get_string(Instance *I, unsigned vr, const char **value, const char *fn);

/* Common start of a getter or setter: phase and array checks; a getter also
 * initialises when parameters changed. */
Status instance_begin_access(Instance *I, int set, const void *vr, size_t nvr, const void *value, const char *fn);

/* Bring the outputs at the current time up to date after inputs changed
 * (direct feedthrough: ground.ahTotal, ground.avTotal, the accelerations). */
void instance_update_outputs(Instance *I);

/* ------------------------------------------------------------- FMU state */

Status instance_get_state(Instance *I, void **state, const char *fn);
Status instance_set_state(Instance *I, const void *state, const char *fn);
Status instance_free_state(Instance *I, void **state);
size_t instance_state_size(void);
Status instance_serialize_state(Instance *I, const void *state, unsigned char *bytes, size_t size, const char *fn);
Status instance_deserialize_state(Instance *I, const unsigned char *bytes, size_t size, void **state,
                                  const char *fn);

/* ------------------------------------------------------ co-simulation step */

/* What a communication step ended with. */
typedef struct {
    double time;      /* the time reached: the step's end, or an event's time on early return */
    int event;        /* an impact, uplift, overturn or pattern change happened at `time` */
    int earlyReturn;  /* the step ended before its end at that event */
    int terminate;    /* the run ended (solver.stopAtOverturn and the block overturned) */
} StepResult;

/* Advance from the current communication point by h (checks of FMI 2.0's
 * fmi2DoStep: point, step size, stop time). With earlyReturn, end at the first
 * event after the communication point. */
Status instance_do_step(Instance *I, double currentPoint, double h, int earlyReturn, StepResult *r,
                        const char *fn);

#endif
