/* Dormand-Prince 5(4) with dense output; polynomial root isolation. */
#include "integrator.h"

#include <float.h>
#include <math.h>

/* Butcher tableau of Dormand and Prince (1980). */
static const double C2 = 1.0 / 5, C3 = 3.0 / 10, C4 = 4.0 / 5, C5 = 8.0 / 9;
static const double A21 = 1.0 / 5;
static const double A31 = 3.0 / 40, A32 = 9.0 / 40;
static const double A41 = 44.0 / 45, A42 = -56.0 / 15, A43 = 32.0 / 9;
static const double A51 = 19372.0 / 6561, A52 = -25360.0 / 2187,
                    A53 = 64448.0 / 6561, A54 = -212.0 / 729;
static const double A61 = 9017.0 / 3168, A62 = -355.0 / 33,
                    A63 = 46732.0 / 5247, A64 = 49.0 / 176,
                    A65 = -5103.0 / 18656;
static const double A71 = 35.0 / 384, A73 = 500.0 / 1113, A74 = 125.0 / 192,
                    A75 = -2187.0 / 6784, A76 = 11.0 / 84;
/* error coefficients: 5th minus embedded 4th order weights */
static const double E1 = 71.0 / 57600, E3 = -71.0 / 16695, E4 = 71.0 / 1920,
                    E5 = -17253.0 / 339200, E6 = 22.0 / 525, E7 = -1.0 / 40;
/* dense output (Hairer's contd5) */
static const double D1 = -12715105075.0 / 11282082432.0,
                    D3 = 87487479700.0 / 32700410799.0,
                    D4 = -10690763975.0 / 1880347072.0,
                    D5 = 701980252875.0 / 199316789632.0,
                    D6 = -1453857185.0 / 822651844.0,
                    D7 = 69997945.0 / 29380423.0;

void dopri5_step(RhsFn f, const void *ctx, int n, double t, const double *y,
                 const double *f0, double h, double *y1, double *f1,
                 double *err, double cont[5][NMAX]) {
    double k2[NMAX], k3[NMAX], k4[NMAX], k5[NMAX], k6[NMAX], yt[NMAX] = {0};
    int i;
    for (i = 0; i < n; i++) yt[i] = y[i] + h * A21 * f0[i];
    f(ctx, t + C2 * h, yt, k2);
    for (i = 0; i < n; i++) yt[i] = y[i] + h * (A31 * f0[i] + A32 * k2[i]);
    f(ctx, t + C3 * h, yt, k3);
    for (i = 0; i < n; i++)
        yt[i] = y[i] + h * (A41 * f0[i] + A42 * k2[i] + A43 * k3[i]);
    f(ctx, t + C4 * h, yt, k4);
    for (i = 0; i < n; i++)
        yt[i] = y[i] + h * (A51 * f0[i] + A52 * k2[i] + A53 * k3[i] + A54 * k4[i]);
    f(ctx, t + C5 * h, yt, k5);
    for (i = 0; i < n; i++)
        yt[i] = y[i] + h * (A61 * f0[i] + A62 * k2[i] + A63 * k3[i] +
                            A64 * k4[i] + A65 * k5[i]);
    f(ctx, t + h, yt, k6);
    for (i = 0; i < n; i++)
        y1[i] = y[i] + h * (A71 * f0[i] + A73 * k3[i] + A74 * k4[i] +
                            A75 * k5[i] + A76 * k6[i]);
    f(ctx, t + h, y1, f1);
    for (i = 0; i < n; i++) {
        double ydiff = y1[i] - y[i];
        double bspl = h * f0[i] - ydiff;
        err[i] = h * (E1 * f0[i] + E3 * k3[i] + E4 * k4[i] + E5 * k5[i] +
                      E6 * k6[i] + E7 * f1[i]);
        cont[0][i] = y[i];
        cont[1][i] = ydiff;
        cont[2][i] = bspl;
        cont[3][i] = ydiff - h * f1[i] - bspl;
        cont[4][i] = h * (D1 * f0[i] + D3 * k3[i] + D4 * k4[i] + D5 * k5[i] +
                          D6 * k6[i] + D7 * f1[i]);
    }
}

double dopri5_error_norm(int n, const double *y0, const double *y1,
                         const double *err, double rtol, double atol) {
    double sum = 0.0;
    for (int i = 0; i < n; i++) {
        double sc = atol + rtol * fmax(fabs(y0[i]), fabs(y1[i]));
        double e = err[i] / sc;
        sum += e * e;
    }
    return sqrt(sum / n);
}

void dense_eval(const double cont[5][NMAX], int n, double s, double *y) {
    double s1 = 1.0 - s;
    for (int i = 0; i < n; i++)
        y[i] = cont[0][i] +
               s * (cont[1][i] +
                    s1 * (cont[2][i] + s * (cont[3][i] + s1 * cont[4][i])));
}

void dense_poly(const double cont[5][NMAX], int i, double c[5]) {
    /* r1 + s r2 + (s - s^2) r3 + (s^2 - s^3) r4 + (s^2 - 2 s^3 + s^4) r5 */
    c[0] = cont[0][i];
    c[1] = cont[1][i] + cont[2][i];
    c[2] = -cont[2][i] + cont[3][i] + cont[4][i];
    c[3] = -cont[3][i] - 2.0 * cont[4][i];
    c[4] = cont[4][i];
}

double poly_eval(const double *c, int deg, double s) {
    double p = c[deg];
    for (int i = deg - 1; i >= 0; i--) p = p * s + c[i];
    return p;
}

/* Root of a polynomial that changes sign on [a, b] (fa * fb < 0):
 * Illinois-modified regula falsi, with a bisection fallback. */
static double bracket_root(const double *c, int deg, double a, double b,
                           double fa, double fb) {
    int side = 0;
    for (int it = 0; it < 200; it++) {
        double m;
        if (it % 4 == 3)
            m = 0.5 * (a + b); /* guarantee shrinking */
        else
            m = (a * fb - b * fa) / (fb - fa);
        if (!(m > a && m < b)) m = 0.5 * (a + b);
        if (!(m > a && m < b)) break; /* interval at machine resolution */
        double fm = poly_eval(c, deg, m);
        if (fm == 0.0) return m;
        if ((fm < 0) == (fa < 0)) {
            a = m;
            fa = fm;
            if (side == -1) fb *= 0.5;
            side = -1;
        } else {
            b = m;
            fb = fm;
            if (side == 1) fa *= 0.5;
            side = 1;
        }
        if (b - a <= 4.0 * DBL_EPSILON * fmax(1.0, fabs(a))) break;
    }
    return fabs(fa) < fabs(fb) ? a : b;
}

int poly_roots(const double *c, int deg, double lo, double hi, double *roots) {
    while (deg > 0 && c[deg] == 0.0) deg--;
    if (deg <= 0) return 0;
    if (deg == 1) {
        double r = -c[0] / c[1];
        if (r >= lo && r <= hi) {
            roots[0] = r;
            return 1;
        }
        return 0;
    }
    /* critical points split [lo, hi] into pieces where c is monotone */
    double d[4], crit[4], pts[6];
    for (int i = 1; i <= deg; i++) d[i - 1] = i * c[i];
    int nc = poly_roots(d, deg - 1, lo, hi, crit);
    int np = 0;
    pts[np++] = lo;
    for (int i = 0; i < nc; i++)
        if (crit[i] > pts[np - 1] && crit[i] < hi) pts[np++] = crit[i];
    pts[np++] = hi;
    int nr = 0;
    double fa = poly_eval(c, deg, pts[0]);
    if (fa == 0.0) roots[nr++] = pts[0];
    for (int j = 0; j + 1 < np; j++) {
        double a = pts[j], b = pts[j + 1];
        double fb = poly_eval(c, deg, b);
        if (fb == 0.0) {
            if (nr == 0 || roots[nr - 1] < b) roots[nr++] = b;
        } else if (fa != 0.0 && ((fa < 0) != (fb < 0))) {
            roots[nr++] = bracket_root(c, deg, a, b, fa, fb);
        }
        fa = fb;
        if (nr >= deg) break;
    }
    return nr;
}

double dopri5_initial_step(RhsFn f, const void *ctx, int n, double t,
                           const double *y, const double *f0, double rtol,
                           double atol, double hmax) {
    double d0 = 0, d1 = 0, d2 = 0, h0, h1, y1[NMAX] = {0}, f1[NMAX];
    for (int i = 0; i < n; i++) {
        double sc = atol + rtol * fabs(y[i]);
        d0 += (y[i] / sc) * (y[i] / sc);
        d1 += (f0[i] / sc) * (f0[i] / sc);
    }
    d0 = sqrt(d0 / n);
    d1 = sqrt(d1 / n);
    h0 = (d0 < 1e-5 || d1 < 1e-5) ? 1e-6 : 0.01 * d0 / d1;
    if (h0 > hmax) h0 = hmax;
    for (int i = 0; i < n; i++) y1[i] = y[i] + h0 * f0[i];
    f(ctx, t + h0, y1, f1);
    for (int i = 0; i < n; i++) {
        double sc = atol + rtol * fabs(y[i]);
        double e = (f1[i] - f0[i]) / sc;
        d2 += e * e;
    }
    d2 = sqrt(d2 / n) / h0;
    double dm = fmax(d1, d2);
    h1 = dm <= 1e-15 ? fmax(1e-6, h0 * 1e-3) : pow(0.01 / dm, 0.2);
    double h = fmin(100.0 * h0, h1);
    return h > hmax ? hmax : h;
}

/* Largest |theta| of dense-output component comp over s in [0, sEnd]. */
double dense_abs_max(const double cont[5][NMAX], int comp, double sEnd) {
    double c[5], d[4], roots[3];
    dense_poly(cont, comp, c);
    double m = fmax(fabs(c[0]), fabs(poly_eval(c, 4, sEnd)));
    for (int i = 1; i <= 4; i++) d[i - 1] = i * c[i];
    int nr = poly_roots(d, 3, 0.0, sEnd, roots);
    for (int j = 0; j < nr; j++) m = fmax(m, fabs(poly_eval(c, 4, roots[j])));
    return m;
}
