/* The orders of the integrator's pairs (integrator.c), independent of any model: the linear oscillator
 * y'' = -y (y = cos t) over [0, 2] in n equal steps, n = 4, 8, 16 (DOP853) and 16, 32, 64 (DOPRI5); the end
 * error falls as h^p (p = 8, 5), the dense output's error at s = 0.3 and 0.7 of each step as h^q (at least 7 for DOP853's
 * degree-7 output, 5 for DOPRI5's quartic: its error is the step's, Hairer et al. II.6), and dense_poly's
 * power form equals dense_eval. A step with the components lo..hi-1 alone varying (Dop853Stages' ranges) gives
 * those the same values to the bit and the others their start. Prints, per method, the observed orders of the end
 * error over the two halvings, of the dense error, and the largest dense_poly difference; then the ranges' check
 * (1: the same); tests/test_integrator_order.py runs it. */
#include "integrator.c"

#include <stdio.h>

static void oscillator(const void *ctx, double t, const double *y, double *dy) {
    (void)ctx, (void)t;
    dy[0] = y[1];
    dy[1] = -y[0];
    dy[2] = 0.0; /* a component that never varies */
}

static void run(int method, int n, double *endErr, double *denseErr, double *polyDiff) {
    double y[NMAX] = {1.0, 0.0, 3.0}, f0[NMAX], y1[NMAX], f1[NMAX], e5[NMAX], e3[NMAX], h = 2.0 / n, t = 0.0;
    Dense d;
    Dop853Stages st = {0};
    *denseErr = *polyDiff = 0.0;
    for (int k = 0; k < n; k++) {
        oscillator(NULL, t, y, f0);
        if (method == RK_DOP853) {
            dop853_step(oscillator, NULL, 3, t, y, f0, h, y1, f1, e5, e3, &d, &st);
            dop853_dense(oscillator, NULL, &st, &d);
        } else {
            dopri5_step(oscillator, NULL, 3, t, y, f0, h, y1, f1, e5, &d);
        }
        for (int j = 0; j < 2; j++) {
            double s = j ? 0.7 : 0.3, yd[NMAX], c[DENSE_ROWS];
            dense_eval(&d, 3, s, yd);
            *denseErr = fmax(*denseErr, fabs(yd[0] - cos(t + s * h)));
            int deg = dense_poly(&d, 0, c);
            *polyDiff = fmax(*polyDiff, fabs(poly_eval(c, deg, s) - yd[0]));
        }
        for (int i = 0; i < 3; i++) y[i] = y1[i];
        t += h;
    }
    *endErr = fabs(y[0] - cos(2.0)) + fabs(y[1] + sin(2.0)) + fabs(y[2] - 3.0);
}

int main(void) {
    const int steps[2][3] = {{16, 32, 64}, {4, 8, 16}};
    for (int m = 0; m < 2; m++) {
        double e[3], de[3], pd[3], worstPoly = 0.0;
        for (int k = 0; k < 3; k++) {
            run(m == 0 ? RK_DOPRI5 : RK_DOP853, steps[m][k], &e[k], &de[k], &pd[k]);
            worstPoly = fmax(worstPoly, pd[k]);
        }
        printf("%.3f %.3f %.3f %.3f %.3g\n", log2(e[0] / e[1]), log2(e[1] / e[2]), log2(de[0] / de[1]),
               log2(de[1] / de[2]), worstPoly);
    }
    /* ranges: components 0..1 vary, 2 (derivative 0) keeps its start */
    double y[NMAX] = {0.4, -0.2, 7.0}, f0[NMAX], a[NMAX], b[NMAX], fa[NMAX], fb[NMAX], e5[NMAX], e3[NMAX];
    Dense da, db;
    Dop853Stages all = {0}, part = {0};
    part.nRanges = 1;
    part.lo[0] = 0;
    part.hi[0] = 2;
    oscillator(NULL, 0.0, y, f0);
    dop853_step(oscillator, NULL, 3, 0.0, y, f0, 0.1, a, fa, e5, e3, &da, &all);
    dop853_dense(oscillator, NULL, &all, &da);
    dop853_step(oscillator, NULL, 3, 0.0, y, f0, 0.1, b, fb, e5, e3, &db, &part);
    dop853_dense(oscillator, NULL, &part, &db);
    int same = memcmp(a, b, 3 * sizeof(double)) == 0 && b[2] == 7.0;
    for (int r = 0; r < DENSE_ROWS; r++) same &= memcmp(da.r[r], db.r[r], 3 * sizeof(double)) == 0;
    printf("%d\n", same);
    return 0;
}
