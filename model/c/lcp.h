/* Linear complementarity problems: find z >= 0 with w = A z + q >= 0 and w . z = 0.
 *
 * Lemke's complementary pivoting (Cottle, Pang & Stone 1992, "The Linear Complementarity
 * Problem", section 4.4) on a dense tableau, for the small problems of the contact engine
 * (engine.h: a few unknowns per contact). Knows nothing about contact.
 */
#ifndef ROCKING_LCP_H
#define ROCKING_LCP_H

#ifndef LCP_MAX
#define LCP_MAX 48
#endif

typedef enum {
    LCP_SOLVED = 0,   /* z, w hold a solution; w[i] of a basic z[i] is exactly 0, and z[i] of a basic w[i] */
    LCP_RAY = 1,      /* Lemke ended on a secondary ray: no solution found (e.g. Painleve's paradox) */
    LCP_ITERATIONS = 2 /* no termination within the pivot limit (degenerate cycling) */
} LcpStatus;

/* Solve the n x n problem (A row-major, n <= LCP_MAX). basic[i] (may be NULL) is set to 1 where
 * z[i] is in the final basis (its w[i] = 0 exactly), 0 where w[i] is (z[i] = 0 exactly). */
LcpStatus lcp_solve(int n, const double *A, const double *q, double *z, double *w, int *basic);

#endif
