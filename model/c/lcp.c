/* Lemke's algorithm on a dense tableau (lcp.h). */
#include "lcp.h"

#include <float.h>
#include <math.h>
#include <string.h>

/* Pivots before giving up: far above the few an n <= LCP_MAX problem takes without cycling. */
#define LCP_PIVOTS 200

/* The tableau's rows are the basic variables; its columns: w (0..n-1), z (n..2n-1), z0 (2n),
 * right-hand side (2n + 1). Variable index v: w_i = i, z_i = n + i, z0 = 2n. */
LcpStatus lcp_solve(int n, const double *A, const double *q, double *z, double *w, int *basic) {
    double T[LCP_MAX][2 * LCP_MAX + 2];
    int var[LCP_MAX];
    int cols = 2 * n + 2, rhs = 2 * n + 1;
    memset(z, 0, sizeof(double) * (size_t)n);
    for (int i = 0; i < n; i++) w[i] = q[i];
    if (basic)
        for (int i = 0; i < n; i++) basic[i] = 0;
    int r = -1;
    double qmin = 0.0;
    for (int i = 0; i < n; i++) {
        if (q[i] < qmin) {
            qmin = q[i];
            r = i;
        }
    }
    if (r < 0) return LCP_SOLVED; /* z = 0 */
    /* w - A z - e z0 = q */
    for (int i = 0; i < n; i++) {
        for (int j = 0; j < cols; j++) T[i][j] = 0.0;
        T[i][i] = 1.0;
        for (int j = 0; j < n; j++) T[i][n + j] = -A[i * n + j];
        T[i][2 * n] = -1.0;
        T[i][rhs] = q[i];
        var[i] = i;
    }
    int entering = 2 * n;
    const double tiny = 1e-13;
    for (int pivots = 0; pivots < LCP_PIVOTS; pivots++) {
        /* pivot on row r, column entering */
        double p = T[r][entering];
        for (int j = 0; j < cols; j++) T[r][j] /= p;
        for (int i = 0; i < n; i++) {
            if (i == r || T[i][entering] == 0.0) continue;
            double f = T[i][entering];
            for (int j = 0; j < cols; j++) T[i][j] -= f * T[r][j];
            T[i][entering] = 0.0;
        }
        T[r][entering] = 1.0;
        int leaving = var[r];
        var[r] = entering;
        if (leaving == 2 * n) { /* z0 left the basis: a solution */
            for (int i = 0; i < n; i++) {
                double x = T[i][rhs] > 0 ? T[i][rhs] : 0.0;
                if (var[i] < n) w[var[i]] = x;
                else z[var[i] - n] = x;
            }
            for (int i = 0; i < n; i++) {
                int wb = 0;
                for (int k = 0; k < n; k++) wb |= var[k] == i;
                if (!wb) w[i] = 0.0;
                else z[i] = 0.0;
                if (basic) basic[i] = !wb;
            }
            return LCP_SOLVED;
        }
        /* the complement of the variable that left enters */
        entering = leaving < n ? leaving + n : leaving - n;
        /* ratio test (ties: the row with z0 first, then the lowest index) */
        r = -1;
        double best = INFINITY;
        for (int i = 0; i < n; i++) {
            double a = T[i][entering];
            if (!(a > tiny)) continue; /* the basic variable falls as the entering one grows */
            double ratio = T[i][rhs] / a;
            if (ratio < 0) ratio = 0.0;
            double tol = 1e-12 * (1.0 + best);
            if (r < 0 || ratio < best - tol || (fabs(ratio - best) <= tol && var[i] == 2 * n)) {
                best = ratio;
                r = i;
            }
        }
        if (r < 0) return LCP_RAY;
    }
    return LCP_ITERATIONS;
}
