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

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

#define REAL_TYPE double
#define INTEGER_TYPE int
#define BOOLEAN_TYPE int

/* All FMI variables: parameters, inputs and outputs, generated from the table. */
typedef struct {
#define VAR(T, vr, field, name, caus, var, start, unit, desc) T##_TYPE field;
#include "variables.def"
#undef VAR
} Variables;

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
} Derived;

typedef enum { MODE_ROCKING = 0, MODE_REST = 1, MODE_OVERTURNED = 2 } Mode;
typedef enum { EVENT_NONE = 0, EVENT_IMPACT = 1, EVENT_OVERTURN = 2 } EventKind;

#define MAX_STEP_PEAKS 4

/* Integrator and discrete state. The integrator may run ahead of the last
 * communication point: outputs there are taken from the dense output of the
 * last accepted step, so results do not depend on the communication step. */
typedef struct {
    double t;             /* time of the integrator state y, s */
    double y[NMAX];       /* theta (rad), omega (rad/s) at t */
    double f[NMAX];          /* derivative at (t, y) (first-same-as-last) */
    int fValid;
    int side;             /* +1 pivot on right corner, -1 on left corner */
    Mode mode;
    double h;             /* proposed next step, s (0: choose one) */

    /* dense output of the last accepted step, valid on [tOld, t] */
    int denseValid;
    double tOld, hDense;
    double cont[5][NMAX];
    int denseSide;

    EventKind pending;    /* event located at t, not yet applied */

    /* peaks located in the last step, committed once time passes them */
    int nStepPeaks;
    double stepPeakTime[MAX_STEP_PEAKS];
    double stepPeakTheta[MAX_STEP_PEAKS];

    /* committed counters */
    int impacts, peaks;
    double lastImpactTime, lastPeakTime, lastPeakTheta, maxAbsTheta;
    double overturnTime, restTime;
    long long steps, rejected;
} State;

typedef struct {
    Variables v;
    Derived d;
    State s;
} Model;

/* Logging callback used by the solver; ctx is opaque. category: 0 events,
 * 1 errors. Event messages are only formatted when `events` is set. */
typedef void (*LogFn)(void *ctx, int category, const char *message);
typedef struct {
    LogFn fn;
    void *ctx;
    int events;
} Logger;

/* Set every variable to its start value. */
void model_set_defaults(Model *M);

/* Validate the parameters; on failure write a one-line reason to msg and
 * return nonzero. */
int model_validate(const Variables *v, char *msg, size_t n);

/* Compute the derived quantities (parameters must be valid). */
void model_derive(const Variables *v, Derived *d);

/* Restitution coefficient of the law selected by the parameters (before the
 * correction factor). */
double model_law_restitution(const Variables *v, double alpha);

/* Total ground accelerations (built-in plus inputs), m/s^2. */
void model_ground(const Model *M, double t, double *ah, double *av);

/* Equation of motion: dy = (omega, theta'') for pivot side (+1 right, -1 left):
 *   theta'' = -(m R / I0) [ (g + a_v) sin(side*alpha - theta)
 *                           + a_h cos(side*alpha - theta) ]            */
void model_rhs(const Model *M, double t, const double y[2], int side, double dy[2]);

/* Energy (J): 0.5 I0 omega^2 + m g R (cos(alpha - |theta|) - cos(alpha)). */
double model_energy(const Model *M, double theta, double omega);

/* Piece of the excitation active on a step starting at tStart (0 outside
 * the excitation window, 1 inside). A step never crosses a window edge, so
 * evaluating the piece's analytic formula at the step's end points gives the
 * correct one-sided limits at discontinuities (cosine pulse). */
int model_piece(const Model *M, double tStart);
void model_ground_piece(const Model *M, double t, int piece, double *ah, double *av);
void model_rhs_piece(const Model *M, double t, const double y[2], int side,
                     int piece, double dy[2]);
/* Uplift indicator of a block at rest for tipping towards side: positive
 * when the ground pushes it over its corner on that side. */
double model_uplift_indicator_piece(const Model *M, double t, int side, int piece);

/* Set the state from the initial parameters at time t0. */
void model_initialize(Model *M, double t0);

#endif
