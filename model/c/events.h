/* Event location shared by the one-block and two-block solvers: logging,
 * excitation break points, step-length refinement of events and the search
 * for uplift from rest. */
#ifndef ROCKING_EVENTS_H
#define ROCKING_EVENTS_H

#include "integrator.h"
#include "ground.h"
#include "model.h"

#define LOG_EVENTS 0
#define LOG_ERROR 1

/* printf-style message to the solver's logger (events only if enabled). */
/* Whether say() writes messages of this category (to skip work done only for a message). */
int says(const Logger *log, int category);
void say(const Logger *log, int category, const char *fmt, ...);

/* One accepted adaptive step from (t, y) with f0 = f(t, y): tries *h
 * (capped at hmax, in which case *hitMax is set), shrinking it until the
 * error norm is <= 1. Writes the step result, its dense output and the
 * proposed next step; counts rejected attempts. Returns 0, or -1 if the
 * step size underflows, is not finite or no step is accepted within
 * MAX_REJECTS attempts. */
#define MAX_REJECTS 1000
int adaptive_step(RhsFn f, const void *ctx, int n, double t, const double *y,
                  const double *f0, double *h, double hmax, double rtol, double atol,
                  double *y1, double *f1, Dense *cont, double *hNext,
                  int *hitMax, long long *rejected);

/* adaptive_step by the method (RK_DOPRI5, or RK_DOP853 with its stages in st, NULL for DOPRI5) whose error control
 * covers the first nErr of the n components only (the others are integrals that ride along, such as work done),
 * with the absolute tolerance of component i scaled by scale[i] (components of other units than the angles; 0: a
 * component not controlled; NULL: all 1). A DOP853 step's dense output is of degree 3 until dop853_dense. */
int adaptive_step_controlled(int method, RhsFn f, const void *ctx, int n, int nErr, const double *scale, double t,
                             const double *y, const double *f0, double *h, double hmax, double rtol, double atol,
                             double *y1, double *f1, Dense *cont, Dop853Stages *st, double *hNext,
                             int *hitMax, long long *rejected);

/* One step of the method (stages in st for RK_DOP853) of length h, its error estimate discarded. */
void rk_step(int method, RhsFn f, const void *ctx, int n, double t, const double *y, const double *f0, double h,
             double *y1, double *f1, Dense *cont, Dop853Stages *st);

/* Newton iteration on the step length h in (0, hMax] so that the weighted
 * sum of the step result's components, sum w[i] y1[i], equals target.
 * Leaves the step result for the returned h in y1, f1, cont. */
double refine_step(int method, RhsFn f, const void *ctx, int n, double t, const double *y,
                   const double *f0, double h, double hMax, const double *w,
                   double target, double *y1, double *f1, Dense *cont, Dop853Stages *st);
/* refine_step from a step of length h already taken (its result in y1, f1, cont). */
double refine_step_from(int method, RhsFn f, const void *ctx, int n, double t, const double *y, const double *f0,
                        double h, double hMax, const double *w, double target, double *y1, double *f1, Dense *cont,
                        Dop853Stages *st);

/* The first x in (a, b] at which f turns negative, given f(a) = fa >= 0 > f(b) = fb: regula
 * falsi with the Illinois change (a few evaluations for a smooth f), falling back to halving
 * when an end stays put, until the bracket is no wider than
 * epsFactor * DBL_EPSILON * max(floor, |offset + b|) or after maxIter evaluations. Used to locate
 * the first sliding or lift-off of the contact monitors. */
double first_negative(double (*f)(void *ctx, double x), void *ctx, double a, double fa, double b, double fb,
                      double epsFactor, double offset, double floor, int maxIter);
/* As first_negative, for an f costly to evaluate (the contact engine's indicators after a real step): regula
 * falsi with the Anderson-Bjorck change (Anderson & Bjorck 1973: the end that stays put has its value scaled by
 * 1 - f(x) / f(the other end), superlinear without halving), and each estimate kept at least the final width
 * inside the bracket, so that once the estimate has converged the next one closes the bracket from its other
 * side (as in Brent's method); an estimate on an end (an f exactly 0 there) moves just inside it too. About 5 evaluations where first_negative takes 16. */
double first_negative_costly(double (*f)(void *ctx, double x), void *ctx, double a, double fa, double b, double fb,
                             double epsFactor, double offset, double floor, int maxIter);

/* The first s in (0, 1] at which g(s) (an indicator along a step's dense output, >= 0 at s = 0)
 * is negative: g sampled at `samples` evenly spaced points, the first sign change bisected to a
 * few units of rounding; 2 if no sample is negative. Used for the stack's contact openings and
 * rocking-sliding's stick-to-slip. */
double first_negative_sampled(double (*g)(void *ctx, double s), void *ctx, int samples);

/* First root in (0, 1] of the polynomial c of degree deg (at most 7) crossing with the given slope sign
 * (-1 falling, +1 rising); 2 if there is none. */
double first_crossing(const double *c, int deg, int slope);

/* Nonzero if the polynomial c of degree deg may have a root in [0, 1] (coefficient bounds). */
int may_have_root(const double *c, int deg);

/* At rest: the first time in [t, tc] at which |ah| exceeds
 * M->d.upliftSlope * (g + av), found cell by cell (the excitation is
 * monotone on each cell, ground.h) and by bisection. Returns the tipping side (+1, -1)
 * and the time in *tu, 0 if the ground does not tip the body before tc, or
 * UPLIFT_STUCK if the next cell edge is not after the current time (a time so
 * large that its resolution is coarser than the excitation's cells). */
#define UPLIFT_STUCK 2
int find_uplift(const Model *M, double t, double tc, double *tu);

/* An indicator of leaving rest at time t (piece: model_piece's at the start of its cell): positive
 * once the ground moves the bodies resting on it, and crossing zero at most once on each cell of
 * the excitation (where it is monotone). */
typedef double (*RestExitFn)(const Model *M, double t, int piece);
/* The first time in [t, tc] at which ind turns positive, found cell by cell and by bisection as
 * find_uplift does; +inf if none before tc, NaN if the next cell edge is not after t. */
double find_exit(const Model *M, double t, double tc, RestExitFn ind);

/* Peaks of block 1 (its rate's zeros) located in the last step: count and log those passed, and the
 * largest |theta| so far (block 1's rotation is y[0] in every one-block state vector). */
void commit_peaks(Model *M, const Logger *log);
/* The peak outputs at the output time tc (peaks, lastPeakTime, lastPeakTheta, maxAbsTheta): the committed
 * ones and those of the last step up to tc; theta is block 1's rotation at tc. */
void peak_outputs(const State *S, double tc, double theta, Variables *v);
/* Keep only the located peaks at or before tc (a rollback to tc). */
void keep_peaks_until(State *S, double tc);

/* What a solver plugs into advance_to(). */
typedef struct {
    /* apply the event pending at S->t; nonzero on failure */
    int (*apply_event)(Model *M, const Logger *log);
    /* one integrator step in a moving mode; nonzero on failure */
    int (*take_step)(Model *M, const Logger *log);
    /* the ground tips the body resting at time t towards side */
    void (*start_moving)(Model *M, double t, int side, const Logger *log);
    /* called before each step or rest search (may be NULL) */
    void (*before_step)(Model *M, const Logger *log);
    /* contact reactions of the moving bodies (contact.h) */
    void (*reactions)(const Model *M, double t, int inStep, double T[2], double N[2]);
    /* when the bodies at rest start to move (NULL: the rigid uplift threshold, find_uplift) */
    RestExitFn rest_exit;
    /* once the bodies' run has ended (overturned): one step of what still moves (a two-way support; it may
     * step past tc, with a dense output); nonzero on failure. NULL: nothing moves, time jumps to tc */
    int (*ended)(Model *M, double tc, const Logger *log);
} SolverOps;

/* Advance M to tc: apply events once time reaches them, wait at rest for
 * uplift (find_uplift), step while moving, stay put once overturned.
 * Gives up with an error after MAX_STALLS passes in a row that leave the
 * time where it was (whatever the state, the loop ends). With stop (may be
 * NULL), returns early right after the first event that stop asks for. */
#define MAX_STALLS 1000
int advance_to(Model *M, double tc, const Logger *log, const SolverOps *ops, EventStop *stop);

#endif
