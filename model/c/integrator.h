/* Dormand-Prince 5(4) step with dense output, and real-root isolation of
 * the dense-output polynomials (used to locate events).
 *
 * The integrator knows nothing about rocking: it advances y' = f(t, y) for
 * n <= NMAX components by one step and reports an error estimate and the
 * coefficients of the 4th-order continuous extension (Hairer, Norsett and
 * Wanner, Solving ODE I, section II.6).
 */
#ifndef ROCKING_INTEGRATOR_H
#define ROCKING_INTEGRATOR_H

/* Largest number of components. RockingBlock's: 41, the contact engine's two bodies (three coordinates
 * each and their rates, the ground's work, two friction losses, and two slips and their rates: 19) and a
 * two-way support (ten floors' displacements and velocities, its base work and damping loss: 22). A model with more defines NMAX before including
 * this header, in every file that does (ShearBuilding: model/c/building/building_integrator.c). */
#ifndef NMAX
#define NMAX 44
#endif

typedef void (*RhsFn)(const void *ctx, double t, const double *y, double *dy);

/* One step of size h from (t, y) with f0 = f(t, y). Writes y1 = y(t + h),
 * f1 = f(t + h, y1), the embedded error estimate err[] and the dense-output
 * coefficients cont[5][NMAX]. */
void dopri5_step(RhsFn f, const void *ctx, int n, double t, const double *y,
                 const double *f0, double h, double *y1, double *f1,
                 double *err, double cont[5][NMAX]);

/* Scaled RMS norm of err with weights atol + rtol * max(|y0|, |y1|). */
double dopri5_error_norm(int n, const double *y0, const double *y1,
                         const double *err, double rtol, double atol);

/* Dense output at s = (t - tOld) / h in [0, 1]. */
void dense_eval(const double cont[5][NMAX], int n, double s, double *y);

/* Power-basis coefficients c[0..4] in s of component i of the dense output. */
void dense_poly(const double cont[5][NMAX], int i, double c[5]);

/* Evaluate a polynomial of degree deg. */
double poly_eval(const double *c, int deg, double s);

/* All real roots of the polynomial c (degree <= 4) in [lo, hi], ascending,
 * isolated by recursion on the derivative (so no pair of close roots is
 * missed) and refined by bracketing to machine precision. Returns the
 * number of roots (at most deg). */
int poly_roots(const double *c, int deg, double lo, double hi, double *roots);

/* Largest |component comp| of a dense output over s in [0, sEnd] (its end values and the
 * quartic's interior extremes). */
double dense_abs_max(const double cont[5][NMAX], int comp, double sEnd);

/* Initial step size guess (Hairer's algorithm, simplified). */
double dopri5_initial_step(RhsFn f, const void *ctx, int n, double t,
                           const double *y, const double *f0, double rtol,
                           double atol, double hmax);

#endif
