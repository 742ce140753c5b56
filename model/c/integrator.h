/* Dormand-Prince 5(4) and 8(5,3) steps with dense output, and real-root
 * isolation of the dense-output polynomials (used to locate events).
 *
 * The integrator knows nothing about rocking: it advances y' = f(t, y) for
 * n <= NMAX components by one step and reports an error estimate and the
 * coefficients of its continuous extension, of degree 4 (DOPRI5) or 7
 * (DOP853) (Hairer, Norsett and Wanner, Solving ODE I, sections II.5-II.6).
 */
#ifndef ROCKING_INTEGRATOR_H
#define ROCKING_INTEGRATOR_H

/* Largest number of components. RockingBlock's: 95, the contact engine's column of eight bodies (three
 * coordinates each and their rates, the ground's work, eight friction losses, eight slips and their rates:
 * EN_N(8) = 73) and a two-way support (ten floors' displacements and velocities, its base work and damping
 * loss: 22). A model with more defines NMAX before including this header, in every file that does
 * (ShearBuilding: model/c/building/building_integrator.c). */
#ifndef NMAX
#define NMAX 96
#endif

typedef void (*RhsFn)(const void *ctx, double t, const double *y, double *dy);

/* The methods: Dormand and Prince's 5(4) pair, and Dormand and Prince's 8(5,3) (Hairer's DOP853). */
enum { RK_DOPRI5 = 0, RK_DOP853 = 1 };

/* A step's dense output: rows r[0..4] (DOPRI5, Hairer's contd5) or r[0..7] (DOP853, contd8) of the nested form
 * y(s) = r0 + s (r1 + (1 - s) (r2 + s (r3 + (1 - s) (r4 + ...)))), s = (t - tOld) / h in [0, 1]. The rows a method
 * does not use are 0. */
#define DENSE_ROWS 8
typedef struct {
    int method, rows; /* (two ints: no padding, so that two dense outputs compare by their bytes) */
    double r[DENSE_ROWS][NMAX];
} Dense;

/* A DOP853 step's stages, which its dense output needs (dop853_dense). */
typedef struct {
    int nRanges, lo[2], hi[2]; /* set by the caller: the components that vary, lo[r]..hi[r]-1 (nRanges 0: all) */
    int n;
    double t, h;
    double k[16][NMAX];
} Dop853Stages;

/* One step of size h from (t, y) with f0 = f(t, y). Writes y1 = y(t + h),
 * f1 = f(t + h, y1) (the last evaluation), the embedded error estimate err[] and the dense output d. */
void dopri5_step(RhsFn f, const void *ctx, int n, double t, const double *y,
                 const double *f0, double h, double *y1, double *f1,
                 double *err, Dense *d);

/* One DOP853 step, as dopri5_step: the error estimates of orders 5 and 3 (err5, err3; dop853_error_norm combines
 * them), and the stages in st. Only the components in st's ranges vary (none given: all n); f must give the
 * others derivative 0, and they keep their values. f1 = f(t + h, y1) is the last evaluation; d holds rows
 * 0..3 only (dense output of degree 3) until dop853_dense completes it. */
void dop853_step(RhsFn f, const void *ctx, int n, double t, const double *y, const double *f0, double h, double *y1,
                 double *f1, double *err5, double *err3, Dense *d, Dop853Stages *st);

/* The dense output of degree 7 of the DOP853 step st (three more evaluations of f, after the step's last). */
void dop853_dense(RhsFn f, const void *ctx, Dop853Stages *st, Dense *d);

/* Scaled RMS norm of err with weights atol + rtol * max(|y0|, |y1|). */
double dopri5_error_norm(int n, const double *y0, const double *y1,
                         const double *err, double rtol, double atol);

/* DOP853's error norm (Hairer's: |err5|^2 / sqrt(|err5|^2 + 0.01 |err3|^2), RMS) with the weights
 * atol * scale[i] + rtol * max(|y0|, |y1|) (scale NULL: all 1; a component with scale[i] = 0 is not counted). */
double dop853_error_norm(int n, const double *scale, const double *y0, const double *y1, const double *err5,
                         const double *err3, double rtol, double atol);

/* to = from on the first n components of its rows (the others of to kept). */
void dense_copy(Dense *to, const Dense *from, int n);

/* Dense output at s = (t - tOld) / h in [0, 1]. */
void dense_eval(const Dense *d, int n, double s, double *y);

/* Power-basis coefficients c[0..deg] in s of component i of the dense output; returns deg (4 or 7). */
int dense_poly(const Dense *d, int i, double c[DENSE_ROWS]);

/* Evaluate a polynomial of degree deg. */
double poly_eval(const double *c, int deg, double s);

/* All real roots of the polynomial c (degree <= 7) in [lo, hi], ascending,
 * isolated by recursion on the derivative (so no pair of close roots is
 * missed) and refined by bracketing to machine precision. Returns the
 * number of roots (at most deg). */
int poly_roots(const double *c, int deg, double lo, double hi, double *roots);

/* Largest |component comp| of a dense output over s in [0, sEnd] (its end values and the
 * polynomial's interior extremes). */
double dense_abs_max(const Dense *d, int comp, double sEnd);

/* Initial step size guess (Hairer's algorithm, simplified). */
double dopri5_initial_step(RhsFn f, const void *ctx, int n, double t,
                           const double *y, const double *f0, double rtol,
                           double atol, double hmax);

#endif
