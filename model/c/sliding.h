/* Rocking-sliding of one block on the ground (contact.model = 1): the hybrid
 * automaton. Each mode has its equations of motion, the solver's event
 * indicators say when it ends, and the transitions below say which mode
 * follows. Derivation and assumptions: docs/sliding.md.
 *
 * State vector (RS_N components):
 *   y[0] theta (rad), y[1] omega (rad/s),
 *   y[RS_WORK] work of the ground's motion (J),
 *   y[RS_SLIP] slip u (m): x of the pivot corner minus its rest offset side * b,
 *        i.e. the base centre's displacement whenever the base is flat,
 *   y[RS_RATE] slip rate du/dt (m/s): the pivot's sliding velocity,
 *   y[RS_LOSS] work dissipated by friction (J).
 * A pivot that sticks integrates the first RS_N_ROCK components only (the others stay put).
 * Modes (State.mode, State.sigma): MODE_REST (stick, flat), MODE_SLIDE (flat,
 * sliding in direction sigma), MODE_ROCKING with sigma = 0 (rock: the pivot
 * sticks) or sigma = +-1 (slide-rock), MODE_OVERTURNED.
 * Coulomb friction with one coefficient mu = contact.muGround: a sliding
 * contact carries T = -sigma mu N.
 */
#ifndef ROCKING_SLIDING_H
#define ROCKING_SLIDING_H

#include "model.h"

#define RS_WORK 2
#define RS_SLIP 3
#define RS_RATE 4
#define RS_LOSS 5
#define RS_N 6
#define RS_N_ROCK 3
/* components under error control: theta, omega while the pivot sticks (the rigid
 * model's steps exactly), all of them while it slides */
#define RS_ERR_ROCK 2
#define RS_ERR_SLIDE RS_N

/* The motion left after an impact at time t (rate w, slip rate v of a flat block) is
 * negligible: the ground below the threshold that starts a block at rest, and a kinetic energy
 * that would lift the centre of mass less than a rebound to restRatio * alpha does. */
int sliding_negligible(const Model *M, double t, double w, double v);

/* Components a step integrates in mode (mode, sigma). */
int sliding_components(Mode mode, int sigma);

/* Nonzero for the rocking-sliding model. */
int sliding_on(const Model *M);

/* Derivatives dy[RS_N] in mode (mode, side, sigma) at (t, y); the equation of motion's
 * terms k (ground accelerations, sin and cos of phi = side alpha - theta) and, unless T is
 * NULL, the ground's reaction (T, N) in newtons. Returns the Painleve denominator of
 * slide-rock (> 0 where the mode has a unique solution; 1 in the other modes). */
double sliding_rhs(const Model *M, double t, const double *y, Mode mode, int side, int sigma, int piece,
                   double *dy, RhsTerms *k, double *T, double *N);

/* Energy (J): kinetic (rotation and the centre of mass's velocity relative to the
 * ground) plus m g times the rise of the centre of mass. */
double sliding_energy(const Model *M, const double *y, Mode mode, int side);
/* Horizontal momentum relative to the ground (kg m/s) of the block at y in mode with pivot side. */
double sliding_momentum(const Model *M, const double *y, Mode mode, int side);

/* Stick-to-slip indicator of a pivot that sticks: mu N - |T| (N). A pivot whose margin is
 * already negative (held in flight: N < 0, outside the model, flagged by the monitor lifts)
 * starts no slip until the margin has been >= 0 again. */
double sliding_stick_margin(const Model *M, double T, double N);

/* The mode a block at rest starts at time t when the ground exceeds
 * min(mu, tan alpha) (g + a_v) towards side: slide if mu <= tan alpha, else rock if
 * rocking's friction demand there is at most mu, else slide-rock. Sets *mode, *sigma. */
void sliding_start(const Model *M, double t, int side, Mode *mode, int *sigma);

/* A pivot that slid has stopped (slip rate 0) at time t in the state y (mode
 * MODE_ROCKING or MODE_SLIDE, side): the mode that follows (stick: rest or rock;
 * or a slip the other way). */
void sliding_stop(const Model *M, double t, const double *y, Mode mode, int side, Mode *next, int *sigma);

/* The slip of a rocking block's pivot at rest on the ground (slip rate 0) at (t, y): 0 if it
 * sticks (rock: N >= 0 and |T| <= mu N), else the direction of the slide-rock that is
 * consistent there (the ground pressing, the slip accelerating the way it slips); a pivot
 * with no consistent slide and N < 0 is held (flight, outside the model). */
int sliding_settle(const Model *M, double t, const double *y, int side);

/* The slip direction of a sticking pivot whose margin mu N - |T| has just reached zero at (t, y)
 * (a located stick-to-slip event, where the margin is zero to rounding). */
int sliding_slip_start(const Model *M, double t, const double *y, int side);

/* Impact at time t of a block landing at theta = 0 on the corner opposite `side`
 * with rate wm and slip rate vm. Writes the mode after it, the pivot, the slip
 * direction, the rate wp and slip rate vp, and the impulses (Pt, Pn) of the ground
 * (N s). Law: docs/sliding.md. */
void sliding_impact(const Model *M, double t, double wm, double vm, int side, Mode *mode, int *newSide,
                    int *sigma, double *wp, double *vp, double *Pt, double *Pn);

#endif
