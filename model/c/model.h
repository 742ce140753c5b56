/* Rocking rigid block: model data and physics.
 *
 * Units SI, angles in radians. Sign convention (docs/conventions.md):
 *   x to the right, y up; theta > 0 is a clockwise rotation about the
 *   bottom RIGHT corner, theta < 0 a counter-clockwise rotation about the
 *   bottom LEFT corner. a_h > 0 accelerates the ground towards +x (which
 *   tips a block at rest towards theta < 0); a_v > 0 accelerates the ground
 *   upwards (effective gravity g + a_v).
 *
 * The struct Model holds everything one instance needs and no pointers, so
 * it can be copied byte for byte (FMU state get/set and serialisation) and
 * several instances never share anything.
 */
#ifndef ROCKING_MODEL_H
#define ROCKING_MODEL_H

#include <stddef.h>

#include "integrator.h" /* NMAX */
#include "record.h"
#include "support.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* String parameters (excitation.file) live in the struct as fixed buffers,
 * so that a Model stays free of pointers into variable data. */
#define STRING_CAPACITY 4096
#define MODEL_INPUTS 3    /* the continuous inputs ground.ah, ground.av, support.force (State's inD) */
typedef char FixedString[STRING_CAPACITY];

#define REAL_TYPE double
#define INTEGER_TYPE int
#define BOOLEAN_TYPE int
#define STRING_TYPE FixedString

/* excitation.kind */
typedef enum {
    KIND_NONE = 0,
    KIND_SINE_PULSE = 1,
    KIND_COSINE_PULSE = 2,
    KIND_HARMONIC = 3,
    KIND_RECORD = 4,
    KIND_RICKER = 5,
    KIND_RICKER_ANTISYMMETRIC = 6,
    KIND_MP_PULSE = 7,
    KIND_COUNT = 8
} ExcitationKind;

/* most edges of the cells on which a built-in pulse is monotone (ground.c) */
#define MAX_CELLS 64

/* The most blocks of a column (nBlocks): blocks 1 and 2 have variables of their own, blocks 3 to 8
 * the families of variables.def's BLOCK lines (field[K - 3]). */
#define MAX_BLOCKS 8

/* All FMI variables: parameters, inputs and outputs, generated from the table. */
typedef struct Variables {
#define VAR(T, vr, field, name, caus, var, start, unit, desc) T##_TYPE field;
#define BLOCK(T, base, field, member, caus, var, start, unit, desc) T##_TYPE field[MAX_BLOCKS - 2];
#include "variables.def"
#undef BLOCK
#undef VAR
} Variables;

/* The contact engine (engine.h): which corners of each body touch its support (0 left, 1 right)
 * and how its contact slides (0 sticks, +-1 the sign of the slip rate). */
#ifndef EN_MAX_BODIES /* (white-box checks build the engine with their own: tests/c/engine_column.c) */
#define EN_MAX_BODIES MAX_BLOCKS
#endif
typedef struct {
    int closed[EN_MAX_BODIES][2];
    int sigma[EN_MAX_BODIES];
    /* which pair makes the contact at each end i (0 left, 1 right) of body k on body k - 1 (docs/columns.md,
     * "Overhangs"): 0 body k's base corner i on its support's top face, 1 the support's top corner i against body
     * k's base face (body k's corner i lies beyond the support's edge: an overhang). Always 0 on the ground. */
    int over[EN_MAX_BODIES][2];
} EnMode;
/* The engine's bodies (engine.h): convex polygons in their rest pose, in a body frame (x right, y up, y = 0 the
 * base, x = 0 the axis: a column's axes align at rest), derived once by engine_body_polygon or
 * engine_body_rectangle; body k stands on body k - 1 (the ground for k = 0). Lengths in m. Contacts are the base's
 * two end corners (index 0 left, 1 right) against the support's top face. */
typedef struct {
    double b, h;    /* size scales: the larger horizontal distance of a base corner from the centre of mass, and the
                     * centre's height above the base (a rectangle's half width and half height); hypot(b, h) is the
                     * farther base corner's distance from the centre */
    double m, Ic;   /* mass (kg), inertia about the centre of mass (kg m^2) */
    double cx[2], cy; /* the base corners (left, right) from the centre of mass, body frame (cy = -h < 0) */
    double xG;      /* the centre of mass from the axis (x; 0 for a symmetric body) */
    double xa[2];   /* the base corners from the axis (x; the slip of a contact is its corner's slip less this) */
    double ht;      /* the top face above the centre of mass (what a body on it stands on) */
    double tm, tw;  /* the top face's middle from the axis (x) and its half width (tw = 0: no flat top, it carries
                     * nothing) */
    double iIo[2];  /* 1 / (Ic + m |c|^2): the inverse inertia about each base corner c, 1/(kg m^2) */
    double over[2]; /* rotation relative to the support (rad, > 0) at which the body, rocking on that corner, lands
                     * on the hull edge next to it: pi less the polygon's interior angle there (pi/2 for a rectangle) */
} EnBody;

typedef struct {
    int nb;
    EnBody body[EN_MAX_BODIES];
    double mu[EN_MAX_BODIES]; /* friction coefficient of body k on its support */
    double g;
    double weight[EN_MAX_BODIES]; /* weight carried by body k's contact (it and those above), N */
} EnSystem;

/* Quantities derived from the parameters at initialisation. */
typedef struct {
    double R;          /* half diagonal, m */
    double alpha;      /* slenderness angle atan(b/h), rad */
    double tanAlpha;
    double I0;         /* moment of inertia about a corner, kg m^2 */
    double mROverI0;   /* m R / I0 = 3 / (4 R), 1/m */
    double p2;         /* frequency parameter squared 3 g / (4 R), 1/s^2 */
    double eta;        /* effective coefficient of restitution */
    double omegaExc;   /* excitation circular frequency, rad/s */
    double accAmp;     /* horizontal acceleration amplitude, m/s^2 */
    double excStart;   /* excitation window [excStart, excEnd), s */
    double excEnd;     /* +inf for an endless harmonic */

    /* built-in pulses (kinds 5 to 7, ground.c): the waveform is divided by
     * pulseNorm so that its peak is 1 */
    double pulseCentre; /* Ricker centre, Mavroeidis-Papageorgiou t0, s */
    double pulseRate;   /* Ricker: kappa of x = kappa (t - centre), 1/s */
    double pulseNorm;
    double mpOmega[3], mpCoef[3]; /* Mavroeidis-Papageorgiou: three sines */
    int nCells;                   /* cells on which the pulse is monotone */
    double cell[MAX_CELLS];
    /* record (kind 4): its samples and content, to check a restored state */
    int recN;
    unsigned long long recHash;
    double upliftSlope; /* at rest the ground tips the body once |ah| > upliftSlope (g + av) */
    double weight[2];   /* weight carried by the ground (both blocks) and by block 1 (block 2), N */

    EnSystem en; /* the contact engine's bodies (one block, or a stack of two) */
    SupportModes sup; /* the support's modes (support.h; nm = 0 on the ground) */
    SupportModes supRest; /* on a two-way support, its first-order modes with every block at rest on it (first = 0:
                           * none; support_rest_modes), and their shapes on every floor */
    SupportShapes restShapes;

    /* two stacked blocks (nBlocks = 2), see stack.h */
    double c;          /* half width of the contact between the blocks, m */
    double Ic1, Ic2;   /* moments of inertia about the centres, kg m^2 */
    double mTot;       /* total mass, kg */
    double yG;         /* height of the pair's centre of mass at rest, m */
    double RL, alphaL, IL; /* the pair as one body about a corner: R, alpha, inertia */
    double RI, alphaI, II; /* block 2 about an end of the contact: R, alpha, inertia */
} Derived;

/* Motion pattern (the value of the output "pattern"). One block: ROCKING,
 * REST, OVERTURNED. Two blocks: REST, UPPER (block 2 rocks on block 1 at
 * rest), LOCKED (the pair rocks as one body), BOTH, OVERTURNED. */
typedef enum {
    MODE_ROCKING = 0,
    MODE_REST = 1,
    MODE_OVERTURNED = 2,
    MODE_UPPER = 3,
    MODE_LOCKED = 4,
    MODE_BOTH = 5,
    MODE_SLIDE = 6 /* one block, rocking-sliding: flat on the ground, sliding */
} Mode;
typedef enum {
    EVENT_NONE = 0,
    EVENT_IMPACT = 1,    /* block 1 lands on the ground */
    EVENT_OVERTURN = 2,  /* block 1 (and with it the stack) falls over */
    EVENT_INTERFACE = 3, /* block 2 lands on block 1 */
    EVENT_OVERTURN2 = 4, /* block 2 falls off block 1 */
    EVENT_OPEN = 5,      /* a closed contact starts to open (no velocity jump) */
    EVENT_SLIP_START = 6, /* rocking-sliding: the pivot starts to slide (|T| reaches mu N) */
    EVENT_SLIP_STOP = 7, /* rocking-sliding: the slip rate reaches zero */
    EVENT_FELL_OFF = 8,  /* contact engine, a stack: block 2 leaves block 1's top */
    EVENT_FLIGHT = 9,    /* (unused: kept so that the codes after it keep their values) */
    EVENT_RECHOOSE = 10, /* contact engine: the contact set no longer holds where a step starts */
    EVENT_JAM = 11,      /* contact engine: a contact sliding on one corner reaches Painleve's singularity */
    EVENT_OVERHANG = 12  /* contact engine: a corner of body k passes the corner of the support's top (the contact at
                          * that end changes its pair: EnMode's over) */
} EventKind;


#define MAX_STEP_PEAKS 4
#define TAYLOR_MAX 30 /* highest order of the Taylor-series integrator */
/* The tightest tolerances the integrators can meet in double precision: a local error
 * below 1e-14 |y| (45 machine epsilons) is lost in the rounding of a step's own
 * arithmetic, and an absolute one below 1e-20 rad (or rad/s) in that of the relative
 * part. Tighter ones never returned (the Taylor series steps by eps^(1/N)). */
#define REL_TOL_MIN 1e-14
#define ABS_TOL_MIN 1e-20

/* Integrator and discrete state. The integrator may run ahead of the last
 * communication point: outputs there are taken from the dense output of the
 * last accepted step, so results do not depend on the communication step. */
typedef struct {
    double t;             /* time of the integrator state y, s */
    double y[NMAX];       /* theta1 (rad), omega1 (rad/s) [, theta2, omega2] at t */
    double f[NMAX];          /* derivative at (t, y) (first-same-as-last) */
    int fValid;
    int side;             /* +1 pivot on right corner, -1 on left corner */
    int side2;            /* block 2's pivot on block 1 (nBlocks = 2) */
    int sigma;            /* rocking-sliding: direction of slip (+1 +x, -1 -x), 0 while the contact sticks */
    Mode mode;
    double h;             /* proposed next step, s (0: choose one) */

    /* dense output of the last accepted step, valid on [tOld, t] */
    int denseValid;
    double tOld, hDense;
    Dense cont;           /* (DOP853 on a two-way support, else DOPRI5: engine_solver.c) */
    int denseSide, denseSide2;
    int denseSigma;       /* rocking-sliding: the slip direction of the last step */
    Mode denseMode;       /* and its mode (MODE_ROCKING or MODE_SLIDE) */
    int denseTaylor;      /* the dense output is the Taylor series tay[0..tayN] */
    int tayN;
    double tay[TAYLOR_MAX + 1];

    EventKind pending;    /* event located at t, not yet applied */

    /* peaks located in the last step, committed once time passes them */
    int nStepPeaks;
    double stepPeakTime[MAX_STEP_PEAKS];
    double stepPeakTheta[MAX_STEP_PEAKS];

    /* committed counters */
    int impacts, peaks;
    double lastImpactTime, lastPeakTime, lastPeakTheta, maxAbsTheta;
    int impactRun;                /* contact engine: impacts in a row, each within CHATTER_INTERVAL of the last */
    int impactsNow;               /* contact engine: impacts at the time of the last one (lastImpactTime) */
    double overturnTime, restTime;
    long long steps, rejected;

    /* two blocks */
    int impactsGround, impactsInterface;
    int overturned1, overturned2;
    double maxAbsTheta2;
    double maxPrev, maxPrev2; /* max |theta1|, |theta2| before the dense step */
    double lastSwitchTime;
    int quickSwitches;    /* pattern changes without time advancing */

    /* rocking-sliding (contact.model = 1, engine_solver.c) */
    double maxAbsSlip;    /* largest |slip| at steps and events, m */
    double slideSince;    /* start of the current sliding phase, s */
    double slideDur;      /* time spent sliding in finished phases, s */
    double impactLoss;    /* kinetic energy lost at impacts, J */
    int slideStarts;      /* stick-to-slip transitions */
    /* rocking-sliding stack: the interface's counterparts of the above (the ground's are the fields above) */
    double maxAbsSlip2, slideSince2, slideDur2, slideStartTime1, slideStartTime2, fellOffTime;
    int slideStarts2, fellOff;
    /* a column's blocks 3 to 8 (contact engine; index k - 2 of body k): their counterparts of block 2's fields above */
    double colMaxTheta[MAX_BLOCKS - 2], colMaxSlip[MAX_BLOCKS - 2], colSlideSince[MAX_BLOCKS - 2];
    double colSlideDur[MAX_BLOCKS - 2], colSlideFirst[MAX_BLOCKS - 2];
    int colSlideStarts[MAX_BLOCKS - 2];
    int fallenBody; /* contact engine: 1 + the body whose overturn or fall off the one below ended the run (0: none) */
    int eventContact, eventEnd; /* the pending event's contact (0 ground, 1 interface) and end (+1, -1) */

    /* the contact engine (engine_solver.c): the contact set now and of the last step, the slip
     * where each sticking contact stands, flights (count, start of the current one, time
     * flown in finished ones) and largest gap of each body, Painleve points met */
    EnMode en, enDense, enFinal; /* enFinal: the contacts as the run left them at its end */
    double enAnchor[EN_MAX_BODIES], enDenseAnchor[EN_MAX_BODIES];
    double flightSince[EN_MAX_BODIES], flightDur[EN_MAX_BODIES], gapMax[EN_MAX_BODIES];
    int flights[EN_MAX_BODIES], painleve;
    double enInd[8 * EN_MAX_BODIES]; /* the indicators at the end of the last step, while fValid and enIndValid */
    int enIndN, enIndKind[8 * EN_MAX_BODIES], enIndBody[8 * EN_MAX_BODIES], enIndCorner[8 * EN_MAX_BODIES]; /* theirs */
    double enT[EN_MAX_BODIES], enN[EN_MAX_BODIES]; /* and each contact's forces there (N), while enIndValid */
    int enIndValid;

    /* Model Exchange (me.c) */
    int omegaSign;        /* sign of omega after the last event (a peak is a change) */

    /* contact monitors (contact.c), over the samples taken so far; index 0 the
     * ground, 1 the interface of a stack */
    int monValid;                 /* a sample has been taken */
    double monT;                  /* time of the last sample, s */
    double monTr[2], monN[2];     /* its reactions, N */
    double demandMax[2];          /* largest |T| / N */
    double normalMin[2];          /* smallest N / (weight carried) */
    double slideTime, liftTime;   /* first sliding, first lift-off, s (-1: none) */
    double impulseDemandMax;      /* largest |tangential| / normal impulse of an impact */
    double withinTime;            /* last sample with every block within its stability limit, s (the start: none) */
    /* one block: the reactions at the end of the last step, from its last evaluation
     * of the equation of motion (valid with fValid: while t, y, f are that end's) */
    int endValid;
    double endTr, endN;
    /* contact.groundLoad's mean over the last communication step (Co-Simulation: instance_do_step
     * sets it, with loadValid = 1); without one (loadValid = 0) the output is the load at the time */
    int loadValid;
    double loadMean, loadSlope;
    /* the blocks' mass times their centres of mass's horizontal position relative to the ground, summed (kg m), at the
     * outputs' time: its change over a communication step is the momentum's integral (contact.groundLoadSlope) */
    double massMoment;
    /* blocks at rest on a two-way support in closed form (support.h), with the energy of blocks and support, the
     * base's work and the dampers' loss when they came to rest (J) */
    SupportRest rest;
    double restE0, restW0, restD0;
    /* the inputs' time derivatives (Co-Simulation, fmi2SetRealInputDerivatives): inD[i][k - 1] the k-th (k = 1, 2) of
     * ground.ah (i = 0), ground.av (i = 1) and support.force (i = 2), from the communication point inT0[i] (s): each
     * input is then the polynomial value + d1 (t - inT0) + d2 (t - inT0)^2 / 2 (model_input) */
    double inD[MODEL_INPUTS][2];
    double inT0[MODEL_INPUTS];
} State;

typedef struct Model {
    Variables v;
    Derived d;
    State s;
    /* The samples of a record excitation (kind 4): owned by the FMU instance,
     * read once per file, not part of the FMU state (a restored state is
     * re-attached to its instance's record, checked by recN and recHash). */
    const Record *rec;
    /* A moving support's table of the record's segments (support.h): owned by the instance like the
     * record, re-attached to a restored state (NULL on the ground). */
    const SupportTable *sup;
    /* On a two-way support, the table of the support with the blocks at rest on it (support_rest_attach), owned by the
     * instance like the record; M->sup while they rest in closed form (State's rest). */
    const SupportTable *restTable;
} Model;

/* Logging callback used by the solver; ctx is opaque. category: 0 events,
 * 1 errors. Event messages are only formatted when `events` is set. */
typedef void (*LogFn)(void *ctx, int category, const char *message);
typedef struct {
    LogFn fn;
    void *ctx;
    int events;
} Logger;

/* Where an advance may end early (solver_advance): right after the first
 * event later than `after` (any: impact, uplift, overturn, pattern change;
 * overturn: an overturn only). stopped and time tell whether and when. */
typedef struct {
    int any;
    int overturn;
    double after;
    int stopped;
    double time;
} EventStop;

/* Set every variable of a zeroed Model to its start value (the rest stays 0). */
void model_set_defaults(Model *M);

/* Validate the parameters; on failure write a one-line reason to msg and
 * return nonzero. A record (kind 4) is checked by ground_validate_record once
 * it is attached. */
int model_validate(const Variables *v, char *msg, size_t n);
/* The contact engine runs the model (engine_solver.c): rocking-sliding (contact.model = 1), and rigid rocking on a
 * two-way support (its contacts then never slip: friction RIGID_MU; docs/supports.md). */
int model_engine(const Variables *v);
#define RIGID_MU 1e6
/* Block k's (k = 0 for block 1) half width b, half height h (m) and mass m (kg), and the friction coefficient of
 * its contact with what it stands on (RIGID_MU in rigid rocking). */
void model_block(const Variables *v, int k, double *b, double *h, double *m);
double model_block_mu(const Variables *v, int k);
/* Block k given by its outline (a body of real shape, blockK.outline set); any block of the run so. */
int model_block_polygon(const Variables *v, int k);
int model_polygons(const Variables *v);
/* Block k as the contact engine's body: its outline's polygon (engine_body_polygon), or the rectangle of its half
 * sizes. Returns nonzero with a one-line reason (naming the block) in msg where the outline is refused. */
int model_block_body(const Variables *v, int k, EnBody *B, char *msg, size_t n);

/* Compute the derived quantities (parameters valid, record attached). */
void model_derive(Model *M);

/* Restitution coefficient of the law selected by the parameters (before the
 * correction factor). */
double model_law_restitution(const Variables *v, double alpha);

/* Equation of motion: dy = (omega, theta'') for pivot side (+1 right, -1 left):
 *   theta'' = -(m R / I0) [ (g + a_v) sin(side*alpha - theta)
 *                           + a_h cos(side*alpha - theta) ]            */
void model_rhs(const Model *M, double t, const double y[2], int side, double dy[2]);

/* The impact map of block 1 landing on the ground at time t with angular
 * velocity wm: writes the velocity just after, *wp = eta wm, and returns 1 if
 * the block comes to rest there (rest criterion: below the uplift threshold,
 * a rebound that would peak, in free rocking with effective gravity g + a_v,
 * below restRatio * alpha), else 0. Used by the built-in solver and by Model
 * Exchange's event update alike. */
int model_impact(const Model *M, double t, double wm, double *wp);

/* model_impact's rest criterion for the rate wp just after an impact at time t. */
int model_rebound_negligible(const Model *M, double t, double wp);

/* Energy (J): 0.5 I0 omega^2 + m g R (cos(alpha - |theta|) - cos(alpha)). */
double model_energy(const Model *M, double theta, double omega);

void model_rhs_piece(const Model *M, double t, const double y[2], int side,
                     int piece, double dy[2]);
/* The terms of one evaluation of the equation of motion: the ground's
 * accelerations and the sine and cosine of phi = side alpha - theta (the
 * contact reactions reuse them, contact.h). */
typedef struct {
    double ah, av, sphi, cphi;
} RhsTerms;
void model_rhs_terms(const Model *M, double t, const double y[2], int side, int piece, double dy[2],
                     RhsTerms *k);
/* Uplift indicator of a block at rest for tipping towards side: positive
 * when the ground pushes it over its corner on that side. */
double model_uplift_indicator_piece(const Model *M, double t, int side, int piece);

/* Set the state from the initial parameters at time t0. */
void model_initialize(Model *M, double t0);

#endif
