/* The chain (engine.c: chain, chain_one) against the constrained Newton-Euler system (solve_set) at random
 * states of every contact set of one body and of a stack of two in which every body touches (each contact
 * sticking, and in the second half each sliding either way or sticking, at random): accelerations over g
 * and forces over the weight carried (each over its own size where larger); and the placed centres on the
 * constraints (closed corners at zero gap and normal rate, sticking corners at zero slip rate) where every
 * contact sticks; and the plastic impact onto each set (chain_impulse) against solve_set on the rates before.
 * Where a contact slides, the chain as a step integrates it (engine_rhs from its reduced coordinates, the
 * slips and slip rates engine_hold_slips writes) against the full state: the centres it places and the
 * derivatives. And Painleve's margin of one body sliding on one corner of the ground, written out, against the
 * rows, with its bound 1 - 3 mu / 4. And one body's chain with its slopes in the support's acceleration from one
 * evaluation (engine_rhs_slope), against two evaluations of engine_rhs a unit of acceleration apart.
 * Prints the largest of each and the number of states with a sliding contact, then the impacts', the reduced
 * sliding chain's, the margin's and the least slack of its bound, then the slopes';
 * tests/test_engine_chain.py runs it. White-box: it includes engine.c for its static solvers. */
#include "engine.c"

#include <stdio.h>
#include <stdlib.h>

static double rnd(void) { return 2.0 * rand() / RAND_MAX - 1.0; }

int main(int argc, char **argv) {
    int trials = argc > 1 ? atoi(argv[1]) : 20000;
    double worstDyn = 0.0, worstPlace = 0.0, worstImp = 0.0, worstSlide = 0.0, worstJam = 0.0, jamSlack = INFINITY;
    double worstSlope = 0.0;
    int nSliding = 0;
    const double b[2] = {0.3, 0.2}, h[2] = {0.5, 0.8}, m[2] = {450.0, 690.0}, g = 9.81;
    srand(12345);
    for (int trial = 0; trial < trials; trial++) {
        EnSystem s;
        memset(&s, 0, sizeof(s));
        s.nb = 1 + trial % 2;
        s.g = g;
        for (int k = 0; k < s.nb; k++) {
            double f = 1.0 + 0.5 * rnd(); /* sizes and masses varied around the statue on its plinth */
            engine_body_rectangle(&s.body[k], b[k] * f, h[k] / f, m[k] * f * f);
            s.mu[k] = 0.3;
        }
        for (int k = s.nb - 1; k >= 0; k--) s.weight[k] = s.body[k].m * g + (k + 1 < s.nb ? s.weight[k + 1] : 0.0);
        EnMode mode;
        memset(&mode, 0, sizeof(mode));
        for (int k = 0; k < s.nb; k++) {
            int c = (trial / 2 + k) % 3; /* left, right or both corners closed */
            mode.closed[k][0] = c != 1;
            mode.closed[k][1] = c != 0;
        }
        /* the second half: each contact slides (sigma +-1) or sticks, at random */
        int slides = trial >= trials / 2;
        int sigma[EN_MAX_BODIES] = {0, 0};
        if (slides)
            for (int k = 0; k < s.nb; k++) sigma[k] = rand() % 3 - 1;
        double y[NMAX] = {0}, xi0[EN_MAX_BODIES] = {0.05 * rnd(), 0.05 * rnd()};
        for (int k = 0; k < s.nb; k++) {
            y[EN_TH(k)] = 0.4 * rnd();
            y[EN_W(k)] = 3.0 * rnd();
        }
        EnForces reduced, full;
        if (!engine_chain(&s, &mode, xi0, y, 0.0, 0.0, &reduced)) return 2; /* places the centres */
        /* a slip rate v_k along its support's top for each sliding contact: body k and the bodies above it
         * move with it (their own contacts unchanged) */
        for (int k = 0; k < s.nb; k++) {
            mode.sigma[k] = sigma[k];
            if (!sigma[k]) continue;
            double v = 0.5 * rnd(), th = k > 0 ? y[EN_TH(k - 1)] : 0.0;
            for (int i = k; i < s.nb; i++) {
                y[EN_VEL(s.nb, i, 0)] += v * cos(th);
                y[EN_VEL(s.nb, i, 1)] -= v * sin(th);
            }
        }
        double ah = 8.0 * rnd(), av = 8.0 * rnd();
        if (!engine_solve(&s, &mode, y, ah, av, &reduced)) return 2; /* the chain (engine_solve's dispatch) */
        /* the chain as a step integrates it, from its reduced coordinates (rotations, and each sliding contact's
         * slip and slip rate, engine_hold_slips) and the anchors: the state it places is y's, its derivatives
         * those of the full state (rotations' rates over 1/s, slip rates and their rates over sqrt(g R)) */
        if (slides) {
            double yr[NMAX], placed[NMAX], dyr[NMAX], dyf[NMAX];
            EnForces fr, ff;
            memcpy(yr, y, sizeof(yr));
            engine_hold_slips(&s, &mode, yr);
            if (!engine_rhs(&s, &mode, xi0, yr, ah, av, dyr, &fr, placed) || !engine_rhs(&s, &mode, NULL, yr, ah, av, dyf, &ff, NULL))
                return 2;
            if (s.nb == 1) { /* the slopes in ah from one evaluation against the difference of two, over g (or size) */
                double d0[NMAX], d1[NMAX], da[NMAX], p0[NMAX], p1[NMAX];
                EnForces f0, f1, fa;
                if (engine_rhs_slope(&s, &mode, xi0, yr, ah, av, d0, &f0, p0, da, &fa) != 1 ||
                    !engine_rhs(&s, &mode, xi0, yr, ah + 1.0, av, d1, &f1, p1))
                    return 2;
                double R = sqrt(s.body[0].b * s.body[0].b + s.body[0].h * s.body[0].h), sc = fmax(g, fabs(f0.qdd[2]) * R);
                for (int q = 0; q < 3; q++)
                    worstSlope = fmax(worstSlope, fabs(f1.qdd[q] - f0.qdd[q] - fa.qdd[q]) * (q == 2 ? R : 1.0) / sc);
                worstSlope = fmax(worstSlope, fabs(f1.T[0] - f0.T[0] - fa.T[0]) / s.weight[0]);
                for (int i = 0; i < 2; i++) worstSlope = fmax(worstSlope, fabs(f1.N[0][i] - f0.N[0][i] - fa.N[0][i]) / s.weight[0]);
                if (mode.sigma[0]) worstSlope = fmax(worstSlope, fabs(f1.xidd[0] - f0.xidd[0] - fa.xidd[0]) / sc);
                /* the derivatives engine_rhs writes for this chain (the losses and slips where it slides), over g or
                 * their size, and the powers over the weight times sqrt(g R) */
                const int at[6] = {EN_TH(0), EN_W(0), EN_WORK(1), EN_LOSS(1, 0), EN_XI(1, 0), EN_XID(1, 0)};
                for (int j = 0; j < (mode.sigma[0] ? 6 : 3); j++) {
                    int i = at[j];
                    double size = i == EN_WORK(1) || i == EN_LOSS(1, 0) ? s.weight[0] * sqrt(g * R) : sc;
                    worstSlope = fmax(worstSlope, fmax(fabs(d1[i] - d0[i] - da[i]), fabs(d0[i] - dyr[i])) / size);
                }
            }
            for (int k = 0; k < s.nb; k++) {
                double R = sqrt(s.body[k].b * s.body[k].b + s.body[k].h * s.body[k].h), v = sqrt(g * R), a = g;
                for (int i = 0; i < 2; i++) {
                    worstSlide = fmax(worstSlide, fabs(placed[EN_POS(s.nb, k, i)] - y[EN_POS(s.nb, k, i)]) / R);
                    worstSlide = fmax(worstSlide, fabs(placed[EN_VEL(s.nb, k, i)] - y[EN_VEL(s.nb, k, i)]) / v);
                    a = fmax(a, fabs(ff.qdd[EN_Q(k, i)]));
                }
                a = fmax(a, fabs(ff.qdd[EN_Q(k, 2)]) * R);
                worstSlide = fmax(worstSlide, fabs(dyr[EN_W(k)] - dyf[EN_W(k)]) * R / a);
                if (!mode.sigma[k]) continue; /* (a chain in which every contact sticks integrates no loss) */
                worstSlide = fmax(worstSlide, fabs(dyr[EN_LOSS(s.nb, k)] - dyf[EN_LOSS(s.nb, k)]) / (s.weight[k] * v));
                EnPoint p; /* the slip acceleration: the closed corner's along its support's top (Newton-Euler) */
                int c = mode.closed[k][0] ? -1 : 1;
                engine_point(&s, k, c, yr, &p);
                double xidd = p.bT;
                for (int q = 0; q < 3 * s.nb; q++) xidd += p.wT[q] * ff.qdd[q];
                worstSlide = fmax(worstSlide, fabs(dyr[EN_XI(s.nb, k)] - p.xid) / v);
                worstSlide = fmax(worstSlide, fabs(dyr[EN_XID(s.nb, k)] - xidd) / a);
            }
        }
        /* Painleve's margin of a body sliding on one corner of the ground: written out against the rows, and at
         * least 1 - 3 mu / 4 (the bound below which the engine does not watch it) */
        if (s.nb == 1 && mode.sigma[0] && mode.closed[0][0] != mode.closed[0][1]) {
            int c = mode.closed[0][0] ? -1 : 1;
            const double mus[4] = {0.1, 0.7, 4.0 / 3.0, 2.0}; /* (no draw: the states drawn stay those above) */
            for (int j = 0; j < 4; j++) {
                EnSystem sj = s;
                sj.mu[0] = mus[j];
                double a = engine_jam_margin(&sj, &mode, 0, y), b = jam_margin_rows(&sj, &mode, 0, c, y);
                worstJam = fmax(worstJam, fabs(a - b));
                jamSlack = fmin(jamSlack, a - (1.0 - 0.75 * sj.mu[0]));
            }
        }
        double Minv[EN_NQ], fext[EN_NQ], a0[EN_NQ];
        free_terms(&s, ah, av, Minv, fext);
        for (int q = 0; q < 3 * s.nb; q++) a0[q] = Minv[q] * fext[q];
        if (!solve_set(&s, &mode, y, a0, 1, &full)) return 2;
        if (slides) nSliding += mode.sigma[0] != 0 || mode.sigma[1] != 0;
        /* the plastic impact onto the set from rates that break its constraints (chain_impulse against
         * solve_set on the rates before): rates after over sqrt(g R), impulses over the momentum carried */
        double yi[NMAX], v0[EN_NQ] = {0};
        memcpy(yi, y, sizeof(yi));
        for (int k = 0; k < s.nb; k++)
            for (int i = 0; i < 3; i++) yi[EN_VEL(s.nb, k, i)] += (i == 2 ? 2.0 : 0.5) * rnd();
        gather(&s, yi, 1, v0);
        EnForces ri, fi;
        if (!chain_impulse(&s, &mode, yi, &ri) || !solve_set(&s, &mode, yi, v0, 0, &fi)) return 2;
        for (int k = 0; k < s.nb; k++) {
            double R = sqrt(s.body[k].b * s.body[k].b + s.body[k].h * s.body[k].h), v = sqrt(g * R);
            for (int i = 0; i < 3; i++)
                worstImp = fmax(worstImp, fabs(fi.qdd[EN_Q(k, i)] - ri.qdd[EN_Q(k, i)]) * (i == 2 ? R : 1.0) / v);
            double P = fmax(s.weight[k] / g * v, fabs(fi.N[k][0]) + fabs(fi.N[k][1]) + fabs(fi.T[k]));
            for (int i = 0; i < 2; i++) worstImp = fmax(worstImp, fabs(fi.N[k][i] - ri.N[k][i]) / P);
            worstImp = fmax(worstImp, fabs(fi.T[k] - ri.T[k]) / P);
        }
        for (int k = 0; k < s.nb; k++) {
            double R = sqrt(s.body[k].b * s.body[k].b + s.body[k].h * s.body[k].h);
            /* accelerations over g, or their own size where larger (a stack sliding on two corners can be
             * near a singular set, with accelerations of hundreds of g) */
            double a = fmax(g, fmax(fmax(fabs(full.qdd[EN_Q(k, 0)]), fabs(full.qdd[EN_Q(k, 1)])),
                                    fabs(full.qdd[EN_Q(k, 2)]) * R));
            for (int i = 0; i < 2; i++) worstDyn = fmax(worstDyn, fabs(full.qdd[EN_Q(k, i)] - reduced.qdd[EN_Q(k, i)]) / a);
            worstDyn = fmax(worstDyn, fabs(full.qdd[EN_Q(k, 2)] - reduced.qdd[EN_Q(k, 2)]) * R / a);
            /* forces over the weight carried, or the forces themselves where larger (a flat body's split of
             * several weights between its corners rounds at their size) */
            double F = fmax(s.weight[k], fabs(full.N[k][0]) + fabs(full.N[k][1]) + fabs(full.T[k]));
            for (int i = 0; i < 2; i++) worstDyn = fmax(worstDyn, fabs(full.N[k][i] - reduced.N[k][i]) / F);
            worstDyn = fmax(worstDyn, fabs(full.T[k] - reduced.T[k]) / F);
            for (int i = 0; i < 2 && !slides; i++) {
                if (!mode.closed[k][i]) continue;
                EnPoint p;
                engine_point(&s, k, 2 * i - 1, y, &p);
                double v = sqrt(g * R);
                worstPlace = fmax(worstPlace, fmax(fabs(p.g) / R, fmax(fabs(p.gd) / v, fabs(p.xid) / v)));
                worstPlace = fmax(worstPlace, fabs(p.xi - (xi0[k] + (2 * i - 1) * s.body[k].b)) / R);
            }
        }
    }
    printf("%.3e %.3e %d %.3e %.3e %.3e %.3e %.3e\n", worstDyn, worstPlace, nSliding, worstImp, worstSlide, worstJam, jamSlack,
           worstSlope);
    return 0;
}
