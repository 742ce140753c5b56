/* Taylor-series integration of one rocking block (solver.method = 1, and the default 2 = auto
 * for one block in rigid rocking).
 *
 * Between events the block obeys theta'' = -(m R / I0) [ (g + a_v) sin(phi)
 * + a_h cos(phi) ], phi = s alpha - theta, with a_h, a_v sines or cosines of
 * time (or constants). The Taylor coefficients of theta about t follow from
 * the recurrences of sin and cos of a series (automatic differentiation), so
 * a step of any order N costs O(N^2) operations and two sincos calls, and
 * the series itself is the dense output. The step length comes from the
 * size of the last two coefficients (Jorba and Zou's rule); events are
 * located on the series.
 */
#ifndef ROCKING_TAYLOR_H
#define ROCKING_TAYLOR_H

#include "model.h"

/* 1 if the Taylor series integrates the model M: solver.method = 1, or the default
 * solver.method = 2 (auto) for one block in rigid rocking (contact.model = 0) under any
 * excitation but a record; a stack, rocking-sliding and a record (whose samples cut every
 * step, where Dormand-Prince's cheaper steps cost less) are Dormand-Prince's. */
int taylor_on(const Model *M);

/* Order used for the tolerance rtol: ceil(-0.6 ln rtol) + 8, within 10 to TAYLOR_MAX. */
int taylor_order(double rtol);

/* Coefficients x[0..N] of theta(t + s) = sum x[k] s^k for pivot side and
 * excitation piece, from theta, omega at t. */
void taylor_series(const Model *M, double t, double theta, double omega, int side, int piece, int N,
                   double *x);

/* Step length (s) for an error per step of about eps in theta and omega. */
double taylor_step(const double *x, int N, double eps);

/* theta and omega at s from the coefficients. */
void taylor_eval(const double *x, int N, double s, double *theta, double *omega);

/* First s in (0, h] where sign * (theta(s) - target) (comp 0) or sign * omega(s)
 * (comp 1) crosses zero with the given slope (-1 falling, +1 rising); > h if none.
 * Ruled out at once where the polynomial's linear part keeps its sign by more than
 * the other terms can change it; solved on the whole step where its derivative is
 * ruled out the same way (monotone); else found on `samples` sub-intervals. Refined
 * by regula falsi (Illinois). */
double taylor_first_crossing(const double *x, int N, double h, int comp, double sign, double target,
                             int slope, int samples);

/* The s in [a, b] where theta(s) = target, given that theta - target changes sign from a to b
 * (to machine precision: the end beyond target). */
double taylor_solve(const double *x, int N, double a, double b, double target);

#endif
