/* Rocking-sliding of two stacked blocks (contact.model = 1, nBlocks = 2): the
 * hybrid automaton of both contacts. Derivation and every rule: docs/stack_sliding.md.
 *
 * Each contact (the ground under block 1, block 1's top under block 2) is flat
 * or rocks on its corner s (+1 right, -1 left), and sticks (sigma = 0) or slides
 * (sigma = +-1, the sign of its slip rate). A combined pattern is one 10 x 10
 * linear system: Newton-Euler on both blocks (six rows) and two rows per
 * contact, in the unknowns (u1'', theta1'', u2'', theta2'', T0, N0, M0, T1, N1, M1).
 *
 * State vector (SS_N components): the rigid stack's four first,
 *   y[0] theta1, y[1] omega1, y[2] theta2, y[3] omega2 (rad, rad/s, absolute),
 *   y[SS_WORK] work of the ground's motion (J),
 *   y[SS_U1], y[SS_V1] block 1's slip on the ground (m) and its rate (m/s),
 *   y[SS_U2], y[SS_V2] block 2's slip along block 1's top (m, block 1's frame) and its rate,
 *   y[SS_LOSS1], y[SS_LOSS2] work dissipated by friction at the ground and between the blocks (J).
 */
#ifndef ROCKING_STACK_SLIDING_H
#define ROCKING_STACK_SLIDING_H

#include <stddef.h>

#include "model.h"

#define SS_WORK 4
#define SS_U1 5
#define SS_V1 6
#define SS_U2 7
#define SS_V2 8
#define SS_LOSS1 9
#define SS_LOSS2 10
#define SS_N 11

/* Nonzero for the rocking-sliding stack (nBlocks = 2, contact.model = 1). */
int ss_on(const Model *M);

/* Generalised positions q = (u1, theta1, u2, theta2) and rates of a state vector. */
void ss_qw(const double *y, double q[4], double w[4]);

/* A solved pattern: generalised accelerations and contact forces (N, N m): T0, N0, M0 on
 * block 1 from the ground at its pivot; T1, N1, M1 on block 2 from block 1 at block 2's
 * pivot (T along block 1's top, N normal to it, M clockwise). */
typedef struct {
    double qdd[4];
    double F[6];
} SsSolution;

/* Solve pattern p at (q, w) under the ground accelerations (ah, av). Returns 0 if the
 * system is singular. */
int ss_solve(const Model *M, const StackPattern *p, const double q[4], const double w[4], double ah, double av,
             SsSolution *sol);

/* Normalised indicators of a solved pattern (each >= 0 while the pattern holds; +INFINITY where
 * a contact has no such indicator): 0 ground N, 1 interface N, 2/3 ground right/left end
 * margins, 4/5 interface right/left, 6 ground friction margin, 7 interface friction margin. */
#define SS_IND 8
void ss_indicators(const Model *M, const StackPattern *p, const double q[4], const SsSolution *sol,
                   double ind[SS_IND]);

/* Whether the solved pattern obeys the contact laws at (q, w) (docs/stack_sliding.md,
 * "Consistency of a pattern"). */
int ss_consistent(const Model *M, const StackPattern *p, const double q[4], const double w[4],
                  const SsSolution *sol, int allowOverhang);

/* Exclusions when choosing a pattern at an event: bit 1 "not flat", bit 2 "not sticking",
 * per contact (index 0 ground, 1 interface). */
#define SS_NOT_FLAT 1
#define SS_NOT_STICK 2
#define SS_NOT_ROCK 4  /* flat only */
#define SS_NOT_PLUS 4  /* not sliding with sigma = +1 */
#define SS_NOT_MINUS 8 /* not sliding with sigma = -1 */

/* The first consistent pattern, least motion first, at (t, q, w); 0 if none. */
int ss_select(const Model *M, double t, const double q[4], const double w[4], const int exclude[2], int allowRest,
              int allowOverhang, StackPattern *out);

/* Nonzero if p is the rest pattern (both contacts flat and sticking). */
int ss_is_rest(const StackPattern *p);

/* Right-hand side of the state vector in pattern p (rocking-sliding stack). Returns 0 if
 * the pattern's system is singular. Writes the solution if sol is not NULL. */
int ss_rhs(const Model *M, const StackPattern *p, double t, const double *y, int piece, double *dy, SsSolution *sol);

/* Kinetic energy (J) relative to the ground, and kinetic plus potential energy (zero at rest). */
double ss_kinetic(const Model *M, const double q[4], const double w[4], int s1, int s2);
double ss_energy(const Model *M, const double *y, const StackPattern *p);
/* Horizontal momentum relative to the ground (kg m/s) of both blocks at y in pattern p. */
double ss_momentum(const Model *M, const double *y, const StackPattern *p);

/* An impact of the contact `landing` (0 ground, 1 interface) in pattern p at positions q with
 * rates w: writes the pattern and rates after it. Returns 0 if no consistent impact exists
 * (flight), 1 if consistent, 2 if a contact had to be held (logged "held"). */
int ss_impact(const Model *M, int landing, const StackPattern *p, const double q[4], const double w[4],
              StackPattern *out, double wp[4], double impulses[6]);

/* Rebound rate (rad/s) below which a landing contact closes (docs/two_blocks.md). */
double ss_settle_rate(const Model *M, int contact, double av);

/* Close the rocking contacts `closing` (bit 0 ground, bit 1 interface) by a plastic impact onto
 * the pattern in which they are flat (each contact keeping its friction mode). */
void ss_close(const Model *M, const StackPattern *p, const double q[4], const double w[4], int closing,
              StackPattern *out, double wp[4]);

/* The solver of the rocking-sliding stack (stack_sliding_solver.c): what stack_solver.h's
 * functions of the same names do for the rigid stack. */
void ss_initialize(Model *M);
int ss_advance(Model *M, double tc, const Logger *log, EventStop *stop);
void ss_outputs(Model *M, double tc);
void ss_rollback(Model *M, double tc);
void ss_state_rhs(const Model *M, double f[NMAX]);
void ss_replay_step(const Model *M, double y1[NMAX], double f1[NMAX], double cont[5][NMAX]);

/* Checks of a restored state's rocking-sliding stack fields: 0, or 1 with a one-line reason. */
int ss_check_state(const Model *M, char *msg, size_t n);

/* A readable label of a pattern, e.g. "rock/slide-rock". */
const char *ss_label(const StackPattern *p, char buf[40]);

#endif
