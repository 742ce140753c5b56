/* Two stacked rocking blocks: equations of motion, contact reactions and
 * the impact map (derivation in docs/two_blocks.md).
 *
 * State y = (theta1, omega1, theta2, omega2): absolute clockwise rotations of
 * the lower block 1 and the upper block 2 (rad) and their rates (rad/s).
 * Pivot indicators: s1 = +1/-1 when block 1 turns about its bottom right /
 * left corner on the ground, s2 = +1/-1 when block 2 turns about the right /
 * left end of its contact with block 1 (half width c = min(b1, b2)).
 *
 * A pattern says which contacts are open:
 *   MODE_REST    both contacts closed (nothing moves),
 *   MODE_UPPER   block 1 flat on the ground, block 2 rocks on it (s2),
 *   MODE_LOCKED  block 2 seated on block 1, the pair rocks as one body (s1),
 *   MODE_BOTH    both rock (s1, s2).
 * A closed contact is admissible while its reaction can be carried inside
 * the contact: the reaction moment about either end pushes the bodies apart,
 * never pulls them together (docs/two_blocks.md, "Contact reactions").
 */
#ifndef ROCKING_STACK_H
#define ROCKING_STACK_H

#include "model.h"

/* Derive the stack's constant quantities into M->d (parameters valid). */
void stack_derive(const Variables *v, Derived *d);

/* Angular accelerations (theta1'', theta2'') of the pattern at state y for
 * the ground accelerations ah, av (m/s^2). */
void stack_accel(const Model *M, Mode mode, int s1, int s2, const double y[4],
                 double ah, double av, double acc[2]);

/* Right-hand side dy/dt of the pattern (y as above). */
void stack_rhs(const Model *M, Mode mode, int s1, int s2, double t, const double y[4],
               int piece, double dy[4]);

/* stack_rhs and, in dy[4], the power (W) of the ground's motion on the stack: minus the rate of
 * the potential of the field (ah, av) at fixed accelerations (the rocking-sliding stack's work
 * integral while nothing slides). */
void stack_rhs_work(const Model *M, Mode mode, int s1, int s2, double t, const double y[4], int piece,
                    double dy[5]);

/* Reaction margins of the closed contacts of the pattern, per end of the
 * contact (index 0: right end, 1: left end), normalised by the weight times
 * the half width of the contact. A margin is the moment the contact must
 * supply about that end to keep the bodies from turning into each other:
 * >= 0 while the contact holds, < 0 once it would have to pull, at which
 * point the contact opens about that end. Open contacts give +INFINITY.
 * ground: block 1 on the ground; interface: block 2 on block 1. */
void stack_margins(const Model *M, Mode mode, int s1, int s2, const double y[4],
                   double ah, double av, double ground[2], double interface[2]);

/* Impact map (conservation of momentum): post-impact rates wPlus of the
 * pattern (mode, n1, n2) from the pre-impact rates wMinus with pivots
 * (o1, o2), at the positions y. Impulses act only where the bodies touch in
 * the new pattern, so the map is the mass-weighted projection of the
 * velocity field onto the motions the new pattern allows. Returns 1 if the
 * impulses on the closed contacts of the new pattern push at both ends of
 * the contact (the pattern is admissible), 0 otherwise. */
int stack_impact(const Model *M, Mode mode, int n1, int n2, int o1, int o2,
                 const double y[4], const double wMinus[2], double wPlus[2]);

/* A closed contact opens once its margin (stack_margins) falls below -STACK_TOL_OPEN: a reaction
 * moment 1e-9 of weight times contact half width. */
#define STACK_TOL_OPEN 1e-9

/* Smallest reaction margin of the pattern's closed contacts at (y, ah, av), and which contact (0 ground,
 * 1 interface) and end (+1, -1) it belongs to. */
double stack_weakest(const Model *M, Mode mode, int s1, int s2, const double y[4], double ah, double av,
                     int *contact, int *end);

/* Whether the pattern is admissible at (y, ah, av): its closed contacts hold and every open contact with
 * zero gap and zero gap rate accelerates open. */
int stack_admissible(const Model *M, Mode mode, int s1, int s2, const double y[4], double ah, double av);

/* The pattern a stack resting at time t starts in when the ground tips it towards side:
 * the most settled admissible one (locked, upper, both), from theta = omega = 0. */
Mode stack_start_pattern(const Model *M, double t, int side);

/* Kinetic energy (J) of rates w with pivots s1, s2. */
double stack_kinetic(const Model *M, int s1, int s2, const double y[4], const double w[2]);

/* Kinetic plus gravitational potential energy (J), zero at rest. */
double stack_energy(const Model *M, int s1, int s2, const double y[4]);

#endif
