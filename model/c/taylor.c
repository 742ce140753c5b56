/* Taylor-series integration of one rocking block (see taylor.h). */
#include "taylor.h"

#include <float.h>
#include <math.h>

#include "ground.h"

int taylor_on(const Model *M) {
    const Variables *v = &M->v;
    return v->method == 1 || (v->method == 2 && v->nBlocks == 1 && v->contactModel == 0 && v->kind != KIND_RECORD);
}

int taylor_order(double rtol) {
    int n = (int)ceil(-0.6 * log(rtol)) + 8;
    if (n < 10) n = 10;
    if (n > TAYLOR_MAX) n = TAYLOR_MAX;
    return n;
}

void taylor_series(const Model *M, double t, double theta, double omega, int side, int piece, int N,
                   double *x) {
    double ah[TAYLOR_MAX + 1], ge[TAYLOR_MAX + 1];
    double ph[TAYLOR_MAX + 1], S[TAYLOR_MAX + 1], C[TAYLOR_MAX + 1];
    double kk = M->d.mROverI0;
    ground_series(M, t, piece, N, ah, ge); /* ge: a_v for now, then g + a_v */
    ge[0] += M->v.g;
    /* the ground's series end early without a wave (free rocking, no vertical, a record's
     * straight pieces): the products below stop at their last nonzero terms */
    int nah = N, nge = N;
    while (nah > 0 && ah[nah] == 0.0) nah--;
    while (nge > 0 && ge[nge] == 0.0) nge--;
    x[0] = theta;
    x[1] = omega;
    ph[0] = side * M->d.alpha - theta;
    S[0] = sin(ph[0]);
    C[0] = cos(ph[0]);
    for (int k = 0; k + 2 <= N; k++) {
        if (k >= 1) {
            double s = 0.0, c = 0.0;
            ph[k] = -x[k];
            for (int j = 1; j <= k; j++) {
                s += j * ph[j] * C[k - j];
                c += j * ph[j] * S[k - j];
            }
            S[k] = s / k;
            C[k] = -c / k;
        }
        double F = 0.0;
        for (int j = 0; j <= k && j <= nge; j++) F += ge[j] * S[k - j];
        for (int j = 0; j <= k && j <= nah; j++) F += ah[j] * C[k - j];
        x[k + 2] = -kk * F / ((k + 1.0) * (k + 2.0));
    }
}

double taylor_step(const double *x, int N, double eps) {
    /* The last three terms of theta's series and of omega's (k x[k] s^(k-1))
     * must each be below eps: one small coefficient cannot fake a long step. */
    double h = INFINITY;
    for (int j = N - 2; j <= N; j++) {
        if (x[j] == 0.0) continue;
        h = fmin(h, pow(eps / fabs(x[j]), 1.0 / j));
        h = fmin(h, pow(eps / (j * fabs(x[j])), 1.0 / (j - 1)));
    }
    /* Jorba and Zou's safety factor exp(-0.7 / (N - 1)) */
    return h * exp(-0.7 / (N - 1));
}

void taylor_eval(const double *x, int N, double s, double *theta, double *omega) {
    double th = x[N], om = 0.0; /* Horner for the polynomial and its derivative together */
    for (int k = N - 1; k >= 0; k--) {
        om = om * s + th;
        th = th * s + x[k];
    }
    *theta = th;
    if (omega) *omega = om;
}

/* The polynomial sum a[k] s^k (k = 0..n), by Horner. */
static double poly(const double *a, int n, double s) {
    double v = a[n];
    for (int k = n - 1; k >= 0; k--) v = v * s + a[k];
    return v;
}

/* Root of the polynomial a in [lo, hi] with p(lo) * slope < 0 <= p(hi) * slope: the Illinois
 * variant of regula falsi, to machine precision. */
static double refine_root(const double *a, int n, double lo, double hi, int slope) {
    double fa = poly(a, n, lo), fb = poly(a, n, hi);
    int side = 0;
    for (int it = 0; it < 100 && hi - lo > 2.0 * DBL_EPSILON * fabs(hi); it++) {
        double m = (fa * hi - fb * lo) / (fa - fb);
        if (!(m > lo && m < hi)) m = 0.5 * (lo + hi);
        double fm = poly(a, n, m);
        if (fm * slope >= 0.0) {
            hi = m, fb = fm;
            if (side == -1) fa *= 0.5;
            side = -1;
        } else {
            lo = m, fa = fm;
            if (side == 1) fb *= 0.5;
            side = 1;
        }
        if (fm == 0.0) return m;
    }
    return hi;
}

/* 1 if the polynomial sum a[k] s^k (k = 0..n) has no zero in (0, h]: its linear part keeps one
 * sign there by more than the sum of the other terms' magnitudes at h (and a margin for the
 * rounding of its evaluation); a zero at s = 0 is divided out first. A cheap proof that
 * sampling would find no crossing in the step, taken before the samples. */
static int no_zero(const double *a, int n, double h) {
    while (n > 1 && a[0] == 0.0) a++, n--; /* p(s) = s q(s): q's sign on (0, h] is p's */
    double a0 = a[0], a1h = a[1] * h, tail = 0.0, hk = h;
    for (int k = 2; k <= n; k++) {
        hk *= h;
        tail += fabs(a[k]) * hk;
    }
    double lin = a0 > 0.0 ? fmin(a0, a0 + a1h) : -fmax(a0, a0 + a1h);
    return a0 != 0.0 && lin - tail > 1e-12 * (fabs(a0) + fabs(a1h) + tail);
}

double taylor_first_crossing(const double *x, int N, double h, int comp, double sign, double target,
                             int slope, int samples) {
    /* the polynomial whose sign change is sought: sign * (theta - target), or sign * omega */
    double a[TAYLOR_MAX + 1];
    int n = comp == 0 ? N : N - 1;
    a[0] = comp == 0 ? sign * (x[0] - target) : sign * x[1];
    for (int k = 1; k <= n; k++) a[k] = comp == 0 ? sign * x[k] : sign * (k + 1) * x[k + 1];
    if (no_zero(a, n, h)) return 2.0 * h;
    /* monotone on [0, h] (its derivative has no zero there): one crossing at most, bracketed by
     * the step's ends (from a zero at s = 0 it leaves the surface at once: no crossing) */
    double d[TAYLOR_MAX + 1];
    for (int k = 0; k < n; k++) d[k] = (k + 1) * a[k + 1];
    if (n >= 2 && no_zero(d, n - 1, h)) {
        double v0 = a[0], vh = poly(a, n, h);
        int crosses = slope < 0 ? v0 > 0.0 && vh <= 0.0 : v0 < 0.0 && vh >= 0.0;
        return crosses ? refine_root(a, n, 0.0, h, slope) : 2.0 * h;
    }
    double lo = 0.0, vlo = a[0];
    for (int i = 1; i <= samples; i++) {
        double hi = h * i / samples, vhi = poly(a, n, hi);
        int crosses = slope < 0 ? (vlo > 0.0 && vhi <= 0.0) || (i == 1 && vlo == 0.0 && vhi < 0.0)
                                : (vlo < 0.0 && vhi >= 0.0);
        if (crosses) {
            double from = lo;
            if (vlo == 0.0) { /* starting on the surface (just after an impact): find where it leaves */
                from = 0.5 * hi;
                while (from > 1e-3 * DBL_EPSILON * h && poly(a, n, from) * slope >= 0.0) from *= 0.5;
                if (poly(a, n, from) * slope >= 0.0) return 2.0 * h;
            }
            return refine_root(a, n, from, hi, slope);
        }
        lo = hi;
        vlo = vhi;
    }
    return 2.0 * h;
}

double taylor_solve(const double *x, int N, double a, double b, double target) {
    double p[TAYLOR_MAX + 1];
    p[0] = x[0] - target;
    for (int k = 1; k <= N; k++) p[k] = x[k];
    return refine_root(p, N, a, b, poly(p, N, a) < 0.0 ? 1 : -1);
}
