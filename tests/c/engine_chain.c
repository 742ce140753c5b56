/* The sticking chain (engine.c: chain, chain_one) against the constrained Newton-Euler system (solve_set)
 * at random states of every sticking contact set of one body and of a stack of two: accelerations over g,
 * forces over the weight carried (or their own size where larger); and the placed centres on the constraints (closed corners at zero gap
 * and normal rate, sticking corners at zero slip rate). Prints the largest of each; tests/test_engine_chain.py
 * runs it. White-box: it includes engine.c for its static solvers. */
#include "engine.c"

#include <stdio.h>
#include <stdlib.h>

static double rnd(void) { return 2.0 * rand() / RAND_MAX - 1.0; }

int main(void) {
    double worstDyn = 0.0, worstPlace = 0.0;
    const double b[2] = {0.3, 0.2}, h[2] = {0.5, 0.8}, m[2] = {450.0, 690.0}, g = 9.81;
    srand(12345);
    for (int trial = 0; trial < 20000; trial++) {
        EnSystem s;
        memset(&s, 0, sizeof(s));
        s.nb = 1 + trial % 2;
        s.g = g;
        for (int k = 0; k < s.nb; k++) {
            double f = 1.0 + 0.5 * rnd(); /* sizes and masses varied around the statue on its plinth */
            s.body[k].b = b[k] * f;
            s.body[k].h = h[k] / f;
            s.body[k].m = m[k] * f * f;
            s.body[k].Ic = s.body[k].m * (s.body[k].b * s.body[k].b + s.body[k].h * s.body[k].h) / 3.0;
            s.mu[k] = 0.5;
        }
        for (int k = s.nb - 1; k >= 0; k--) s.weight[k] = s.body[k].m * g + (k + 1 < s.nb ? s.weight[k + 1] : 0.0);
        EnMode mode;
        memset(&mode, 0, sizeof(mode));
        for (int k = 0; k < s.nb; k++) {
            int c = (trial / 2 + k) % 3; /* left, right or both corners closed; every contact sticks */
            mode.closed[k][0] = c != 1;
            mode.closed[k][1] = c != 0;
        }
        double y[NMAX] = {0}, xi0[EN_MAX_BODIES] = {0.05 * rnd(), 0.05 * rnd()};
        for (int k = 0; k < s.nb; k++) {
            y[EN_TH(k)] = 0.4 * rnd();
            y[EN_W(k)] = 3.0 * rnd();
        }
        EnForces reduced, full;
        if (!engine_chain(&s, &mode, xi0, y, 0.0, 0.0, &reduced)) return 2; /* places the centres */
        double ah = 8.0 * rnd(), av = 8.0 * rnd();
        if (!engine_solve(&s, &mode, y, ah, av, &reduced)) return 2; /* the chain (engine_solve's dispatch) */
        double Minv[EN_NQ], fext[EN_NQ], a0[EN_NQ];
        free_terms(&s, ah, av, Minv, fext);
        for (int q = 0; q < 3 * s.nb; q++) a0[q] = Minv[q] * fext[q];
        if (!solve_set(&s, &mode, y, a0, 1, &full)) return 2;
        for (int k = 0; k < s.nb; k++) {
            double R = sqrt(s.body[k].b * s.body[k].b + s.body[k].h * s.body[k].h);
            for (int i = 0; i < 2; i++) worstDyn = fmax(worstDyn, fabs(full.qdd[EN_Q(k, i)] - reduced.qdd[EN_Q(k, i)]) / g);
            worstDyn = fmax(worstDyn, fabs(full.qdd[EN_Q(k, 2)] - reduced.qdd[EN_Q(k, 2)]) * R / g);
            /* forces over the weight carried, or the forces themselves where larger (a flat body's split of
             * several weights between its corners rounds at their size) */
            double F = fmax(s.weight[k], fabs(full.N[k][0]) + fabs(full.N[k][1]) + fabs(full.T[k]));
            for (int i = 0; i < 2; i++) worstDyn = fmax(worstDyn, fabs(full.N[k][i] - reduced.N[k][i]) / F);
            worstDyn = fmax(worstDyn, fabs(full.T[k] - reduced.T[k]) / F);
            for (int i = 0; i < 2; i++) {
                if (!mode.closed[k][i]) continue;
                EnPoint p;
                engine_point(&s, k, 2 * i - 1, y, &p);
                double v = sqrt(g * R);
                worstPlace = fmax(worstPlace, fmax(fabs(p.g) / R, fmax(fabs(p.gd) / v, fabs(p.xid) / v)));
                worstPlace = fmax(worstPlace, fabs(p.xi - (xi0[k] + (2 * i - 1) * s.body[k].b)) / R);
            }
        }
    }
    printf("%.3e %.3e\n", worstDyn, worstPlace);
    return 0;
}
