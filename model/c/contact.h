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

/* Reaction of the ground on one block rocking on a corner, from one evaluation
 * of its equation of motion: the rate omega, the acceleration alphaDD it gave
 * and its terms k. A block at rest (or lying overturned) moves with the ground:
 * omega = alphaDD = 0 and any k.sphi, k.cphi. */
void contact_one_block_terms(const Model *M, double omega, double alphaDD, const RhsTerms *k, double *T,
                             double *N);

/* Reactions of a stack in pattern `mode` with pivots s1, s2 at y =
 * (theta1, omega1, theta2, omega2) with angular accelerations acc: ground
 * on block 1 (Tg, Ng) and block 1 on block 2 (Ti, Ni). */
void contact_stack(const Model *M, Mode mode, int s1, int s2, const double y[4], const double acc[2],
                   double ah, double av, double *Tg, double *Ng, double *Ti, double *Ni);

/* Linear momenta relative to the ground (kg m/s) of block 1 and block 2 (0 with
 * one block, and for bodies at rest or overturned) in pattern mode with pivots
 * s1, s2 at y = (theta1, omega1[, theta2, omega2]). */
void contact_momenta(const Model *M, Mode mode, int s1, int s2, const double *y, double p[2][2]);
/* The blocks' mass times their centres of mass's horizontal displacement from rest relative to the ground, summed
 * (kg m): the integral of contact_momenta's horizontal momentum (the rigid models; 0 at rest). */
double contact_mass_moment(const Model *M, Mode mode, int s1, int s2, const double *y);

/* ---------------------------------------------------------------- monitors
 *
 * Whether the reactions stay within what the rigid-rocking model assumes:
 * |T| <= mu N (no sliding) and N >= 0 (no flight), at the ground [0] and, with
 * two blocks, at the interface [1]. advance_to (events.c) takes samples at the
 * start of every integrator step, just before and after every event, and at
 * every edge of the excitation's monotone cells while the bodies rest (where
 * the extremes of the rest reactions lie). A first sliding or lift-off between
 * two samples joined by a continuous motion is located by bisection on that
 * motion (the last step's dense output, or the rest reactions). */

/* The reactions of the bodies at time t: of the current state (inStep = 0), or,
 * for t inside the last step, of its dense output (inStep = 1). */
typedef void (*ReactionsFn)(const Model *M, double t, int inStep, double T[2], double N[2]);

/* The side towards which the ground tips a body resting at time t (1 or -1), or 0. */
int contact_tipping_side(const Model *M, double t);

/* Reactions of bodies resting on the ground (moving with it) at time t; bodies that the
 * ground tips at t itself (a step) carry those of the motion that starts there. */
void contact_rest(const Model *M, double t, int inStep, double T[2], double N[2]);

/* The reactions of the current state: at rest contact_rest's, else `moving`'s. */
void contact_now(const Model *M, ReactionsFn moving, double T[2], double N[2]);

/* A sample of the current state, whose moving bodies' reactions `moving`
 * gives. continuous: the motion since the last sample is the last step's
 * (or, at rest, the rest's), which locates a first violation between them. */
void contact_sample_state(Model *M, ReactionsFn moving, const Logger *log, int continuous);

/* Samples of bodies at rest at every edge of the excitation's monotone cells
 * in (t, end), and at end: the rest reactions take their extremes there. */
void contact_sample_rest(Model *M, double end, const Logger *log);

/* An impact at time t at the positions y, from the rates wm with pivots
 * (o1, o2) in pattern om to the rates wp with pivots (n1, n2) in pattern nm
 * (the impact map's, before any rest criterion stops the bodies): the impulses
 * from the change of momentum, on block 1 from the ground (the change of the
 * total momentum) and on block 2 from block 1 (in block 1's axes), and their
 * friction demand |tangential| / normal. */
void contact_impulse(Model *M, double t, const double *y, Mode om, int o1, int o2, const double wm[2],
                     Mode nm, int n1, int n2, const double wp[2], const Logger *log);

/* The monitor outputs at the output time: the samples so far and the
 * reactions already in v (contact.groundT ...). */
void contact_outputs(const Model *M, Variables *v);

#endif
