/* ShearBuilding's model (building.h): parameters, natural frequencies, Rayleigh damping,
 * derivatives, the integration of a communication step, energy and outputs. No globals. */
#include "building.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#define TWO_PI 6.283185307179586
#define MAX_GROUND_ACCELERATION 1000.0 /* m/s2, about 100 g: a scaled record beyond is a mistake */
#define MAX_STEPS 100000000L           /* accepted and rejected steps of one communication step */

#define FAIL(...)                        \
    do {                                 \
        snprintf(msg, n, __VA_ARGS__);   \
        return 1;                        \
    } while (0)

void building_defaults(BuildingVars *v) {
    memset(v, 0, sizeof(*v));
    v->nStoreys = 3;
    for (int i = 0; i < BUILDING_MAX_STOREYS; i++) {
        v->mass[i] = 1e4;
        v->stiffness[i] = 1e7;
    }
    v->dampingRatio = 0.05;
    v->scale = 1.0;
    v->startTime = 0.0;
    v->relTol = 1e-10;
    v->absTol = 1e-12;
}

int building_validate(const BuildingVars *v, char *msg, size_t n) {
    if (v->nStoreys < 1 || v->nStoreys > BUILDING_MAX_STOREYS)
        FAIL("nStoreys = %d must be in [1, %d]", v->nStoreys, BUILDING_MAX_STOREYS);
    for (int i = 0; i < v->nStoreys; i++) {
        if (!(v->mass[i] > 0 && isfinite(v->mass[i])))
            FAIL("storey[%d].mass = %g kg must be > 0 (storey %d of nStoreys = %d)", i + 1, v->mass[i], i + 1,
                 v->nStoreys);
        if (!(v->carriedMass[i] >= 0 && isfinite(v->carriedMass[i])))
            FAIL("storey[%d].carriedMass = %g kg must be >= 0", i + 1, v->carriedMass[i]);
        if (!(v->stiffness[i] > 0 && isfinite(v->stiffness[i])))
            FAIL("storey[%d].stiffness = %g N/m must be > 0 (storey %d of nStoreys = %d)", i + 1, v->stiffness[i],
                 i + 1, v->nStoreys);
    }
    double fmax_ = building_highest_frequency(v->nStoreys, v->mass, v->stiffness) / TWO_PI;
    if (!(fmax_ <= BUILDING_MAX_FREQUENCY))
        FAIL("the highest natural frequency, %g Hz, is above %g Hz: check the storeys' masses (kg) and "
             "stiffnesses (N/m); the integrator would need millions of steps per second", fmax_,
             BUILDING_MAX_FREQUENCY);
    if (!(v->dampingRatio >= 0 && v->dampingRatio < 1))
        FAIL("damping.ratio = %g must be in [0, 1)", v->dampingRatio);
    if (!isfinite(v->scale)) FAIL("excitation.scale = %g must be a finite number", v->scale);
    if (!(fabs(v->startTime) <= RECORD_MAX_TIME))
        FAIL("excitation.startTime = %g s must be a finite time within %g s", v->startTime, RECORD_MAX_TIME);
    if (!(v->relTol >= BUILDING_REL_TOL_MIN && v->relTol <= BUILDING_REL_TOL_MAX))
        FAIL("solver.relTol = %g must be in [%g, %g]", v->relTol, BUILDING_REL_TOL_MIN, BUILDING_REL_TOL_MAX);
    if (!(v->absTol > 0 && v->absTol <= BUILDING_ABS_TOL_MAX))
        FAIL("solver.absTol = %g must be in (0, %g] (m, m/s, J)", v->absTol, BUILDING_ABS_TOL_MAX);
    for (int i = v->nStoreys; i < BUILDING_MAX_STOREYS; i++)
        if (v->force[i] != 0.0)
            FAIL("storey[%d].force = %g N acts on a storey the building does not have (nStoreys = %d)", i + 1,
                 v->force[i], v->nStoreys);
    return 0;
}

int building_validate_record(const BuildingVars *v, const Record *rec, char *msg, size_t n) {
    if (rec && !(fabs(v->scale) * rec->peak <= MAX_GROUND_ACCELERATION))
        FAIL("excitation.scale = %g brings the record's peak acceleration to %g m/s2, beyond %g m/s2 (about 100 g)",
             v->scale, fabs(v->scale) * rec->peak, MAX_GROUND_ACCELERATION);
    return 0;
}

/* ------------------------------------------------------------ frequencies */

/* Number of eigenvalues below x of the symmetric tridiagonal (d, e) (e[i] couples i and i+1):
 * the negative pivots of the LDL^T factorisation of T - x I (Sturm sequence). */
static int sturm_count(int n, const double *d, const double *e, double x) {
    int count = 0;
    double q = 1.0;
    for (int i = 0; i < n; i++) {
        double off = i > 0 ? e[i - 1] * e[i - 1] / q : 0.0;
        q = d[i] - x - off;
        if (q == 0.0) q = -DBL_EPSILON * (fabs(d[i]) + fabs(x) + DBL_MIN);
        if (q < 0) count++;
    }
    return count;
}

/* M^-1/2 K M^-1/2 as (d, e), and the Gershgorin bound of its eigenvalues (each is in (0, hi]). */
static double tridiagonal(int n, const double *m, const double *k, double *d, double *e) {
    double hi = 0.0;
    for (int i = 0; i < n; i++) {
        double kAbove = i + 1 < n ? k[i + 1] : 0.0;
        d[i] = (k[i] + kAbove) / m[i];
        e[i] = i + 1 < n ? -k[i + 1] / sqrt(m[i] * m[i + 1]) : 0.0;
    }
    for (int i = 0; i < n; i++)
        hi = fmax(hi, d[i] + fabs(e[i]) + (i > 0 ? fabs(e[i - 1]) : 0.0));
    return hi;
}

/* The (j + 1)-th smallest eigenvalue of (d, e) in (0, hi], by bisection to adjacent doubles. */
static double eigenvalue(int n, const double *d, const double *e, double hi, int j) {
    double lo = 0.0, up = hi * (1.0 + 4.0 * DBL_EPSILON);
    for (int it = 0; it < 2000; it++) {
        double mid = 0.5 * (lo + up);
        if (!(mid > lo && mid < up)) break;
        if (sturm_count(n, d, e, mid) > j) up = mid;
        else lo = mid;
    }
    return 0.5 * (lo + up);
}

void building_frequencies(int n, const double *m, const double *k, double omega[2]) {
    double d[BUILDING_MAX_STOREYS], e[BUILDING_MAX_STOREYS];
    double hi = tridiagonal(n, m, k, d, e);
    for (int j = 0; j < 2 && j < n; j++) omega[j] = sqrt(eigenvalue(n, d, e, hi, j));
    if (n == 1) omega[1] = omega[0];
}

double building_highest_frequency(int n, const double *m, const double *k) {
    double d[BUILDING_MAX_STOREYS], e[BUILDING_MAX_STOREYS];
    double hi = tridiagonal(n, m, k, d, e);
    return isfinite(hi) ? sqrt(eigenvalue(n, d, e, hi, n - 1)) : INFINITY;
}

/* ------------------------------------------------------------- excitation */

/* Time of record sample i, placed at excitation.startTime. */
static double sample_time(const Building *B, int i) { return B->v.startTime + B->rec->t[i]; }

/* The piece of the base acceleration that starts at or before t and goes on after it:
 * 0 before the first sample, p (1..n-1) between samples p-1 and p, n after the last. */
static int piece_at(const Building *B, double t) {
    const Record *r = B->rec;
    if (!r) return 0;
    if (t < sample_time(B, 0)) return 0;
    if (t >= sample_time(B, r->n - 1)) return r->n;
    int lo = 0, hi = r->n - 1; /* sample_time(lo) <= t < sample_time(hi) */
    while (hi - lo > 1) {
        int mid = lo + (hi - lo) / 2;
        if (sample_time(B, mid) <= t) lo = mid;
        else hi = mid;
    }
    return lo + 1;
}

/* Where piece p ends: a break point of the integration. */
static double piece_end(const Building *B, int p) {
    if (!B->rec || p >= B->rec->n) return INFINITY;
    return sample_time(B, p);
}

/* The record's part of a_g on piece p, at t (linear in t: extended past the piece's ends, so
 * that the integrator's stages see one smooth function). */
static double piece_value(const Building *B, int p, double t) {
    const Record *r = B->rec;
    if (!r || p <= 0 || p >= r->n) return 0.0;
    double t0 = sample_time(B, p - 1), t1 = sample_time(B, p);
    double s = (t - t0) / (t1 - t0);
    return B->v.scale * (r->ah[p - 1] + s * (r->ah[p] - r->ah[p - 1]));
}

double building_ground(const Building *B, double t) {
    const Record *r = B->rec;
    double rec = 0.0;
    if (r && t >= sample_time(B, 0) && t <= sample_time(B, r->n - 1))
        rec = t == sample_time(B, r->n - 1) ? B->v.scale * r->ah[r->n - 1] : piece_value(B, piece_at(B, t), t);
    return rec + B->v.baseA;
}

/* -------------------------------------------------------------- dynamics */

/* K x of the shear building (x: n floor values relative to the base). */
static void stiffness_times(int n, const double *k, const double *x, double *out) {
    for (int i = 0; i < n; i++) {
        double below = i > 0 ? x[i] - x[i - 1] : x[i];
        double above = i + 1 < n ? k[i + 1] * (x[i + 1] - x[i]) : 0.0;
        out[i] = k[i] * below - above;
    }
}

/* Restoring and damping forces K u + C u' on the floors. */
static void internal_forces(const Building *B, const double *u, const double *v, double *out) {
    int n = B->n;
    double ku[BUILDING_MAX_STOREYS], kv[BUILDING_MAX_STOREYS];
    stiffness_times(n, B->v.stiffness, u, ku);
    stiffness_times(n, B->v.stiffness, v, kv);
    for (int i = 0; i < n; i++) out[i] = ku[i] + B->a0 * B->v.mass[i] * v[i] + B->a1 * kv[i];
}

double building_force(const Building *B, int i, double t) {
    return B->v.force[i] + (B->dForce[i] != 0.0 ? B->dForce[i] * (t - B->forceT0[i]) : 0.0);
}

typedef struct {
    const Building *B;
    int piece;
} Rhs;

static void rhs(const void *ctx, double t, const double *y, double *dy) {
    const Rhs *c = (const Rhs *)ctx;
    const Building *B = c->B;
    int n = B->n;
    const double *u = y, *v = y + n;
    double ag = piece_value(B, c->piece, t) + B->v.baseA;
    double ku[BUILDING_MAX_STOREYS], kv[BUILDING_MAX_STOREYS];
    stiffness_times(n, B->v.stiffness, u, ku);
    stiffness_times(n, B->v.stiffness, v, kv);
    double baseWork = 0.0, forceWork = 0.0, damping = 0.0;
    for (int i = 0; i < n; i++) {
        double m = B->v.mass[i] + B->v.carriedMass[i]; /* inertia */
        double cv = B->a0 * B->v.mass[i] * v[i] + B->a1 * kv[i];
        dy[i] = v[i];
        double F = building_force(B, i, t);
        dy[n + i] = (F - cv - ku[i]) / m - ag;
        baseWork -= ag * m * v[i];
        forceWork += F * v[i];
        damping += v[i] * cv;
    }
    dy[2 * n] = baseWork;
    dy[2 * n + 1] = forceWork;
    dy[2 * n + 2] = damping;
}

void building_start(Building *B, const Record *rec, double t0) {
    BuildingVars *v = &B->v;
    B->n = v->nStoreys;
    B->rec = rec;
    building_frequencies(B->n, v->mass, v->stiffness, B->omega);
    double w1 = B->omega[0], w2 = B->omega[1], z = v->dampingRatio;
    if (B->n == 1) {
        B->a0 = 0.0; /* stiffness-proportional: the storey's own dashpot, C = 2 zeta w1 m */
        B->a1 = 2.0 * z / w1;
    } else {
        B->a0 = 2.0 * z * w1 * w2 / (w1 + w2);
        B->a1 = 2.0 * z / (w1 + w2);
    }
    v->frequency1 = w1 / TWO_PI;
    v->frequency2 = w2 / TWO_PI;
    B->t = t0;
    memset(B->y, 0, sizeof(B->y));
    B->h = 0.0;
    memset(B->dForce, 0, sizeof(B->dForce));
    memset(B->forceT0, 0, sizeof(B->forceT0));
    B->steps = 0;
    building_outputs(B);
}

int building_advance(Building *B, double target, char *msg, size_t n) {
    int dim = 2 * B->n + 3;
    double rtol = B->v.relTol, atol = B->v.absTol;
    double f0[NMAX], y1[NMAX], f1[NMAX], err[NMAX];
    Dense cont; /* (not used: the building is sampled at step ends) */
    long tries = 0;
    while (B->t < target) {
        Rhs ctx = {B, piece_at(B, B->t)};
        double tb = fmin(target, piece_end(B, ctx.piece));
        if (!(tb > B->t)) FAIL("no progress at t = %.17g (break point %.17g)", B->t, tb);
        rhs(&ctx, B->t, B->y, f0);
        if (!(B->h > 0)) B->h = dopri5_initial_step(rhs, &ctx, dim, B->t, B->y, f0, rtol, atol, tb - B->t);
        while (B->t < tb) {
            double rest = tb - B->t, h = B->h;
            int last = 0;
            if (h >= rest) {
                h = rest;
                last = 1;
            } else if (h > 0.5 * rest) {
                h = 0.5 * rest; /* two even steps, not one and a sliver */
            }
            if (++tries > MAX_STEPS)
                FAIL("more than %ld steps in one communication step at t = %.17g", MAX_STEPS, B->t);
            dopri5_step(rhs, &ctx, dim, B->t, B->y, f0, h, y1, f1, err, &cont);
            double e = dopri5_error_norm(dim, B->y, y1, err, rtol, atol);
            if (!isfinite(e)) e = 1e10;
            double fac = e == 0.0 ? 5.0 : fmin(5.0, fmax(0.2, 0.9 * pow(e, -0.2)));
            if (e <= 1.0) {
                B->t = last ? tb : B->t + h;
                memcpy(B->y, y1, sizeof(double) * (size_t)dim);
                memcpy(f0, f1, sizeof(double) * (size_t)dim);
                B->steps++;
                /* a step cut short at a break point says nothing against the proposal */
                if (!(last && h < B->h)) B->h = h * fac;
            } else {
                B->h = h * fac;
            }
            if (!(B->h > 16.0 * DBL_EPSILON * fmax(1.0, fabs(B->t))))
                FAIL("step size %g underflows at t = %.17g (solver.relTol, solver.absTol too small?)", B->h, B->t);
        }
    }
    building_outputs(B);
    return 0;
}

int building_output_derivative(const Building *B, const double *p, double *d) {
    const BuildingVars *v = &B->v;
    int n = B->n;
    for (int i = 0; i < n; i++) {
        if (p == &v->u[i]) {
            *d = v->v[i];
            return 0;
        }
        if (p != &v->v[i] && p != &v->a[i] && p != &v->structureForce[i]) continue;
        double ag = building_ground(B, B->t), w[BUILDING_MAX_STOREYS], f[BUILDING_MAX_STOREYS];
        for (int j = 0; j < n; j++) w[j] = v->a[j] - ag; /* u'' */
        if (p == &v->v[i]) {
            *d = w[i];
            return 0;
        }
        internal_forces(B, v->v, w, f); /* K u' + C u'' */
        *d = p == &v->structureForce[i] ? -f[i] : (B->dForce[i] - f[i]) / (v->mass[i] + v->carriedMass[i]);
        return 0;
    }
    return 1;
}

void building_outputs(Building *B) {
    BuildingVars *v = &B->v;
    int n = B->n;
    const double *u = B->y, *vel = B->y + n;
    double f[BUILDING_MAX_STOREYS];
    internal_forces(B, u, vel, f);
    double shear = 0.0, kinetic = 0.0, strain = 0.0;
    for (int i = 0; i < BUILDING_MAX_STOREYS; i++) {
        if (i >= n) {
            v->u[i] = v->v[i] = v->a[i] = v->structureForce[i] = 0.0;
            continue;
        }
        double m = v->mass[i] + v->carriedMass[i];
        v->u[i] = u[i];
        v->v[i] = vel[i];
        v->a[i] = (building_force(B, i, B->t) - f[i]) / m; /* a_g + u'' */
        v->structureForce[i] = -f[i];
        shear += f[i];
        kinetic += 0.5 * m * vel[i] * vel[i];
        double drift = i > 0 ? u[i] - u[i - 1] : u[i];
        strain += 0.5 * v->stiffness[i] * drift * drift;
    }
    v->aTotal = building_ground(B, B->t);
    v->baseShear = shear;
    v->energy = kinetic + strain;
    v->baseWork = B->y[2 * n];
    v->forceWork = B->y[2 * n + 1];
    v->dampingLoss = B->y[2 * n + 2];
}
