/* Contact reactions the rigid-rocking model needs to hold: the force of the
 * ground on block 1 and, with two blocks, of block 1 on block 2, from Newton's
 * second law for each centre of mass with the accelerations the equations of
 * motion give (derivation: docs/contact.md).
 *
 * Signs (docs/conventions.md): the ground reaction (T, N) is in the ground's
 * axes, T positive towards +x, N positive upwards (compression). The
 * interface reaction is the force of block 1 on block 2 in block 1's axes:
 * T along block 1's top surface (its +x axis turned with it), N along its
 * outward normal. Newtons.
 */
#ifndef ROCKING_CONTACT_H
#define ROCKING_CONTACT_H

#include "model.h"

/* Reaction of the ground on one block: rocking on the corner `side` at
 * (theta, omega) with angular acceleration alphaDD, or at rest / lying
 * overturned (moving = 0: it moves with the ground), under the total ground
 * acceleration (ah, av). */
void contact_one_block(const Model *M, int moving, double theta, double omega, double alphaDD,
                       int side, double ah, double av, double *T, double *N);

/* Reactions of a stack in pattern `mode` with pivots s1, s2 at y =
 * (theta1, omega1, theta2, omega2) with angular accelerations acc: ground
 * on block 1 (Tg, Ng) and block 1 on block 2 (Ti, Ni). */
void contact_stack(const Model *M, Mode mode, int s1, int s2, const double y[4], const double acc[2],
                   double ah, double av, double *Tg, double *Ng, double *Ti, double *Ni);

#endif
