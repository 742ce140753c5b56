/* Overhang contacts (docs/columns.md, "Overhangs"), built with EN_MAX_BODIES = 8 (tests/test_engine_overhang.py):
 * 1. at random states of columns of 2 to 8 bodies in which every body touches, each closed end of a body on the one
 *    below at random in either pair (its corner on the support's top, or the support's top corner on its base), each
 *    contact sticking or sliding: the engine (the chain, engine_solve) against a constrained Newton-Euler system
 *    written here on its own: each contact's gap and slip as functions of the centres and rotations, their first and
 *    second time derivatives by Taylor arithmetic along q + v t + a t^2 / 2 (so its rows and biases owe nothing to
 *    the engine's formulas), M a = f + sum (N grad g + T grad xi), the gaps' and sticking slips' second derivatives
 *    zero, a sliding contact's T = -sigma mu N. Accelerations over g (rotations over g / R), forces over the weight
 *    carried;
 * 2. the chain's placement with anchors: each sticking contact's gap 0 and its slip at its anchor (over R);
 * 3. the switch: a body flat on the one below with its corner exactly on the support's corner (its slip b_j - b_k),
 *    sticking or sliding, and a body on that end alone sticking (turning about the coincident corners, tilted), in
 *    either pair: the placed states and the accelerations and forces of the two pairs (over R, sqrt(g R), g, the
 *    weight; tilted, the contact force as a vector: its normal is the support's top's in one pair, k's base's in the
 *    other), and the overhang's pair against the engine's general constrained system (solve_set).
 * Prints: the largest differences of 1 (dynamics), 2 (placement), 3 (switch), and the number of states with an
 * overhang in 1. White-box: it includes engine.c. */
#include "engine.c"

#include <stdio.h>
#include <stdlib.h>

static double rnd(void) { return 2.0 * rand() / RAND_MAX - 1.0; }

/* Taylor arithmetic to second order: x(t) = x0 + x1 t + x2 t^2 / 2. */
typedef struct {
    double v[3];
} T3;
static T3 tc(double a) { return (T3){{a, 0.0, 0.0}}; }
static T3 tadd(T3 a, T3 b) { return (T3){{a.v[0] + b.v[0], a.v[1] + b.v[1], a.v[2] + b.v[2]}}; }
static T3 tsub(T3 a, T3 b) { return (T3){{a.v[0] - b.v[0], a.v[1] - b.v[1], a.v[2] - b.v[2]}}; }
static T3 tmul(T3 a, T3 b) {
    return (T3){{a.v[0] * b.v[0], a.v[0] * b.v[1] + a.v[1] * b.v[0],
                 a.v[0] * b.v[2] + 2.0 * a.v[1] * b.v[1] + a.v[2] * b.v[0]}};
}
static T3 tscale(T3 a, double s) { return (T3){{s * a.v[0], s * a.v[1], s * a.v[2]}}; }
static void tcossin(T3 th, T3 *c, T3 *s) { /* cos, sin along th(t) */
    double c0 = cos(th.v[0]), s0 = sin(th.v[0]), w = th.v[1], a = th.v[2];
    *c = (T3){{c0, -s0 * w, -c0 * w * w - s0 * a}};
    *s = (T3){{s0, c0 * w, -s0 * w * w + c0 * a}};
}

/* A point (px, py) of body k's frame (from its centre) in the world, along the motion: body k's centre X and its
 * clockwise rotation: world = X + (px c + py s, -px s + py c). */
static void world(const T3 *q, int k, double px, double py, T3 out[2]) {
    T3 c, s;
    tcossin(q[3 * k + 2], &c, &s);
    out[0] = tadd(q[3 * k], tadd(tscale(c, px), tscale(s, py)));
    out[1] = tadd(q[3 * k + 1], tsub(tscale(c, py), tscale(s, px)));
}

/* The gap and slip of end i of body k (k > 0) in pair ov, along the motion q(t), from the geometry alone: a point
 * against a face given by a point on it and its unit normal and tangent. */
static void contact(const EnSystem *s, const T3 *q, int k, int i, int ov, T3 *gap, T3 *slip) {
    const EnBody *B = &s->body[k], *S = &s->body[k - 1];
    int j = k - 1;
    double c = 2 * i - 1;
    T3 cj, sj, ck, sk;
    tcossin(q[3 * j + 2], &cj, &sj);
    tcossin(q[3 * k + 2], &ck, &sk);
    if (!ov) { /* k's corner on j's top: face point j's axis on its top, normal (sin, cos) of j */
        T3 P[2], A[2];
        world(q, k, B->cx[i], B->cy, P);
        world(q, j, -S->xG, S->ht, A);
        T3 d[2] = {tsub(P[0], A[0]), tsub(P[1], A[1])};
        *gap = tadd(tmul(sj, d[0]), tmul(cj, d[1]));
        *slip = tsub(tsub(tmul(cj, d[0]), tmul(sj, d[1])), tc(B->xa[i])); /* along j's top from its axis, less xa */
    } else { /* j's top corner against k's base: face point k's axis on its base, outward normal -(sin, cos) of k */
        T3 Q[2], A[2];
        world(q, j, S->tm + c * S->tw - S->xG, S->ht, Q);
        world(q, k, -B->xG, B->cy, A);
        T3 d[2] = {tsub(Q[0], A[0]), tsub(Q[1], A[1])};
        *gap = tscale(tadd(tmul(sk, d[0]), tmul(ck, d[1])), -1.0);
        /* the slip: j's corner's place from j's axis less its place along k's base from k's axis */
        *slip = tsub(tc(S->tm + c * S->tw), tsub(tmul(ck, d[0]), tmul(sk, d[1])));
    }
}

/* The second derivative of the gap and slip as rows . a + bias (a the accelerations, q-space). */
static void rows(const EnSystem *s, const double *y, int k, int i, int ov, double *wN, double *wT, double *bN,
                 double *bT) {
    int nb = s->nb, nq = 3 * nb;
    T3 q[EN_NQ];
    for (int b = 0; b < nb; b++)
        for (int x = 0; x < 3; x++) q[3 * b + x] = (T3){{y[EN_POS(nb, b, x)], y[EN_VEL(nb, b, x)], 0.0}};
    T3 g0, x0;
    contact(s, q, k, i, ov, &g0, &x0);
    *bN = g0.v[2];
    *bT = x0.v[2];
    for (int d = 0; d < nq; d++) {
        q[d].v[2] = 1.0;
        T3 g, x;
        contact(s, q, k, i, ov, &g, &x);
        wN[d] = g.v[2] - *bN;
        wT[d] = x.v[2] - *bT;
        q[d].v[2] = 0.0;
    }
}

/* The ground's rows for body 0's corner i (a corner on the flat ground, slip from the ground's axis). */
static void ground_rows(const EnSystem *s, const double *y, int i, double *wN, double *wT, double *bN, double *bT) {
    int nb = s->nb, nq = 3 * nb;
    const EnBody *B = &s->body[0];
    T3 q[EN_NQ];
    for (int b = 0; b < nb; b++)
        for (int x = 0; x < 3; x++) q[3 * b + x] = (T3){{y[EN_POS(nb, b, x)], y[EN_VEL(nb, b, x)], 0.0}};
    T3 P[2];
    world(q, 0, B->cx[i], B->cy, P);
    *bN = P[1].v[2];
    *bT = P[0].v[2];
    for (int d = 0; d < nq; d++) {
        q[d].v[2] = 1.0;
        world(q, 0, B->cx[i], B->cy, P);
        wN[d] = P[1].v[2] - *bN;
        wT[d] = P[0].v[2] - *bT;
        q[d].v[2] = 0.0;
    }
}

/* The constrained Newton-Euler system of mode m: unknowns a (nq), each closed end's N, each body's T; returns 0 if
 * singular. */
static int newton_euler(const EnSystem *s, const EnMode *m, const double *y, double ah, double av, EnForces *f) {
    int nb = s->nb, nq = 3 * nb;
    enum { NMX = EN_NQ + 3 * EN_MAX_BODIES };
    static double A[NMX][NMX];
    double r[NMX], x[NMX];
    int n = nq, idxN[EN_MAX_BODIES][2], idxT[EN_MAX_BODIES];
    for (int k = 0; k < nb; k++) {
        for (int i = 0; i < 2; i++) idxN[k][i] = m->closed[k][i] ? n++ : -1;
        idxT[k] = n++;
    }
    for (int a = 0; a < n; a++) {
        r[a] = 0.0;
        for (int b = 0; b < n; b++) A[a][b] = 0.0;
    }
    for (int k = 0; k < nb; k++) { /* M a - forces = f_ext */
        const EnBody *B = &s->body[k];
        A[3 * k][3 * k] = A[3 * k + 1][3 * k + 1] = B->m;
        A[3 * k + 2][3 * k + 2] = B->Ic;
        r[3 * k] = -B->m * ah;
        r[3 * k + 1] = -B->m * (s->g + av);
    }
    for (int k = 0; k < nb; k++) {
        int first = -1;
        double wT1[EN_NQ], bT1 = 0.0;
        for (int i = 0; i < 2; i++) {
            if (!m->closed[k][i]) continue;
            double wN[EN_NQ], wT[EN_NQ], bN, bT;
            if (k == 0) ground_rows(s, y, i, wN, wT, &bN, &bT);
            else rows(s, y, k, i, m->over[k][i], wN, wT, &bN, &bT);
            int c = idxN[k][i];
            for (int d = 0; d < nq; d++) {
                A[d][c] -= wN[d] + (m->sigma[k] ? -m->sigma[k] * s->mu[k] * wT[d] : 0.0);
                A[c][d] = wN[d];
            }
            r[c] = -bN;
            if (first < 0) {
                first = i;
                memcpy(wT1, wT, sizeof(wT1));
                bT1 = bT;
            }
        }
        int t = idxT[k];
        if (m->sigma[k]) { /* T = -sigma mu (N0 + N1): its own row */
            A[t][t] = 1.0;
            for (int i = 0; i < 2; i++)
                if (idxN[k][i] >= 0) A[t][idxN[k][i]] = m->sigma[k] * s->mu[k];
        } else { /* the slip's second derivative zero, T on it */
            for (int d = 0; d < nq; d++) {
                A[d][t] -= wT1[d];
                A[t][d] = wT1[d];
            }
            r[t] = -bT1;
        }
    }
    /* Gaussian elimination, partial pivoting */
    for (int c = 0; c < n; c++) {
        int p = c;
        for (int i = c + 1; i < n; i++)
            if (fabs(A[i][c]) > fabs(A[p][c])) p = i;
        if (!(fabs(A[p][c]) > 1e-300)) return 0;
        for (int j = 0; j < n; j++) {
            double tmp = A[c][j];
            A[c][j] = A[p][j];
            A[p][j] = tmp;
        }
        double tmp = r[c];
        r[c] = r[p];
        r[p] = tmp;
        for (int i = c + 1; i < n; i++) {
            double fct = A[i][c] / A[c][c];
            for (int j = c; j < n; j++) A[i][j] -= fct * A[c][j];
            r[i] -= fct * r[c];
        }
    }
    for (int i = n - 1; i >= 0; i--) {
        double v = r[i];
        for (int j = i + 1; j < n; j++) v -= A[i][j] * x[j];
        x[i] = v / A[i][i];
    }
    memset(f, 0, sizeof(*f));
    for (int d = 0; d < nq; d++) f->qdd[d] = x[d];
    for (int k = 0; k < nb; k++) {
        for (int i = 0; i < 2; i++) f->N[k][i] = idxN[k][i] >= 0 ? x[idxN[k][i]] : 0.0;
        f->T[k] = x[idxT[k]];
    }
    return 1;
}

static void drums(EnSystem *s, int nb, int equal) {
    memset(s, 0, sizeof(*s));
    s->nb = nb;
    s->g = 9.81;
    for (int k = 0; k < nb; k++) {
        double b = equal ? 0.3 : 0.3 * (1.0 + 0.3 * rnd()), h = 0.4 * (1.0 + 0.3 * rnd());
        engine_body_rectangle(&s->body[k], b, h, 500.0 * (1.0 + 0.3 * rnd()));
        s->mu[k] = 0.4;
    }
    for (int k = nb - 1; k >= 0; k--) s->weight[k] = s->body[k].m * s->g + (k + 1 < nb ? s->weight[k + 1] : 0.0);
}

/* The largest difference of two solutions: accelerations over g (rotations times R), forces over the weight. */
static double differ(const EnSystem *s, const EnForces *a, const EnForces *b) {
    double worst = 0.0;
    for (int k = 0; k < s->nb; k++) {
        double R = hypot(s->body[k].b, s->body[k].h);
        for (int x = 0; x < 3; x++)
            worst = fmax(worst, fabs(a->qdd[EN_Q(k, x)] - b->qdd[EN_Q(k, x)]) * (x == 2 ? R : 1.0) / s->g);
        for (int i = 0; i < 2; i++) worst = fmax(worst, fabs(a->N[k][i] - b->N[k][i]) / s->weight[k]);
        worst = fmax(worst, fabs(a->T[k] - b->T[k]) / s->weight[k]);
    }
    return worst;
}

int main(int argc, char **argv) {
    int trials = argc > 1 ? atoi(argv[1]) : 8000, overhangs = 0;
    double dyn = 0.0, place = 0.0, sw = 0.0;
    srand(7);
    for (int trial = 0; trial < trials; trial++) {
        int nb = 2 + trial % (EN_MAX_BODIES - 1);
        EnSystem s;
        drums(&s, nb, 0);
        EnMode m;
        memset(&m, 0, sizeof(m));
        int any = 0;
        for (int k = 0; k < nb; k++) {
            int c = rand() % 3;
            m.closed[k][0] = c != 1;
            m.closed[k][1] = c != 0;
            m.sigma[k] = trial % 2 ? rand() % 3 - 1 : 0;
            for (int i = 0; i < 2 && k > 0; i++) any |= m.over[k][i] = rand() % 2;
        }
        overhangs += any;
        /* a random state placed by the chain from random anchors (slips), rotations and rates */
        double y[NMAX] = {0}, xi0[EN_MAX_BODIES];
        for (int k = 0; k < nb; k++) {
            y[EN_TH(k)] = 0.3 * rnd();
            y[EN_W(k)] = 2.0 * rnd();
            xi0[k] = 0.2 * rnd();
            y[EN_XI(nb, k)] = xi0[k];
            y[EN_XID(nb, k)] = 0.5 * rnd();
        }
        double ah = 3.0 * rnd(), av = 2.0 * rnd();
        EnForces fc, fn;
        if (!engine_chain(&s, &m, xi0, y, ah, av, &fc)) return 1;
        /* 2. placement: each closed end on its face, a sticking contact's slip at its anchor */
        for (int k = 0; k < nb; k++)
            for (int i = 0; i < 2; i++) {
                if (!m.closed[k][i] || (m.closed[k][0] && m.closed[k][1] && i == 1)) continue;
                EnPoint p;
                engine_corner_m(&s, &m, k, 2 * i - 1, y, &p);
                double R = hypot(s.body[k].b, s.body[k].h), want = m.sigma[k] ? y[EN_XI(nb, k)] : xi0[k];
                place = fmax(place, fabs(p.g) / R);
                place = fmax(place, fabs(p.xi - s.body[k].xa[i] - want) / R);
            }
        /* 1. the chain's dynamics (from the placed state, the rates as placed) against Newton-Euler */
        if (!engine_solve(&s, &m, y, ah, av, &fc) || !newton_euler(&s, &m, y, ah, av, &fn)) return 2;
        dyn = fmax(dyn, differ(&s, &fc, &fn));
    }
    /* 3. the switch at coinciding corners */
    for (int trial = 0; trial < trials / 4; trial++) {
        int nb = 2 + trial % (EN_MAX_BODIES - 1);
        EnSystem s;
        drums(&s, nb, 0);
        int k = 1 + rand() % (nb - 1), i = rand() % 2, c = 2 * i - 1, kind = trial % 3;
        EnMode m;
        memset(&m, 0, sizeof(m));
        double y[NMAX] = {0}, xi0[EN_MAX_BODIES];
        for (int j = 0; j < nb; j++) {
            m.closed[j][0] = m.closed[j][1] = 1;
            xi0[j] = 0.05 * rnd();
            y[EN_TH(j)] = 0.2 * rnd();
            y[EN_W(j)] = rnd();
        }
        /* body k's corner i exactly on its support's corner i: the slip tm_j + c tw_j - xa_k[i] */
        xi0[k] = s.body[k - 1].tm + c * s.body[k - 1].tw - s.body[k].xa[i];
        y[EN_XI(nb, k)] = xi0[k];
        y[EN_XID(nb, k)] = kind == 1 ? 0.3 * rnd() : 0.0;
        m.sigma[k] = kind == 1 ? (y[EN_XID(nb, k)] > 0 ? 1 : -1) : 0;
        if (kind == 2) m.closed[k][!i] = 0; /* on that end alone, sticking: turning about the coincident corners */
        EnMode mo = m;
        mo.over[k][i] = 1;
        double ya[NMAX], yb[NMAX];
        memcpy(ya, y, sizeof(ya));
        memcpy(yb, y, sizeof(yb));
        double ah = 3.0 * rnd(), av = 2.0 * rnd();
        EnForces fa, fb;
        if (!engine_chain(&s, &m, xi0, ya, ah, av, &fa) || !engine_chain(&s, &mo, xi0, yb, ah, av, &fb)) return 3;
        /* (the same state either way) */
        for (int j = 0; j < nb; j++)
            for (int x = 0; x < 2; x++) {
                double R = hypot(s.body[j].b, s.body[j].h);
                sw = fmax(sw, fabs(ya[EN_POS(nb, j, x)] - yb[EN_POS(nb, j, x)]) / R);
                sw = fmax(sw, fabs(ya[EN_VEL(nb, j, x)] - yb[EN_VEL(nb, j, x)]) / sqrt(s.g * R));
            }
        if (kind < 2) {
            sw = fmax(sw, differ(&s, &fa, &fb));
        } else { /* tilted on the pin: the same accelerations and the same force on body k, N n + T t, whose normal
                  * is the support's top's (its corner on the top) or k's base's (the support's corner on it) */
            EnForces fa2 = fa, fb2 = fb;
            double tha = ya[EN_TH(k - 1)], thb = ya[EN_TH(k)], N = fa.N[k][i], T = fa.T[k];
            double Fa[2] = {N * sin(tha) + T * cos(tha), N * cos(tha) - T * sin(tha)};
            N = fb.N[k][i], T = fb.T[k];
            double Fb[2] = {N * sin(thb) + T * cos(thb), N * cos(thb) - T * sin(thb)};
            sw = fmax(sw, hypot(Fa[0] - Fb[0], Fa[1] - Fb[1]) / s.weight[k]);
            fa2.N[k][i] = fb2.N[k][i] = fa2.T[k] = fb2.T[k] = 0.0;
            sw = fmax(sw, differ(&s, &fa2, &fb2));
        }
        /* and the general Newton-Euler of the engine (solve_set) on the overhang's pair */
        EnForces fg;
        double Minv[EN_NQ], fext[EN_NQ], a0[EN_NQ];
        free_terms(&s, ah, av, Minv, fext);
        for (int q = 0; q < 3 * nb; q++) a0[q] = Minv[q] * fext[q];
        if (!solve_set(&s, &mo, yb, a0, 1, &fg)) return 4;
        sw = fmax(sw, differ(&s, &fb, &fg));
    }
    printf("%.3e %.3e %.3e %d\n", dyn, place, sw, overhangs);
    return 0;
}
