/* The contact engine with up to EN_MAX_BODIES bodies (built here with 8: tests/test_engine_column.py), a column of
 * drums each standing on the one below:
 * 1. at random states of every contact set of columns of 1 to 8 bodies in which every body touches (each contact
 *    sticking, and in the second half sliding either way or sticking, at random), the chain against the
 *    constrained Newton-Euler system (solve_set): accelerations over g and forces over the weight carried; the
 *    centres it places on the constraints where every contact sticks; the plastic impact onto each set;
 * 2. N identical drums rocking together on the bottom drum's corner (every interface closed and sticking) against
 *    the closed form of one block of their combined height, mass and inertia, theta'' = -(3 / (4 R)) ((g + av)
 *    sin(alpha - theta) + ah cos(alpha - theta)), and its ground reactions against the engine's one block;
 * 3. the complementarity problem's choice (engine_choose) for a column at rest: below the column's uplift
 *    acceleration g b / (N h) it rests, above it the bottom drum lifts with the column on it; with one slippery
 *    interface and an acceleration between its friction and the uplift, only that interface slides.
 * Prints: the largest dynamics, placement and impact differences and the states with a sliding contact (1); the
 * largest rotation and reaction differences (2); the wrong choices out of the cases (3). White-box: it includes
 * engine.c for its static solvers. */
#include "engine.c"

#include <stdio.h>
#include <stdlib.h>

static double rnd(void) { return 2.0 * rand() / RAND_MAX - 1.0; }

static void drums(EnSystem *s, int nb, const double *b, const double *h, const double *m, const double *mu) {
    memset(s, 0, sizeof(*s));
    s->nb = nb;
    s->g = 9.81;
    for (int k = 0; k < nb; k++) {
        engine_body_rectangle(&s->body[k], b[k], h[k], m[k]);
        s->mu[k] = mu[k];
    }
    for (int k = nb - 1; k >= 0; k--) s->weight[k] = s->body[k].m * s->g + (k + 1 < nb ? s->weight[k + 1] : 0.0);
}

/* 1. The chain against the constrained system at random states. */
static int random_states(int trials, double *worstDyn, double *worstPlace, double *worstImp, int *nSliding) {
    for (int trial = 0; trial < trials; trial++) {
        int nb = 1 + trial % EN_MAX_BODIES;
        double b[EN_MAX_BODIES], h[EN_MAX_BODIES], m[EN_MAX_BODIES], mu[EN_MAX_BODIES];
        for (int k = 0; k < nb; k++) { /* drums of varied sizes around 0.5 m x 0.8 m, 500 kg */
            b[k] = 0.25 * (1.0 + 0.3 * rnd());
            h[k] = 0.4 * (1.0 + 0.3 * rnd());
            m[k] = 500.0 * (1.0 + 0.3 * rnd());
            mu[k] = 0.3;
        }
        EnSystem s;
        drums(&s, nb, b, h, m, mu);
        EnMode mode;
        memset(&mode, 0, sizeof(mode));
        for (int k = 0; k < nb; k++) {
            int c = rand() % 3; /* left, right or both corners closed */
            mode.closed[k][0] = c != 1;
            mode.closed[k][1] = c != 0;
        }
        int slides = trial >= trials / 2, sigma[EN_MAX_BODIES] = {0};
        if (slides)
            for (int k = 0; k < nb; k++) sigma[k] = rand() % 3 - 1;
        double y[NMAX] = {0}, xi0[EN_MAX_BODIES] = {0};
        for (int k = 0; k < nb; k++) {
            y[EN_TH(k)] = 0.3 * rnd();
            y[EN_W(k)] = 2.0 * rnd();
            xi0[k] = 0.05 * rnd();
        }
        EnForces reduced, full;
        if (!engine_chain(&s, &mode, xi0, y, 0.0, 0.0, &reduced)) return 2; /* places the centres */
        for (int k = 0; k < nb; k++) { /* a slip rate: body k and those above move with it */
            mode.sigma[k] = sigma[k];
            if (!sigma[k]) continue;
            double v = 0.5 * rnd(), th = k > 0 ? y[EN_TH(k - 1)] : 0.0;
            for (int i = k; i < nb; i++) {
                y[EN_VEL(nb, i, 0)] += v * cos(th);
                y[EN_VEL(nb, i, 1)] -= v * sin(th);
            }
        }
        double ah = 8.0 * rnd(), av = 4.0 * rnd();
        if (!engine_solve(&s, &mode, y, ah, av, &reduced)) return 2;
        double Minv[EN_NQ], fext[EN_NQ], a0[EN_NQ];
        free_terms(&s, ah, av, Minv, fext);
        for (int q = 0; q < 3 * nb; q++) a0[q] = Minv[q] * fext[q];
        if (!solve_set(&s, &mode, y, a0, 1, &full)) return 2;
        int any = 0;
        for (int k = 0; k < nb; k++) any |= mode.sigma[k] != 0;
        *nSliding += slides && any;
        double yi[NMAX], v0[EN_NQ] = {0};
        memcpy(yi, y, sizeof(yi));
        for (int k = 0; k < nb; k++)
            for (int i = 0; i < 3; i++) yi[EN_VEL(nb, k, i)] += (i == 2 ? 2.0 : 0.5) * rnd();
        gather(&s, yi, 1, v0);
        EnForces ri, fi;
        if (!chain_impulse(&s, &mode, yi, &ri) || !solve_set(&s, &mode, yi, v0, 0, &fi)) return 2;
        for (int k = 0; k < nb; k++) {
            double R = hypot(b[k], h[k]), v = sqrt(s.g * R);
            double a = fmax(s.g, fmax(fmax(fabs(full.qdd[EN_Q(k, 0)]), fabs(full.qdd[EN_Q(k, 1)])),
                                      fabs(full.qdd[EN_Q(k, 2)]) * R));
            for (int i = 0; i < 2; i++) *worstDyn = fmax(*worstDyn, fabs(full.qdd[EN_Q(k, i)] - reduced.qdd[EN_Q(k, i)]) / a);
            *worstDyn = fmax(*worstDyn, fabs(full.qdd[EN_Q(k, 2)] - reduced.qdd[EN_Q(k, 2)]) * R / a);
            double F = fmax(s.weight[k], fabs(full.N[k][0]) + fabs(full.N[k][1]) + fabs(full.T[k]));
            for (int i = 0; i < 2; i++) *worstDyn = fmax(*worstDyn, fabs(full.N[k][i] - reduced.N[k][i]) / F);
            *worstDyn = fmax(*worstDyn, fabs(full.T[k] - reduced.T[k]) / F);
            for (int i = 0; i < 3; i++)
                *worstImp = fmax(*worstImp, fabs(fi.qdd[EN_Q(k, i)] - ri.qdd[EN_Q(k, i)]) * (i == 2 ? R : 1.0) / v);
            double P = fmax(s.weight[k] / s.g * v, fabs(fi.N[k][0]) + fabs(fi.N[k][1]) + fabs(fi.T[k]));
            for (int i = 0; i < 2; i++) *worstImp = fmax(*worstImp, fabs(fi.N[k][i] - ri.N[k][i]) / P);
            *worstImp = fmax(*worstImp, fabs(fi.T[k] - ri.T[k]) / P);
            for (int i = 0; i < 2 && !slides; i++) {
                if (!mode.closed[k][i]) continue;
                EnPoint p;
                engine_point(&s, k, 2 * i - 1, y, &p);
                *worstPlace = fmax(*worstPlace, fmax(fabs(p.g) / R, fmax(fabs(p.gd) / v, fabs(p.xid) / v)));
                *worstPlace = fmax(*worstPlace, fabs(p.xi - (xi0[k] + (2 * i - 1) * b[k])) / R);
            }
        }
    }
    return 0;
}

/* 2. N identical drums rocking as one on the bottom drum's right corner, against one block of the column's size. */
static int locked_column(double *worstRot, double *worstReact) {
    const double b = 0.25, h = 0.4, m = 800.0, theta = 0.05, omega = 0.3, ah = 1.5, av = -0.7;
    for (int N = 1; N <= EN_MAX_BODIES; N++) {
        double bs[EN_MAX_BODIES], hs[EN_MAX_BODIES], ms[EN_MAX_BODIES], mus[EN_MAX_BODIES];
        for (int k = 0; k < N; k++) bs[k] = b, hs[k] = h, ms[k] = m, mus[k] = 0.8;
        EnSystem s, one;
        drums(&s, N, bs, hs, ms, mus);
        double H = N * h, M = N * m;
        drums(&one, 1, &b, &H, &M, mus);
        EnMode mode, mode1;
        memset(&mode, 0, sizeof(mode));
        for (int k = 0; k < N; k++) mode.closed[k][0] = mode.closed[k][1] = 1;
        mode.closed[0][0] = 0; /* on the bottom drum's right corner */
        mode1 = mode;
        double y[NMAX] = {0}, y1[NMAX] = {0}, xi0[EN_MAX_BODIES] = {0};
        for (int k = 0; k < N; k++) y[EN_TH(k)] = theta, y[EN_W(k)] = omega;
        y1[EN_TH(0)] = theta, y1[EN_W(0)] = omega;
        EnForces f, f1;
        if (!engine_chain(&s, &mode, xi0, y, ah, av, &f) || !engine_chain(&one, &mode1, xi0, y1, ah, av, &f1)) return 2;
        double R = hypot(b, H), alpha = atan(b / H), phi = alpha - theta;
        double exact = -(3.0 / (4.0 * R)) * ((s.g + av) * sin(phi) + ah * cos(phi));
        for (int k = 0; k < N; k++) *worstRot = fmax(*worstRot, fabs(f.qdd[EN_Q(k, 2)] - exact) * R / s.g);
        *worstRot = fmax(*worstRot, fabs(f1.qdd[EN_Q(0, 2)] - exact) * R / s.g);
        double W = M * s.g;
        for (int i = 0; i < 2; i++) *worstReact = fmax(*worstReact, fabs(f.N[0][i] - f1.N[0][i]) / W);
        *worstReact = fmax(*worstReact, fabs(f.T[0] - f1.T[0]) / W);
    }
    return 0;
}

/* 3. The complementarity problem's choice for a column of N drums at rest. Returns the wrong choices. */
static int choices(int *cases) {
    const double b = 0.25, h = 0.4, m = 800.0;
    int wrong = 0;
    for (int N = 2; N <= EN_MAX_BODIES; N++) {
        for (int c = 0; c < 3; c++) {
            double bs[EN_MAX_BODIES], hs[EN_MAX_BODIES], ms[EN_MAX_BODIES], mus[EN_MAX_BODIES];
            for (int k = 0; k < N; k++) bs[k] = b, hs[k] = h, ms[k] = m, mus[k] = 0.8;
            int slippery = N / 2;  /* case 2: this interface's friction far below the uplift acceleration */
            double lift = 9.81 * b / (N * h), ah = c == 0 ? 0.999 * lift : c == 1 ? 1.001 * lift : 0.0;
            if (c == 2) {
                if (0.05 * 9.81 * 1.5 >= lift) continue;
                mus[slippery] = 0.05;
                ah = 0.05 * 9.81 * 1.5;
            }
            EnSystem s;
            drums(&s, N, bs, hs, ms, mus);
            EnMode rest, out;
            memset(&rest, 0, sizeof(rest));
            for (int k = 0; k < N; k++) rest.closed[k][0] = rest.closed[k][1] = 1;
            double y[NMAX] = {0}, xi0[EN_MAX_BODIES] = {0};
            EnForces f;
            if (!engine_chain(&s, &rest, xi0, y, 0.0, 0.0, &f)) return -1; /* places the column at rest */
            int touching[EN_MAX_BODIES][2], stuck[EN_MAX_BODIES];
            for (int k = 0; k < N; k++) touching[k][0] = touching[k][1] = stuck[k] = 1;
            if (engine_choose(&s, y, ah, 0.0, (const int(*)[2])touching, stuck, &out, &f)) return -1;
            int ok = 1;
            for (int k = 0; k < N; k++) {
                int lifted = k == 0 && c == 1, slides = c == 2 && k == slippery;
                ok &= out.closed[k][0] + out.closed[k][1] == (lifted ? 1 : 2);
                ok &= (out.sigma[k] != 0) == slides;
            }
            wrong += !ok;
            (*cases)++;
        }
    }
    return wrong;
}

int main(int argc, char **argv) {
    int trials = argc > 1 ? atoi(argv[1]) : 16000, nSliding = 0, cases = 0;
    double worstDyn = 0.0, worstPlace = 0.0, worstImp = 0.0, worstRot = 0.0, worstReact = 0.0;
    srand(12345);
    if (random_states(trials, &worstDyn, &worstPlace, &worstImp, &nSliding)) return 2;
    if (locked_column(&worstRot, &worstReact)) return 2;
    int wrong = choices(&cases);
    if (wrong < 0) return 2;
    printf("%.3e %.3e %.3e %d %.3e %.3e %d %d\n", worstDyn, worstPlace, worstImp, nSliding, worstRot, worstReact,
           wrong, cases);
    return 0;
}
