/* White-box check of the contact engine's polygonal bodies (engine_body_polygon; tests/test_engine_polygon.py):
 * 1. rectangles built as polygons against engine_body_rectangle at random states, modes and columns of 1 to
 *    EN_MAX_BODIES bodies: derivatives, forces, indicators, the complementarity choice, impacts and projections;
 * 2. columns of off-centre polygons rocking, each on one corner and sticking, against Newton-Euler with the
 *    constraints written here from the polygons directly (their centres, inertias and corners);
 * 3. an off-centre body at rest just below and above its uplift acceleration to each side;
 * 4. a plastic impact of an off-centre body landing on its other corner: angular momentum about that corner;
 * 5. the overturn angles, the uniform polygon's centroid and inertia, and the refusals of bodies that are not.
 * Includes engine.c for its static solvers. Prints "refuse <case> <status> <reason>" lines, then one line of
 * numbers. */
#include "engine.c"

#include <stdio.h>
#include <stdlib.h>

static double rnd(void) { return 2.0 * rand() / RAND_MAX - 1.0; }

static void finish(EnSystem *s, int nb, const double *mu) {
    s->nb = nb;
    s->g = 9.81;
    for (int k = 0; k < nb; k++) s->mu[k] = mu[k];
    for (int k = nb - 1; k >= 0; k--) s->weight[k] = s->body[k].m * s->g + (k + 1 < nb ? s->weight[k + 1] : 0.0);
}

/* |a - b| over the larger of |a|, |b| and the unit u (a difference relative to the value, or to its unit near 0) */
static double rel(double a, double b, double u) { return fabs(a - b) / fmax(fmax(fabs(a), fabs(b)), u); }

/* The unit of component i of a state (or its derivative: d = 1) of nb bodies: lengths R (d: speeds sqrt(g R)),
 * angles 1 (d: rates sqrt(g / R)), rates sqrt(g R) and sqrt(g / R) (d: accelerations g, g / R), work W R (d: W v). */
static double unit_of(int nb, int i, int d, double g, double R, double W) {
    double v = sqrt(g * R), w = sqrt(g / R);
    if (i < 2 * nb) return i % 2 == 0 ? (d ? w : 1.0) : (d ? g / R : w);
    if (i < 3 * nb + 1) return d ? W * v : W * R;
    if (i < 5 * nb + 1) return (i - 3 * nb - 1) % 2 == 0 ? (d ? v : R) : (d ? g : v);
    return (i - 5 * nb - 1) % 4 < 2 ? (d ? v : R) : (d ? g : v);
}

static double forces_diff(const EnSystem *s, const EnForces *a, const EnForces *b, double R) {
    double e = 0.0;
    for (int k = 0; k < s->nb; k++) {
        for (int i = 0; i < 3; i++) e = fmax(e, rel(a->qdd[EN_Q(k, i)], b->qdd[EN_Q(k, i)], i == 2 ? s->g / R : s->g));
        for (int i = 0; i < 2; i++) e = fmax(e, rel(a->N[k][i], b->N[k][i], s->weight[k]));
        e = fmax(e, rel(a->T[k], b->T[k], s->weight[k]));
        e = fmax(e, rel(a->xidd[k], b->xidd[k], s->g));
    }
    return e;
}

/* 1. A rectangle as a polygon against engine_body_rectangle: worst[0] with its centre and inertia given (the same
 * numbers: bit for bit), worst[1] uniform (its inertia from the polygon's second moment, within an ulp of
 * m (b^2 + h^2) / 3): the largest difference, relative (over its unit near zero; a flat body's edge indicator,
 * the place of its corner forces' resultant, over the weight it carries / their sum too: rounding grows so where
 * they nearly cancel). differ: evaluations whose outcome (a mode, a kind, a status) differs. */
static int rectangles(int trials, double *worstBoth, int *differ, int *evaluations) {
    for (int trial = 0; trial < trials; trial++) {
        double *worst = &worstBoth[trial % 2 ? 0 : 1];
        int nb = 1 + trial % EN_MAX_BODIES;
        double mu[EN_MAX_BODIES], R = 0.0;
        EnSystem sr, sp;
        memset(&sr, 0, sizeof(sr));
        memset(&sp, 0, sizeof(sp));
        for (int k = 0; k < nb; k++) {
            double b = 0.25 * (1.0 + 0.5 * rnd()), h = 0.4 * (1.0 + 0.5 * rnd()), m = 500.0 * (1.0 + 0.5 * rnd());
            double x[4] = {-b, b, b, -b}, y[4] = {0.0, 0.0, 2.0 * h, 2.0 * h}, c[2] = {0.0, h};
            mu[k] = trial % 3 == 0 ? 0.3 : 0.8;
            engine_body_rectangle(&sr.body[k], b, h, m);
            /* uniform (centroid and inertia from the polygon), or the centre and inertia given; clockwise half the time */
            int given = trial % 2, cw = (trial / 2) % 2;
            double xs[4], ys[4];
            for (int i = 0; i < 4; i++) xs[i] = x[cw ? 3 - i : i], ys[i] = y[cw ? 3 - i : i];
            if (engine_body_polygon(&sp.body[k], 4, xs, ys, m, given ? c : NULL, given ? m * (b * b + h * h) / 3.0 : -1.0,
                                    NULL, 0))
                return 2;
            R = fmax(R, hypot(b, h));
        }
        finish(&sr, nb, mu);
        finish(&sp, nb, mu);
        double W = sr.weight[0];
        EnMode mode, chainMode;
        memset(&mode, 0, sizeof(mode));
        for (int k = 0; k < nb; k++) { /* left, right, both or (now and then) no corner closed */
            int c = rand() % 7;
            mode.closed[k][0] = c == 0 || c == 2 || c == 4;
            mode.closed[k][1] = c == 1 || c == 2 || c == 5;
            if (c == 3) mode.closed[k][0] = mode.closed[k][1] = 0;
            if (c == 6) mode.closed[k][1] = 1;
            mode.sigma[k] = trial % 2 && (mode.closed[k][0] || mode.closed[k][1]) ? rand() % 3 - 1 : 0;
        }
        chainMode = mode;
        for (int k = 0; k < nb; k++) {
            if (!chainMode.closed[k][0] && !chainMode.closed[k][1]) chainMode.closed[k][1] = 1;
            chainMode.sigma[k] = 0;
        }
        double y[NMAX] = {0}, xi0[EN_MAX_BODIES];
        for (int k = 0; k < nb; k++) {
            y[EN_TH(k)] = 0.3 * rnd();
            y[EN_W(k)] = 2.0 * rnd();
            xi0[k] = 0.05 * rnd();
        }
        if (!engine_chain(&sr, &chainMode, xi0, y, 0.0, 0.0, NULL)) return 2; /* places the centres */
        for (int k = 0; k < nb; k++) {
            if (!mode.closed[k][0] && !mode.closed[k][1]) { /* a body in flight: a little above, moving */
                y[EN_POS(nb, k, 1)] += 0.01 * (1.0 + rnd());
                for (int i = 0; i < 2; i++) y[EN_VEL(nb, k, i)] += 0.3 * rnd();
            }
            if (!mode.sigma[k]) continue;
            double v = 0.5 * rnd(), th = k > 0 ? y[EN_TH(k - 1)] : 0.0;
            for (int i = k; i < nb; i++) {
                y[EN_VEL(nb, i, 0)] += v * cos(th);
                y[EN_VEL(nb, i, 1)] -= v * sin(th);
            }
        }
        for (int k = 0; k < nb; k++) y[EN_XI(nb, k)] = xi0[k], y[EN_XID(nb, k)] = mode.sigma[k] ? 0.4 * rnd() : 0.0;
        double ah = 8.0 * rnd(), av = 4.0 * rnd();
        /* derivatives and forces: the full state, and a chain's reduced coordinates with its anchors */
        for (int reduced = 0; reduced < 2; reduced++) {
            const double *anchors = reduced && engine_touches(&sr, &mode) ? xi0 : NULL;
            double dr[NMAX] = {0}, dp[NMAX] = {0}, pr[NMAX] = {0}, pp[NMAX] = {0};
            EnForces fr, fp; /* (fields a mode leaves unset, the same 0 in both: engine.h) */
            memset(&fr, 0, sizeof(fr));
            memset(&fp, 0, sizeof(fp));
            int okr = engine_rhs(&sr, &mode, anchors, y, ah, av, dr, &fr, pr);
            int okp = engine_rhs(&sp, &mode, anchors, y, ah, av, dp, &fp, pp);
            (*evaluations)++;
            if (okr != okp) {
                (*differ)++;
                continue;
            }
            if (!okr) continue;
            for (int i = 0; i < EN_N(nb); i++) *worst = fmax(*worst, rel(dr[i], dp[i], unit_of(nb, i, 1, sr.g, R, W)));
            if (anchors)
                for (int i = 0; i < EN_N(nb); i++) *worst = fmax(*worst, rel(pr[i], pp[i], unit_of(nb, i, 0, sr.g, R, W)));
            *worst = fmax(*worst, forces_diff(&sr, &fr, &fp, R));
            /* the indicators (normalised: differences over 1) */
            double ir[EN_IND], ip[EN_IND];
            int kr[EN_IND], kp[EN_IND], br[EN_IND], bp[EN_IND], cr[EN_IND], cp[EN_IND];
            int nr = engine_indicators(&sr, &mode, y, &fr, ir, kr, br, cr);
            int np = engine_indicators(&sp, &mode, y, &fp, ip, kp, bp, cp);
            (*evaluations)++;
            if (nr != np) {
                (*differ)++;
                continue;
            }
            for (int i = 0; i < nr; i++) {
                if (kr[i] != kp[i] || br[i] != bp[i] || cr[i] != cp[i]) (*differ)++;
                int k = br[i], flat = kr[i] == EN_IND_FELL_OFF && mode.closed[k][0] && mode.closed[k][1];
                double u = flat ? fmax(1.0, sr.weight[k] / fabs(fr.N[k][0] + fr.N[k][1])) : 1.0;
                *worst = fmax(*worst, fabs(ir[i] - ip[i]) / fmax(fmax(fabs(ir[i]), fabs(ip[i])), u));
            }
        }
        /* the complementarity problem's choice at this state: the closed corners touching, half the contacts stuck */
        int touching[EN_MAX_BODIES][2], stuck[EN_MAX_BODIES];
        for (int k = 0; k < nb; k++) {
            touching[k][0] = mode.closed[k][0];
            touching[k][1] = mode.closed[k][1];
            stuck[k] = mode.sigma[k] == 0;
        }
        EnMode outr, outp;
        EnForces fr, fp;
        memset(&fr, 0, sizeof(fr));
        memset(&fp, 0, sizeof(fp));
        int cr = engine_choose(&sr, y, ah, av, (const int(*)[2])touching, stuck, &outr, &fr);
        int cp = engine_choose(&sp, y, ah, av, (const int(*)[2])touching, stuck, &outp, &fp);
        (*evaluations)++;
        if (cr != cp || (cr == 0 && memcmp(&outr, &outp, sizeof(outr)))) (*differ)++;
        else if (cr == 0) *worst = fmax(*worst, forces_diff(&sr, &fr, &fp, R));
        /* an impact of the same corners with the rates disturbed */
        double yr[NMAX], yp[NMAX];
        memcpy(yr, y, sizeof(yr));
        for (int k = 0; k < nb; k++)
            for (int i = 0; i < 3; i++) yr[EN_VEL(nb, k, i)] += (i == 2 ? 2.0 : 0.5) * rnd();
        memcpy(yp, yr, sizeof(yp));
        int tr[EN_MAX_BODIES][2], tp[EN_MAX_BODIES][2], sr_[EN_MAX_BODIES] = {0}, sp_[EN_MAX_BODIES] = {0};
        double PNr[EN_MAX_BODIES][2], PNp[EN_MAX_BODIES][2], PTr[EN_MAX_BODIES], PTp[EN_MAX_BODIES];
        memcpy(tr, touching, sizeof(tr));
        memcpy(tp, touching, sizeof(tp));
        int ir_ = engine_impact(&sr, yr, tr, sr_, PNr, PTr), ip_ = engine_impact(&sp, yp, tp, sp_, PNp, PTp);
        (*evaluations)++;
        int same = ir_ == ip_;
        for (int k = 0; k < nb && same && ir_ == 0; k++)
            same = tr[k][0] == tp[k][0] && tr[k][1] == tp[k][1] && sr_[k] == sp_[k];
        if (!same) {
            (*differ)++;
        } else if (ir_ == 0) {
            for (int i = 0; i < EN_N(nb); i++) *worst = fmax(*worst, rel(yr[i], yp[i], unit_of(nb, i, 0, sr.g, R, W)));
            for (int k = 0; k < nb; k++) {
                double P = sr.weight[k] / sr.g * sqrt(sr.g * R);
                for (int i = 0; i < 2; i++) *worst = fmax(*worst, rel(PNr[k][i], PNp[k][i], P));
                *worst = fmax(*worst, rel(PTr[k], PTp[k], P));
            }
        }
        /* projection onto the mode (positions and rates), energy, the rest state */
        memcpy(yr, y, sizeof(yr));
        for (int k = 0; k < nb; k++) yr[EN_POS(nb, k, 0)] += 1e-3 * rnd(), yr[EN_POS(nb, k, 1)] += 1e-3 * rnd();
        memcpy(yp, yr, sizeof(yp));
        engine_project(&sr, &mode, yr, xi0, 1);
        engine_project(&sp, &mode, yp, xi0, 1);
        for (int i = 0; i < EN_N(nb); i++) *worst = fmax(*worst, rel(yr[i], yp[i], unit_of(nb, i, 0, sr.g, R, W)));
        *worst = fmax(*worst, rel(engine_energy(&sr, y), engine_energy(&sp, y), W * R));
        engine_rest_state(&sr, yr);
        engine_rest_state(&sp, yp);
        for (int i = 0; i < EN_N(nb); i++) *worst = fmax(*worst, rel(yr[i], yp[i], unit_of(nb, i, 0, sr.g, R, W)));
        *evaluations += 3;
    }
    return 0;
}

/* ------------------------------------------------------------ off-centre bodies, written independently */

/* A polygon as the test holds it: vertices counter-clockwise, mass, centre, inertia about it. */
typedef struct {
    int n;
    double x[8], y[8], m, G[2], IG;
} Poly;

/* Three off-centre bodies: a leaning pentagon with its mass low and to the right, a trapezoid (wider at its top)
 * with its mass to the left, and a tall hexagon, uniform (its centroid and inertia computed here by triangles). */
static Poly shape(int i, double f) {
    Poly p;
    memset(&p, 0, sizeof(p));
    if (i == 0) {
        double x[5] = {-0.3, 0.5, 0.35, 0.0, -0.25}, y[5] = {0.0, 0.0, 1.2, 1.6, 1.0};
        p.n = 5;
        memcpy(p.x, x, sizeof(x));
        memcpy(p.y, y, sizeof(y));
        p.m = 300.0 * f, p.G[0] = 0.15, p.G[1] = 0.6, p.IG = 40.0 * f;
    } else if (i == 1) {
        double x[4] = {-0.2, 0.3, 0.45, -0.35}, y[4] = {0.0, 0.0, 0.9, 0.9};
        p.n = 4;
        memcpy(p.x, x, sizeof(x));
        memcpy(p.y, y, sizeof(y));
        p.m = 500.0 * f, p.G[0] = -0.05, p.G[1] = 0.5, p.IG = 35.0 * f;
    } else {
        double x[6] = {-0.1, 0.3, 0.4, 0.25, -0.2, -0.25}, y[6] = {0.0, 0.0, 0.8, 1.5, 1.5, 0.7};
        p.n = 6;
        memcpy(p.x, x, sizeof(x));
        memcpy(p.y, y, sizeof(y));
        p.m = 250.0 * f;
        /* uniform: triangles fanned from vertex 0, each's area, centroid and polar moment (A (a^2 + b^2 + c^2) / 36) */
        double A = 0.0, Sx = 0.0, Sy = 0.0, J0 = 0.0;
        for (int t = 1; t + 1 < p.n; t++) {
            double ax = p.x[0], ay = p.y[0], bx = p.x[t], by = p.y[t], cx = p.x[t + 1], cy = p.y[t + 1];
            double a = 0.5 * ((bx - ax) * (cy - ay) - (cx - ax) * (by - ay));
            double gx = (ax + bx + cx) / 3.0, gy = (ay + by + cy) / 3.0;
            double l2 = (bx - ax) * (bx - ax) + (by - ay) * (by - ay) + (cx - bx) * (cx - bx) + (cy - by) * (cy - by) +
                        (ax - cx) * (ax - cx) + (ay - cy) * (ay - cy);
            A += a, Sx += a * gx, Sy += a * gy;
            J0 += a * l2 / 36.0 + a * (gx * gx + gy * gy); /* about the origin, by parallel axes */
        }
        p.G[0] = Sx / A, p.G[1] = Sy / A;
        p.IG = p.m / A * (J0 - A * (p.G[0] * p.G[0] + p.G[1] * p.G[1]));
    }
    return p;
}

/* the base corners (left, right) of p from its vertices, the top face's height */
static void corners_of(const Poly *p, double *xL, double *xR, double *top) {
    *xL = INFINITY, *xR = -INFINITY, *top = 0.0;
    for (int i = 0; i < p->n; i++) {
        if (p->y[i] == 0.0) *xL = fmin(*xL, p->x[i]), *xR = fmax(*xR, p->x[i]);
        *top = fmax(*top, p->y[i]);
    }
}

/* Gaussian elimination with partial pivoting (the test's own). */
static int gauss(int n, double *A, double *r) {
    for (int c = 0; c < n; c++) {
        int p = c;
        for (int i = c + 1; i < n; i++)
            if (fabs(A[i * n + c]) > fabs(A[p * n + c])) p = i;
        if (A[p * n + c] == 0.0) return 0;
        for (int j = 0; j < n; j++) {
            double t = A[c * n + j];
            A[c * n + j] = A[p * n + j];
            A[p * n + j] = t;
        }
        double t = r[c];
        r[c] = r[p];
        r[p] = t;
        for (int i = c + 1; i < n; i++) {
            double f = A[i * n + c] / A[c * n + c];
            for (int j = c; j < n; j++) A[i * n + j] -= f * A[c * n + j];
            r[i] -= f * r[c];
        }
    }
    for (int i = n - 1; i >= 0; i--) {
        for (int j = i + 1; j < n; j++) r[i] -= A[i * n + j] * r[j];
        r[i] /= A[i * n + i];
    }
    return 1;
}

/* 2. Columns of 1 to 3 off-centre bodies, each rocking on one corner of its support and sticking: the engine's
 * chain (placed from its anchors) against Newton-Euler in the ground's frame with each corner pinned to the
 * support's material point under it. Unknowns per body: (ax, ay, alpha counter-clockwise) and the contact force
 * (Fx, Fy) at its corner; equations: m a = F_k - F_(k+1) - m (ah, g + av), IG alpha = r_k x F_k - s_k x F_(k+1)
 * (s_k: the corner of the body above from this one's centre), and the corner's acceleration that of the point
 * under it, a_G + alpha J'r - w^2 r (J'r = (-r_y, r_x), w counter-clockwise). worstPlace: the corners' gaps and
 * slips from the anchors (over R); worstDyn: accelerations over g (g / R), forces over the weight carried. */
static int newton_euler(int trials, double *worstDyn, double *worstPlace) {
    for (int trial = 0; trial < trials; trial++) {
        int nb = 1 + trial % 3;
        Poly P[3];
        EnSystem s;
        memset(&s, 0, sizeof(s));
        double mu[3] = {5.0, 5.0, 5.0};
        for (int k = 0; k < nb; k++) {
            P[k] = shape((trial / 3 + k) % 3, 1.0 + 0.3 * rnd());
            if ((trial / 3 + k) % 3 == 0 && k + 1 < nb) P[k] = shape(1, 1.0 + 0.3 * rnd()); /* (the pentagon has no top) */
            int uniform = (trial / 3 + k) % 3 == 2;
            if (engine_body_polygon(&s.body[k], P[k].n, P[k].x, P[k].y, P[k].m, uniform ? NULL : P[k].G,
                                    uniform ? -1.0 : P[k].IG, NULL, 0))
                return 2;
        }
        finish(&s, nb, mu);
        EnMode mode;
        memset(&mode, 0, sizeof(mode));
        int side[3];
        double y[NMAX] = {0}, xi0[3], R = 0.0;
        for (int k = 0; k < nb; k++) {
            side[k] = rand() % 2; /* 0 left, 1 right */
            mode.closed[k][side[k]] = 1;
            y[EN_TH(k)] = (k ? y[EN_TH(k - 1)] : 0.0) + (side[k] ? 1.0 : -1.0) * 0.2 * (1.0 + rnd()) ;
            y[EN_W(k)] = 2.0 * rnd();
            xi0[k] = 0.05 * rnd();
        }
        double ah = 6.0 * rnd(), av = 3.0 * rnd(), dy[NMAX], placed[NMAX];
        EnForces f;
        if (!engine_rhs(&s, &mode, xi0, y, ah, av, dy, &f, placed)) return 2;
        /* the corners and centres, from the polygons: body k's centre X_k, its corner c_k = X_k + Rot(theta_k) r0 */
        double rc[3][2], sAbove[3][2], Xc[3][2], w[3];
        for (int k = 0; k < nb; k++) {
            double xL, xR, top, th = placed[EN_TH(k)], ck = cos(th), sk = sin(th);
            corners_of(&P[k], &xL, &xR, &top);
            double r0[2] = {(side[k] ? xR : xL) - P[k].G[0], -P[k].G[1]};
            rc[k][0] = r0[0] * ck + r0[1] * sk; /* clockwise by theta */
            rc[k][1] = -r0[0] * sk + r0[1] * ck;
            Xc[k][0] = placed[EN_POS(nb, k, 0)];
            Xc[k][1] = placed[EN_POS(nb, k, 1)];
            w[k] = -placed[EN_W(k)]; /* counter-clockwise */
            R = fmax(R, hypot(fmax(xR - P[k].G[0], P[k].G[0] - xL), P[k].G[1]));
            /* the place the corner was anchored: on the support's top at its axis + anchor + the corner's x */
            double sx = xi0[k] + (side[k] ? xR : xL), sy = 0.0, O[2] = {0.0, 0.0}, ths = 0.0;
            if (k > 0) {
                double xl, xr, tp;
                corners_of(&P[k - 1], &xl, &xr, &tp);
                sx -= P[k - 1].G[0], sy = tp - P[k - 1].G[1];
                O[0] = Xc[k - 1][0], O[1] = Xc[k - 1][1], ths = placed[EN_TH(k - 1)];
            }
            double ax = O[0] + sx * cos(ths) + sy * sin(ths), ay = O[1] - sx * sin(ths) + sy * cos(ths);
            *worstPlace = fmax(*worstPlace, hypot(Xc[k][0] + rc[k][0] - ax, Xc[k][1] + rc[k][1] - ay) / R);
        }
        for (int k = 0; k + 1 < nb; k++)
            for (int i = 0; i < 2; i++) sAbove[k][i] = Xc[k + 1][i] + rc[k + 1][i] - Xc[k][i];
        int n = 5 * nb;
        double A[225] = {0}, r[15] = {0};
        /* unknowns: body k's a (3k, 3k + 1), alpha (3k + 2); force F_k at 3 nb + 2k, 3 nb + 2k + 1 */
        int row = 0;
        for (int k = 0; k < nb; k++) {
            int a = 3 * k, F = 3 * nb + 2 * k, Fu = 3 * nb + 2 * (k + 1);
            for (int i = 0; i < 2; i++, row++) { /* m a_i - F_k,i + F_(k+1),i = -m (ah, g + av)_i */
                A[row * n + a + i] = P[k].m;
                A[row * n + F + i] = -1.0;
                if (k + 1 < nb) A[row * n + Fu + i] = 1.0;
                r[row] = -P[k].m * (i == 0 ? ah : s.g + av);
            }
            /* IG alpha - (r x F_k) + (s x F_(k+1)) = 0 */
            A[row * n + a + 2] = P[k].IG;
            A[row * n + F + 0] = rc[k][1];
            A[row * n + F + 1] = -rc[k][0];
            if (k + 1 < nb) A[row * n + Fu + 0] = -sAbove[k][1], A[row * n + Fu + 1] = sAbove[k][0];
            row++;
            /* the corner's acceleration: a_k + alpha_k J'r_k - w_k^2 r_k = a_j + alpha_j J'd - w_j^2 d (d: the corner
             * from the support's centre; on the ground 0) */
            for (int i = 0; i < 2; i++, row++) {
                A[row * n + a + i] = 1.0;
                A[row * n + a + 2] = i == 0 ? -rc[k][1] : rc[k][0];
                r[row] = w[k] * w[k] * rc[k][i];
                if (k > 0) {
                    int b = 3 * (k - 1);
                    double d[2] = {sAbove[k - 1][0], sAbove[k - 1][1]};
                    A[row * n + b + i] = -1.0;
                    A[row * n + b + 2] = i == 0 ? d[1] : -d[0];
                    r[row] -= w[k - 1] * w[k - 1] * d[i];
                }
            }
        }
        if (!gauss(n, A, r)) return 2;
        for (int k = 0; k < nb; k++) {
            double th = k ? placed[EN_TH(k - 1)] : 0.0, nrm[2] = {sin(th), cos(th)}, tan_[2] = {cos(th), -sin(th)};
            double Fx = r[3 * nb + 2 * k], Fy = r[3 * nb + 2 * k + 1];
            double N = nrm[0] * Fx + nrm[1] * Fy, T = tan_[0] * Fx + tan_[1] * Fy;
            *worstDyn = fmax(*worstDyn, rel(f.qdd[EN_Q(k, 0)], r[3 * k], s.g));
            *worstDyn = fmax(*worstDyn, rel(f.qdd[EN_Q(k, 1)], r[3 * k + 1], s.g));
            *worstDyn = fmax(*worstDyn, rel(f.qdd[EN_Q(k, 2)], -r[3 * k + 2], s.g / R));
            *worstDyn = fmax(*worstDyn, rel(dy[EN_W(k)], -r[3 * k + 2], s.g / R));
            *worstDyn = fmax(*worstDyn, rel(f.N[k][side[k]], N, s.weight[k]));
            *worstDyn = fmax(*worstDyn, rel(f.N[k][1 - side[k]], 0.0, s.weight[k]));
            *worstDyn = fmax(*worstDyn, rel(f.T[k], T, s.weight[k]));
        }
    }
    return 0;
}

/* 3. Each off-centre body at rest on the ground, mu = 5 (no sliding): below g (xR - xG) / yG of ah < 0 it stays flat,
 * above it rocks on its right corner; below g (xG - xL) / yG of ah > 0 flat, above on its left (conventions: ah > 0
 * tips a body at rest towards theta < 0). Returns the wrong choices of cases. */
static int uplift(int *cases) {
    int wrong = 0;
    for (int i = 0; i < 3; i++) {
        Poly p = shape(i, 1.0);
        EnSystem s;
        memset(&s, 0, sizeof(s));
        double mu = 5.0, xL, xR, top;
        if (engine_body_polygon(&s.body[0], p.n, p.x, p.y, p.m, i == 2 ? NULL : p.G, i == 2 ? -1.0 : p.IG, NULL, 0))
            return -1;
        finish(&s, 1, &mu);
        corners_of(&p, &xL, &xR, &top);
        double right = -s.g * (xR - p.G[0]) / p.G[1], left = s.g * (p.G[0] - xL) / p.G[1];
        double ahs[4] = {0.999 * right, 1.001 * right, 0.999 * left, 1.001 * left};
        for (int c = 0; c < 4; c++) {
            EnMode rest, out;
            memset(&rest, 0, sizeof(rest));
            rest.closed[0][0] = rest.closed[0][1] = 1;
            double y[NMAX] = {0}, xi0[1] = {0.0};
            EnForces f;
            if (!engine_chain(&s, &rest, xi0, y, 0.0, 0.0, NULL)) return -1;
            int touching[1][2] = {{1, 1}}, stuck[1] = {1};
            if (engine_choose(&s, y, ahs[c], 0.0, (const int(*)[2])touching, stuck, &out, &f)) return -1;
            int lifted = c % 2, keep = c < 2 ? 1 : 0; /* the corner that stays: right for ah < 0 */
            int ok = out.sigma[0] == 0 && (lifted ? out.closed[0][keep] && !out.closed[0][1 - keep]
                                                   : out.closed[0][0] && out.closed[0][1]);
            wrong += !ok;
            (*cases)++;
        }
    }
    return wrong;
}

/* 4. Each off-centre body rocking on one corner lands on its other one (flat, rotating back): angular momentum about
 * the landing corner, IG w + m (G - P) x v_G (counter-clockwise), before and after the engine's plastic impact
 * (over its value); the corner it left must open (no impulse at it). worstH, and the cases where it did not open. */
static int impacts(double *worstH, int *notOpen, int *cases) {
    for (int i = 0; i < 3; i++)
        for (int from = 0; from < 2; from++) { /* rocking on the right (from 1) or the left corner */
            Poly p = shape(i, 1.0);
            EnSystem s;
            memset(&s, 0, sizeof(s));
            double mu = 5.0, xL, xR, top;
            if (engine_body_polygon(&s.body[0], p.n, p.x, p.y, p.m, p.G, p.IG, NULL, 0)) return 2;
            finish(&s, 1, &mu);
            corners_of(&p, &xL, &xR, &top);
            EnMode m;
            memset(&m, 0, sizeof(m));
            m.closed[0][from] = 1;
            double y[NMAX] = {0}, xi0[1] = {0.01};
            y[EN_W(0)] = from ? -0.7 : 0.7; /* coming back down: clockwise-negative on the right corner */
            if (!engine_chain(&s, &m, xi0, y, 0.0, 0.0, NULL)) return 2;
            double Px = xi0[0] + (from ? xL : xR); /* the landing corner (on the ground, theta = 0) */
            double H0 = -p.IG * y[EN_W(0)] + p.m * ((y[EN_POS(1, 0, 0)] - Px) * y[EN_VEL(1, 0, 1)] -
                                                    y[EN_POS(1, 0, 1)] * y[EN_VEL(1, 0, 0)]);
            int touching[1][2] = {{1, 1}}, stuck[1] = {1};
            double PN[1][2], PT[1];
            if (engine_impact(&s, y, touching, stuck, PN, PT)) return 2;
            double H1 = -p.IG * y[EN_W(0)] + p.m * ((y[EN_POS(1, 0, 0)] - Px) * y[EN_VEL(1, 0, 1)] -
                                                    y[EN_POS(1, 0, 1)] * y[EN_VEL(1, 0, 0)]);
            *worstH = fmax(*worstH, fabs(H1 - H0) / fabs(H0));
            *notOpen += touching[0][from] || PN[0][from] != 0.0 || !(PN[0][1 - from] > 0.0);
            (*cases)++;
        }
    return 0;
}

/* 5a. The overturn angles: turned about its right (left) corner by over[1] (over[0]), the vertex after (before) it
 * lies at the corner's height; and the uniform polygon's centroid and inertia against the test's triangles, the
 * indicator at a state. worst: the largest residual (over R, or relative). */
static int geometry(double *worst) {
    for (int i = 0; i < 3; i++) {
        Poly p = shape(i, 1.0);
        EnBody B;
        if (engine_body_polygon(&B, p.n, p.x, p.y, p.m, p.G, p.IG, NULL, 0)) return 2;
        double xL, xR, top, Rr = hypot(B.b, B.h);
        corners_of(&p, &xL, &xR, &top);
        for (int j = 0; j < p.n; j++) {
            int nx = (j + 1) % p.n, pv = (j + p.n - 1) % p.n;
            if (p.y[j] == 0.0 && p.x[j] == xR) { /* clockwise by over[1] about the right corner */
                double th = B.over[1], dx = p.x[nx] - xR, dy = p.y[nx];
                *worst = fmax(*worst, fabs(-dx * sin(th) + dy * cos(th)) / Rr);
            }
            if (p.y[j] == 0.0 && p.x[j] == xL) { /* counter-clockwise by over[0] about the left one */
                double th = -B.over[0], dx = p.x[pv] - xL, dy = p.y[pv];
                *worst = fmax(*worst, fabs(-dx * sin(th) + dy * cos(th)) / Rr);
            }
        }
        /* the indicator of the body rocking on its right corner at 0.1 rad */
        EnSystem s;
        memset(&s, 0, sizeof(s));
        s.body[0] = B;
        double mu = 5.0;
        finish(&s, 1, &mu);
        EnMode m;
        memset(&m, 0, sizeof(m));
        m.closed[0][1] = 1;
        double y[NMAX] = {0}, xi0[1] = {0.0}, ind[EN_IND];
        int kind[EN_IND], body[EN_IND], corner[EN_IND];
        y[EN_TH(0)] = 0.1;
        EnForces f;
        if (!engine_chain(&s, &m, xi0, y, 0.0, 0.0, &f)) return 2;
        int n = engine_indicators(&s, &m, y, &f, ind, kind, body, corner), found = 0;
        for (int j = 0; j < n; j++)
            if (kind[j] == EN_IND_OVERTURN) found = 1, *worst = fmax(*worst, fabs(ind[j] - (B.over[1] - 0.1)));
        if (!found) return 2;
    }
    /* the uniform hexagon: engine_body_polygon's centroid and inertia against the triangles' */
    Poly p = shape(2, 1.0);
    EnBody B;
    if (engine_body_polygon(&B, p.n, p.x, p.y, p.m, NULL, -1.0, NULL, 0)) return 2;
    *worst = fmax(*worst, fabs(B.xG - p.G[0]) / 1.0);
    *worst = fmax(*worst, fabs(-B.cy - p.G[1]) / 1.0);
    *worst = fmax(*worst, fabs(B.Ic - p.IG) / p.IG);
    /* and a rectangle's: m (b^2 + h^2) / 3, its overturn angles pi/2 */
    double x[4] = {-0.3, 0.3, 0.3, -0.3}, yv[4] = {0.0, 0.0, 1.0, 1.0};
    if (engine_body_polygon(&B, 4, x, yv, 100.0, NULL, -1.0, NULL, 0)) return 2;
    *worst = fmax(*worst, fabs(B.Ic - 100.0 * (0.09 + 0.25) / 3.0) / B.Ic);
    *worst = fmax(*worst, fmax(fabs(B.over[0] - M_PI / 2), fabs(B.over[1] - M_PI / 2)));
    return 0;
}

/* 5b. Refusals: each invalid body refused with a reason (printed), each valid one accepted. Returns the cases that
 * went the wrong way. */
static int refusals(int *cases) {
    typedef struct {
        const char *name;
        int n, valid;
        double x[6], y[6], m, G[2], IG; /* G[0] NAN: the centroid (centre NULL) */
    } Case;
    const double nan = NAN, inf = INFINITY;
    const Case cs[] = {
        {"two_vertices", 2, 0, {0, 1}, {0, 0}, 1, {nan, 0}, -1},
        {"not_finite", 4, 0, {-1, 1, 1, -1}, {0, 0, nan, 2}, 1, {nan, 0}, -1},
        {"infinite", 4, 0, {-1, 1, inf, -1}, {0, 0, 2, 2}, 1, {nan, 0}, -1},
        {"not_convex", 5, 0, {-1, 1, 1, 0, -1}, {0, 0, 2, 1, 2}, 1, {nan, 0}, -1},
        {"bow_tie", 4, 0, {-1, 1, -1, 1}, {0, 0, 2, 2}, 1, {nan, 0}, -1},
        {"pentagram", 5, 0, {0, 0.5878, -0.9511, 0.9511, -0.5878}, {1, -0.809, 0.309, 0.309, -0.809}, 1, {nan, 0}, -1},
        {"no_area", 3, 0, {-1, 0, 1}, {0, 0, 0}, 1, {nan, 0}, -1},
        {"base_not_at_zero", 4, 0, {-1, 1, 1, -1}, {0.5, 0.5, 2, 2}, 1, {nan, 0}, -1},
        {"pointed_base", 3, 0, {0, 1, -1}, {0, 1, 1}, 1, {nan, 0}, -1},
        {"tilted_base", 4, 0, {-1, 1, 1, -1}, {0, 0.1, 2, 2}, 1, {nan, 0}, -1},
        {"mass_zero", 4, 0, {-1, 1, 1, -1}, {0, 0, 2, 2}, 0, {nan, 0}, -1},
        {"mass_negative", 4, 0, {-1, 1, 1, -1}, {0, 0, 2, 2}, -3, {nan, 0}, -1},
        {"IG_zero", 4, 0, {-1, 1, 1, -1}, {0, 0, 2, 2}, 1, {0, 1}, 0},
        {"IG_nan", 4, 0, {-1, 1, 1, -1}, {0, 0, 2, 2}, 1, {0, 1}, nan},
        {"uniform_IG_given_centre", 4, 0, {-1, 1, 1, -1}, {0, 0, 2, 2}, 1, {0.1, 1}, -1},
        {"centre_beyond_right_corner", 4, 0, {-1, 1, 1.5, -1}, {0, 0, 2, 2}, 1, {1.2, 1.5}, 1},
        {"centre_on_left_corner_line", 4, 0, {-1, 1, 1, -1}, {0, 0, 2, 2}, 1, {-1, 1}, 1},
        {"centre_on_base", 4, 0, {-1, 1, 1, -1}, {0, 0, 2, 2}, 1, {0, 0}, 1},
        {"centre_outside", 4, 0, {-1, 1, 1, -1}, {0, 0, 2, 2}, 1, {0, 3}, 1},
        {"centre_not_finite", 4, 0, {-1, 1, 1, -1}, {0, 0, 2, 2}, 1, {0, inf}, 1},
        {"too_many", 65, 0, {0}, {0}, 1, {nan, 0}, -1},
        {"clockwise_rectangle", 4, 1, {-1, -1, 1, 1}, {0, 2, 2, 0}, 1, {nan, 0}, -1},
        {"collinear_and_repeated", 6, 1, {-1, 0, 1, 1, 1, -1}, {0, 0, 0, 0, 2, 2}, 1, {nan, 0}, -1},
        {"triangle_no_top", 3, 1, {-1, 1, 0}, {0, 0, 2}, 1, {nan, 0}, -1},
    };
    int wrong = 0, nc = (int)(sizeof(cs) / sizeof(cs[0]));
    for (int i = 0; i < nc; i++) {
        EnBody B;
        char msg[200] = "x";
        const Case *c = &cs[i];
        int rc = engine_body_polygon(&B, c->n, c->x, c->y, c->m, isnan(c->G[0]) ? NULL : c->G, c->IG, msg,
                                     sizeof(msg));
        printf("refuse %s %d %s\n", c->name, rc, msg);
        wrong += c->valid ? rc != 0 : rc == 0 || strlen(msg) == 0 || strchr(msg, '\n') != NULL;
        (*cases)++;
    }
    /* a short message buffer: cut, terminated */
    {
        EnBody B;
        char msg[8];
        int rc = engine_body_polygon(&B, 2, cs[0].x, cs[0].y, 1.0, NULL, -1.0, msg, sizeof(msg));
        wrong += rc == 0 || strlen(msg) != 7;
        rc = engine_body_polygon(&B, 2, cs[0].x, cs[0].y, 1.0, NULL, -1.0, NULL, 0);
        wrong += rc == 0;
        (*cases) += 2;
    }
    /* a stack on a body without a flat top: refused; on a rectangle: accepted */
    {
        EnSystem s;
        memset(&s, 0, sizeof(s));
        double x[3] = {-1, 1, 0}, y[3] = {0, 0, 2}, mu[2] = {0.5, 0.5};
        char msg[200] = "";
        if (engine_body_polygon(&s.body[0], 3, x, y, 1.0, NULL, -1.0, NULL, 0)) return 99;
        engine_body_rectangle(&s.body[1], 0.2, 0.5, 1.0);
        finish(&s, 2, mu);
        int rc = engine_check_stack(&s, msg, sizeof(msg));
        printf("refuse stack_on_triangle %d %s\n", rc, msg);
        wrong += rc == 0 || strlen(msg) == 0;
        engine_body_rectangle(&s.body[0], 0.3, 0.5, 1.0);
        wrong += engine_check_stack(&s, msg, sizeof(msg)) != 0;
        (*cases) += 2;
    }
    return wrong;
}

int main(int argc, char **argv) {
    int trials = argc > 1 ? atoi(argv[1]) : 8000, differ = 0, evaluations = 0, lifts = 0, hits = 0, notOpen = 0;
    int checks = 0;
    double worstRect[2] = {0.0, 0.0}, worstDyn = 0.0, worstPlace = 0.0, worstH = 0.0, worstGeo = 0.0;
    srand(4242);
    if (rectangles(trials, worstRect, &differ, &evaluations)) return 2;
    if (newton_euler(trials / 4 + 3, &worstDyn, &worstPlace)) return 2;
    int wrongLift = uplift(&lifts);
    if (wrongLift < 0) return 2;
    if (impacts(&worstH, &notOpen, &hits)) return 2;
    if (geometry(&worstGeo)) return 2;
    int wrongRefusal = refusals(&checks);
    printf("%.3e %.3e %d %d %.3e %.3e %d %d %.3e %d %d %.3e %d %d\n", worstRect[0], worstRect[1], differ, evaluations, worstDyn, worstPlace,
           wrongLift, lifts, worstH, notOpen, hits, worstGeo, wrongRefusal, checks);
    return 0;
}
