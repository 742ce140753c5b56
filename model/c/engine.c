/* The planar contact engine (engine.h). Derivation: docs/flight.md, "The contact engine". */
#include "engine.h"

#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "lcp.h"

#define EN_CORNERS (2 * EN_MAX_BODIES)
/* the most constraint rows of a mode: two corners and a friction row per body */
#define EN_ROWS (3 * EN_MAX_BODIES)

/* Clockwise rotation of (x, y) by theta with cos c and sin s. */
static void rot(double c, double s, double x, double y, double out[2]) {
    out[0] = x * c + y * s;
    out[1] = -x * s + y * c;
}
static double dot(const double a[2], const double b[2]) { return a[0] * b[0] + a[1] * b[1]; }

/* ------------------------------------------------------------------------ bodies */

void engine_body_rectangle(EnBody *B, double b, double h, double m) {
    memset(B, 0, sizeof(*B));
    B->b = b;
    B->h = h;
    B->m = m;
    B->Ic = m * (b * b + h * h) / 3.0;
    B->iIo[0] = B->iIo[1] = 1.0 / (m * (b * b + h * h) + B->Ic);
    B->cx[0] = B->xa[0] = -b;
    B->cx[1] = B->xa[1] = b;
    B->cy = -h;
    B->xG = 0.0;
    B->ht = h;
    B->tm = 0.0;
    B->tw = b;
    B->over[0] = B->over[1] = M_PI / 2;
}

/* A one-line reason in msg (if any room), and 1. */
static int refuse(char *msg, size_t len, const char *fmt, ...) {
    if (msg && len) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(msg, len, fmt, ap);
        va_end(ap);
    }
    return 1;
}

int engine_body_polygon(EnBody *B, int n, const double *x, const double *y, double m, const double *centre,
                        double IG, char *msg, size_t len) {
    if (msg && len) msg[0] = '\0';
    if (!x || !y || n < 3) return refuse(msg, len, "a polygon needs at least 3 vertices (%d given)", x && y ? n : 0);
    if (n > EN_POLY_MAX) return refuse(msg, len, "a polygon of %d vertices: at most %d", n, EN_POLY_MAX);
    for (int i = 0; i < n; i++)
        if (!isfinite(x[i]) || !isfinite(y[i]))
            return refuse(msg, len, "vertex %d (%g, %g) is not finite", i, x[i], y[i]);
    if (!(m > 0.0) || !isfinite(m)) return refuse(msg, len, "mass %g must be > 0 kg (and finite)", m);
    if (centre && (!isfinite(centre[0]) || !isfinite(centre[1])))
        return refuse(msg, len, "centre of mass (%g, %g) is not finite", centre[0], centre[1]);
    if (isnan(IG) || isinf(IG) || IG == 0.0)
        return refuse(msg, len, "inertia IG = %g must be > 0 kg m^2 (or < 0: the uniform polygon's)", IG);
    if (IG < 0.0 && centre)
        return refuse(msg, len, "a uniform inertia (IG < 0) needs the polygon's centroid as centre (centre NULL)");
    /* lengths from vertex 0 (no cancellation of a frame far away); ext the polygon's extent, tol its square's
     * rounding: a turn within it is a straight line */
    double ext = 0.0;
    for (int i = 0; i < n; i++) ext = fmax(ext, fmax(fabs(x[i] - x[0]), fabs(y[i] - y[0])));
    double tol = 1e-12 * ext * ext, A2 = 0.0;
    for (int i = 0; i < n; i++) {
        int j = (i + 1) % n;
        A2 += (x[i] - x[0]) * (y[j] - y[0]) - (x[j] - x[0]) * (y[i] - y[0]);
    }
    if (!(fabs(A2) > tol)) return refuse(msg, len, "the polygon has no area");
    /* counter-clockwise, repeated vertices once */
    double px[EN_POLY_MAX], py[EN_POLY_MAX], vx[EN_POLY_MAX], vy[EN_POLY_MAX];
    int np = 0;
    for (int i = 0; i < n; i++) {
        int src = A2 > 0 ? i : n - 1 - i;
        if (np && x[src] == px[np - 1] && y[src] == py[np - 1]) continue;
        px[np] = x[src], py[np++] = y[src];
    }
    while (np > 1 && px[np - 1] == px[0] && py[np - 1] == py[0]) np--;
    /* convex: every turn to the left; straight ones (collinear vertices) dropped */
    int nv = 0;
    for (int i = 0; i < np; i++) {
        int a = (i + np - 1) % np, c = (i + 1) % np;
        double cr = (px[i] - px[a]) * (py[c] - py[i]) - (py[i] - py[a]) * (px[c] - px[i]);
        if (cr < -tol) return refuse(msg, len, "the polygon is not convex at vertex (%g, %g)", px[i], py[i]);
        if (cr > tol) vx[nv] = px[i], vy[nv++] = py[i];
    }
    if (nv < 3) return refuse(msg, len, "the polygon has fewer than 3 corners that are not collinear");
    /* simple: its turns add to one full turn (a star's to more) */
    double turn = 0.0;
    for (int i = 0; i < nv; i++) {
        int a = (i + nv - 1) % nv, c = (i + 1) % nv;
        double ux = vx[i] - vx[a], uy = vy[i] - vy[a], wx = vx[c] - vx[i], wy = vy[c] - vy[i];
        turn += atan2(ux * wy - uy * wx, ux * wx + uy * wy);
    }
    if (fabs(turn - 2.0 * M_PI) > 1e-6) return refuse(msg, len, "the polygon crosses itself (it turns %g times)",
                                                      turn / (2.0 * M_PI));
    /* the base: the lowest vertices, at y = 0, two of them (a convex polygon has at most two at one height) */
    double ymin = INFINITY, ymax = -INFINITY;
    for (int i = 0; i < nv; i++) ymin = fmin(ymin, vy[i]), ymax = fmax(ymax, vy[i]);
    if (ymin != 0.0) return refuse(msg, len, "the lowest vertex is at y = %g: the base must lie at y = 0", ymin);
    int iL = -1, iR = -1, nTop = 0, iT[2] = {0, 0};
    for (int i = 0; i < nv; i++) {
        if (vy[i] == 0.0) {
            if (iL < 0 || vx[i] < vx[iL]) iL = i;
            if (iR < 0 || vx[i] > vx[iR]) iR = i;
        }
        if (vy[i] == ymax && nTop < 2) iT[nTop++] = i;
    }
    if (iL == iR) return refuse(msg, len, "one vertex at y = 0: the base is not flat (the body could not stand)");
    double xL = vx[iL], xR = vx[iR];
    /* area, centroid and polar second moment of the uniform polygon (Bourke 1988, Steger 1996: sums over its edges), from
     * vertex 0 */
    double A = 0.0, Cx = 0.0, Cy = 0.0, J = 0.0;
    for (int i = 0; i < nv; i++) {
        int j = (i + 1) % nv;
        double xi = vx[i] - vx[0], yi = vy[i] - vy[0], xj = vx[j] - vx[0], yj = vy[j] - vy[0];
        double cr = xi * yj - xj * yi;
        A += 0.5 * cr;
        Cx += (xi + xj) * cr;
        Cy += (yi + yj) * cr;
        J += (xi * xi + xi * xj + xj * xj + yi * yi + yi * yj + yj * yj) * cr;
    }
    Cx /= 6.0 * A;
    Cy /= 6.0 * A;
    J = J / 12.0 - A * (Cx * Cx + Cy * Cy); /* about the centroid */
    double xG = centre ? centre[0] : Cx + vx[0], yG = centre ? centre[1] : Cy + vy[0];
    double Ic = IG > 0.0 ? IG : m / A * J;
    if (!(yG > 0.0)) return refuse(msg, len, "the centre of mass at y = %g must lie above the base", yG);
    if (!(xL < xG && xG < xR))
        return refuse(msg, len, "the centre of mass at x = %g must lie between the base corners %g and %g "
                      "(the body could not stand)", xG, xL, xR);
    for (int i = 0; i < nv; i++) {
        int j = (i + 1) % nv;
        if ((vx[j] - vx[i]) * (yG - vy[i]) - (vy[j] - vy[i]) * (xG - vx[i]) < -tol)
            return refuse(msg, len, "the centre of mass (%g, %g) lies outside the polygon", xG, yG);
    }
    if (!(Ic > 0.0) || !isfinite(Ic)) return refuse(msg, len, "inertia IG = %g must be > 0 kg m^2", Ic);
    memset(B, 0, sizeof(*B));
    B->m = m;
    B->Ic = Ic;
    B->cx[0] = xL - xG;
    B->cx[1] = xR - xG;
    B->cy = -yG;
    B->xG = xG;
    B->xa[0] = xL;
    B->xa[1] = xR;
    B->b = fmax(xG - xL, xR - xG);
    B->h = yG;
    for (int i = 0; i < 2; i++) B->iIo[i] = 1.0 / (Ic + m * (B->cx[i] * B->cx[i] + yG * yG));
    B->ht = ymax - yG;
    if (nTop == 2) { /* a flat top: the edge at the greatest height */
        double a = fmin(vx[iT[0]], vx[iT[1]]), c = fmax(vx[iT[0]], vx[iT[1]]);
        B->tm = 0.5 * (a + c);
        B->tw = 0.5 * (c - a);
    } else {
        B->tm = vx[iT[0]];
        B->tw = 0.0;
    }
    /* the hull edges next to the corners (counter-clockwise: the base runs from left to right, the right corner's
     * edge follows it, the left corner's comes before it); turning about a corner by their angle from the base
     * lays them on the support */
    int r = (iR + 1) % nv, l = (iL + nv - 1) % nv;
    B->over[1] = atan2(vy[r] - vy[iR], vx[r] - vx[iR]);
    B->over[0] = atan2(vy[l] - vy[iL], -(vx[l] - vx[iL]));
    return 0;
}

int engine_check_stack(const EnSystem *s, char *msg, size_t len) {
    if (msg && len) msg[0] = '\0';
    for (int k = 0; k + 1 < s->nb; k++)
        if (!(s->body[k].tw > 0.0))
            return refuse(msg, len, "body %d carries body %d but has no flat top face", k + 1, k + 2);
    return 0;
}

/* engine_point, and with ROWS = 0 engine_corner (a constant where this is inlined) */
static inline __attribute__((always_inline)) void point(const EnSystem *s, int k, int c, const double *y, EnPoint *p,
                                                        const int ROWS) {
    int nb = s->nb;
    const EnBody *B = &s->body[k];
    /* the rows over the bodies' coordinates (a reader reads no further: the rest of EnPoint's rows is undefined) */
    if (ROWS)
        for (int q = 0; q < 3 * nb; q++) p->wN[q] = p->wT[q] = 0.0;
    double th = y[EN_TH(k)], ck = cos(th), sk = sin(th);
    double w = y[EN_W(k)];
    double Rd[2], JRd[2];
    rot(ck, sk, B->cx[c > 0], B->cy, Rd);
    JRd[0] = Rd[1]; /* d(rot d)/dtheta = J rot d, J (x, y) = (y, -x) */
    JRd[1] = -Rd[0];
    double P[2] = {y[EN_POS(nb, k, 0)] + Rd[0], y[EN_POS(nb, k, 1)] + Rd[1]};
    double Pd[2] = {y[EN_VEL(nb, k, 0)] + w * JRd[0], y[EN_VEL(nb, k, 1)] + w * JRd[1]};
    /* the support's frame: origin its centre of mass, top normal n, tangent t, its top face's height above the
     * centre hs, its axis's offset -xs from the centre along t (slips are measured from the axis), rotation rate ws */
    double n[2] = {0.0, 1.0}, t[2] = {1.0, 0.0}, D[2] = {P[0], P[1]}, Dd[2] = {Pd[0], Pd[1]}, hs = 0.0, ws = 0.0;
    double xs = 0.0;
    int j = k - 1;
    if (j >= 0) {
        double thj = y[EN_TH(j)], cj = cos(thj), sj = sin(thj);
        ws = y[EN_W(j)];
        n[0] = sj;
        n[1] = cj;
        t[0] = cj;
        t[1] = -sj;
        D[0] -= y[EN_POS(nb, j, 0)];
        D[1] -= y[EN_POS(nb, j, 1)];
        Dd[0] -= y[EN_VEL(nb, j, 0)];
        Dd[1] -= y[EN_VEL(nb, j, 1)];
        hs = s->body[j].ht;
        xs = s->body[j].xG;
    }
    double nD = dot(n, D), tD = dot(t, D), nDd = dot(n, Dd), tDd = dot(t, Dd);
    p->g = nD - hs;
    p->gd = ws * tD + nDd;
    p->xi = tD + xs;
    p->xid = -ws * nD + tDd;
    if (!ROWS) return;
    p->wN[EN_Q(k, 0)] = n[0];
    p->wN[EN_Q(k, 1)] = n[1];
    p->wN[EN_Q(k, 2)] = dot(n, JRd);
    p->wT[EN_Q(k, 0)] = t[0];
    p->wT[EN_Q(k, 1)] = t[1];
    p->wT[EN_Q(k, 2)] = dot(t, JRd);
    p->bN = -w * w * dot(n, Rd);
    p->bT = -w * w * dot(t, Rd);
    if (j >= 0) {
        p->wN[EN_Q(j, 0)] = -n[0];
        p->wN[EN_Q(j, 1)] = -n[1];
        p->wN[EN_Q(j, 2)] = tD;
        p->wT[EN_Q(j, 0)] = -t[0];
        p->wT[EN_Q(j, 1)] = -t[1];
        p->wT[EN_Q(j, 2)] = -nD;
        p->bN += -ws * ws * nD + 2.0 * ws * tDd;
        p->bT += -ws * ws * tD - 2.0 * ws * nDd;
    }
}

/* The support's top corner c against body k's base face (k > 0; docs/columns.md, "Overhangs"): E the corner Q from
 * k's centre, n and t k's base normal (up) and tangent; gap cy - n . E (Q below the base: open), slip coordinate
 * xtop + cx - t . E (xtop Q's place from the support's axis, cx k's corner from its centre: k's corner's place on the
 * support's top were the two flat, so that xi - xa is k's slip). With dn/dtheta = t, dt/dtheta = -n. */
static void point_over(const EnSystem *s, int k, int c, const double *y, EnPoint *p, const int ROWS) {
    int nb = s->nb, j = k - 1;
    const EnBody *B = &s->body[k], *S = &s->body[j];
    if (ROWS)
        for (int q = 0; q < 3 * nb; q++) p->wN[q] = p->wT[q] = 0.0;
    double th = y[EN_TH(k)], ck = cos(th), sk = sin(th), w = y[EN_W(k)];
    double thj = y[EN_TH(j)], cj = cos(thj), sj = sin(thj), wj = y[EN_W(j)];
    double xtop = S->tm + c * S->tw, Rq[2], JRq[2];
    rot(cj, sj, xtop - S->xG, S->ht, Rq);
    JRq[0] = Rq[1];
    JRq[1] = -Rq[0];
    double n[2] = {sk, ck}, t[2] = {ck, -sk};
    double E[2] = {y[EN_POS(nb, j, 0)] + Rq[0] - y[EN_POS(nb, k, 0)], y[EN_POS(nb, j, 1)] + Rq[1] - y[EN_POS(nb, k, 1)]};
    double Ed[2] = {y[EN_VEL(nb, j, 0)] + wj * JRq[0] - y[EN_VEL(nb, k, 0)],
                    y[EN_VEL(nb, j, 1)] + wj * JRq[1] - y[EN_VEL(nb, k, 1)]};
    double nE = dot(n, E), tE = dot(t, E), nEd = dot(n, Ed), tEd = dot(t, Ed);
    p->g = B->cy - nE;
    p->gd = -(w * tE + nEd);
    p->xi = xtop + B->cx[c > 0] - tE;
    p->xid = w * nE - tEd;
    if (!ROWS) return;
    p->wN[EN_Q(k, 0)] = n[0];
    p->wN[EN_Q(k, 1)] = n[1];
    p->wN[EN_Q(k, 2)] = -tE;
    p->wN[EN_Q(j, 0)] = -n[0];
    p->wN[EN_Q(j, 1)] = -n[1];
    p->wN[EN_Q(j, 2)] = -dot(n, JRq);
    p->wT[EN_Q(k, 0)] = t[0];
    p->wT[EN_Q(k, 1)] = t[1];
    p->wT[EN_Q(k, 2)] = nE;
    p->wT[EN_Q(j, 0)] = -t[0];
    p->wT[EN_Q(j, 1)] = -t[1];
    p->wT[EN_Q(j, 2)] = -dot(t, JRq);
    p->bN = w * w * nE - 2.0 * w * tEd + wj * wj * dot(n, Rq);
    p->bT = w * w * tE + 2.0 * w * nEd + wj * wj * dot(t, Rq);
}

void engine_point(const EnSystem *s, int k, int c, const double *y, EnPoint *p) { point(s, k, c, y, p, 1); }
void engine_corner(const EnSystem *s, int k, int c, const double *y, EnPoint *p) { point(s, k, c, y, p, 0); }
static inline int over_of(const EnMode *m, int k, int c) { return m && k > 0 && m->over[k][c > 0]; }
void engine_point_m(const EnSystem *s, const EnMode *m, int k, int c, const double *y, EnPoint *p) {
    if (over_of(m, k, c)) point_over(s, k, c, y, p, 1);
    else point(s, k, c, y, p, 1);
}
void engine_corner_m(const EnSystem *s, const EnMode *m, int k, int c, const double *y, EnPoint *p) {
    if (over_of(m, k, c)) point_over(s, k, c, y, p, 0);
    else point(s, k, c, y, p, 0);
}
double engine_overhang(const EnSystem *s, int k, int c, const double *y) {
    EnPoint p;
    point(s, k, c, y, &p, 0);
    const EnBody *S = &s->body[k - 1];
    return c * (p.xi - S->tm) - S->tw;
}

/* The inverse mass matrix (diagonal) and the generalised forces of gravity and of the ground's
 * motion (the inertial force -m (ah, av)) of the free bodies. */
static void free_terms(const EnSystem *s, double ah, double av, double *Minv, double *fext) {
    for (int k = 0; k < s->nb; k++) {
        const EnBody *B = &s->body[k];
        Minv[EN_Q(k, 0)] = Minv[EN_Q(k, 1)] = 1.0 / B->m;
        Minv[EN_Q(k, 2)] = 1.0 / B->Ic;
        fext[EN_Q(k, 0)] = -B->m * ah;
        fext[EN_Q(k, 1)] = -B->m * (s->g + av);
        fext[EN_Q(k, 2)] = 0.0;
    }
}

/* The state's positions (rates = 0) or rates (rates = 1) in q-space order. */
static void gather(const EnSystem *s, const double *y, int rates, double *q) {
    for (int k = 0; k < s->nb; k++)
        for (int i = 0; i < 3; i++) q[EN_Q(k, i)] = y[rates ? EN_VEL(s->nb, k, i) : EN_POS(s->nb, k, i)];
}
/* y's positions or rates += d (q-space order). */
static void scatter_add(const EnSystem *s, double *y, int rates, const double *d) {
    for (int k = 0; k < s->nb; k++)
        for (int i = 0; i < 3; i++) y[rates ? EN_VEL(s->nb, k, i) : EN_POS(s->nb, k, i)] += d[EN_Q(k, i)];
}

static double wdot(const double *a, const double *Minv, const double *b, int nq) {
    double x = 0.0;
    for (int i = 0; i < nq; i++) x += a[i] * Minv[i] * b[i];
    return x;
}

/* Gaussian elimination with partial pivoting of the n x n system A x = r (A, r overwritten). */
static int solve_dense(int n, double A[][EN_ROWS], double *r, double *x) {
    for (int c = 0; c < n; c++) {
        int p = c;
        for (int i = c + 1; i < n; i++)
            if (fabs(A[i][c]) > fabs(A[p][c])) p = i;
        if (!(fabs(A[p][c]) > 1e-300)) return 0;
        if (p != c) {
            for (int j = 0; j < n; j++) {
                double tmp = A[c][j];
                A[c][j] = A[p][j];
                A[p][j] = tmp;
            }
            double tmp = r[c];
            r[c] = r[p];
            r[p] = tmp;
        }
        for (int i = c + 1; i < n; i++) {
            double f = A[i][c] / A[c][c];
            if (f == 0.0) continue;
            for (int j = c; j < n; j++) A[i][j] -= f * A[c][j];
            r[i] -= f * r[c];
        }
    }
    for (int i = n - 1; i >= 0; i--) {
        double v = r[i];
        for (int j = i + 1; j < n; j++) v -= A[i][j] * x[j];
        x[i] = v / A[i][i];
    }
    return 1;
}

/* A x = r for n <= 2 in closed form (Cramer), else by solve_dense. Returns 0 if singular. */
static int solve_small(int n, double A[][EN_ROWS], double *r, double *x) {
    if (n == 1) {
        if (!(fabs(A[0][0]) > 1e-300)) return 0;
        x[0] = r[0] / A[0][0];
        return 1;
    }
    if (n == 2) {
        double det = A[0][0] * A[1][1] - A[0][1] * A[1][0];
        if (!(fabs(det) > 1e-300)) return 0;
        x[0] = (r[0] * A[1][1] - A[0][1] * r[1]) / det;
        x[1] = (A[0][0] * r[1] - A[1][0] * r[0]) / det;
        return 1;
    }
    return solve_dense(n, A, r, x);
}

/* The first closed corner of body k in m (-1, +1), or 0. */
static int first_closed(const EnMode *m, int k) { return m->closed[k][0] ? -1 : m->closed[k][1] ? 1 : 0; }

/* The constraints of mode m at the state y on a = a0 + Minv (sum of force columns x unknowns):
 * row . a + bias = 0 (bias: withBias; accelerations and forces), or row . a = 0 (a0 the rates before
 * an impact: the rates after and the impulses). a goes to f->qdd, the forces (impulses) to f->N, f->T. */
static int solve_set(const EnSystem *s, const EnMode *m, const double *y, const double *a0, int withBias,
                     EnForces *f) {
    int nb = s->nb, nq = 3 * nb;
    double Minv[EN_NQ], fext[EN_NQ];
    free_terms(s, 0.0, 0.0, Minv, fext);
    /* constraint rows and force columns: one per closed corner, one per sticking body */
    double row[EN_ROWS][EN_NQ], col[EN_ROWS][EN_NQ], bias[EN_ROWS];
    int who[EN_ROWS], corner[EN_ROWS], nr = 0;
    for (int k = 0; k < nb; k++) {
        EnPoint P[2];
        int any = 0;
        for (int i = 0; i < 2; i++) {
            if (!m->closed[k][i]) continue;
            engine_point_m(s, m, k, 2 * i - 1, y, &P[i]);
            for (int q_ = 0; q_ < nq; q_++) row[nr][q_] = P[i].wN[q_];
            for (int q = 0; q < nq; q++) col[nr][q] = P[i].wN[q] - m->sigma[k] * s->mu[k] * P[i].wT[q];
            bias[nr] = P[i].bN;
            who[nr] = k;
            corner[nr] = i;
            nr++;
            any = 1;
        }
        if (any && m->sigma[k] == 0) {
            const EnPoint *p = &P[m->closed[k][0] ? 0 : 1];
            for (int q_ = 0; q_ < nq; q_++) row[nr][q_] = p->wT[q_];
            for (int q_ = 0; q_ < nq; q_++) col[nr][q_] = p->wT[q_];
            bias[nr] = p->bT;
            who[nr] = k;
            corner[nr] = -1;
            nr++;
        }
    }
    double A[EN_ROWS][EN_ROWS], r[EN_ROWS], lam[EN_ROWS];
    for (int i = 0; i < nr; i++) {
        r[i] = withBias ? -bias[i] : 0.0;
        for (int q = 0; q < nq; q++) r[i] -= row[i][q] * a0[q];
        for (int j = 0; j < nr; j++) A[i][j] = wdot(row[i], Minv, col[j], nq);
    }
    if (nr && !solve_dense(nr, A, r, lam)) return 0;
    memset(f, 0, sizeof(*f));
    for (int q = 0; q < nq; q++) {
        double F = 0.0;
        for (int j = 0; j < nr; j++) F += col[j][q] * lam[j];
        f->qdd[q] = a0[q] + Minv[q] * F;
    }
    /* a body flat on its support turns with it: exactly (no rounding left in its relative rotation,
     * nor, on the ground, in its height) */
    for (int k = 0; k < nb; k++)
        if (m->closed[k][0] && m->closed[k][1]) {
            f->qdd[EN_Q(k, 2)] = k > 0 ? f->qdd[EN_Q(k - 1, 2)] : 0.0;
            if (k == 0) f->qdd[EN_Q(0, 1)] = 0.0;
        }
    for (int j = 0; j < nr; j++) {
        int k = who[j];
        if (corner[j] >= 0) {
            f->N[k][corner[j]] = lam[j];
            if (m->sigma[k]) f->T[k] -= m->sigma[k] * s->mu[k] * lam[j];
        } else {
            f->T[k] = lam[j];
        }
    }
    return 1;
}

/* ---------------------------------------------------------------------- chains */

int engine_is_chain(const EnSystem *s, const EnMode *m) {
    for (int k = 0; k < s->nb; k++)
        if (!(m->closed[k][0] || m->closed[k][1]) || m->sigma[k]) return 0;
    return 1;
}

/* J (x, y) = (y, -x): the velocity of a point at offset r on a body turning at rate w is w J r */
static void perp(const double r[2], double out[2]) {
    out[0] = r[1];
    out[1] = -r[0];
}

/* The forces of bodies past a system's own that readers still take as 0: those of the two blocks the outputs name
 * (block1.*, block2.*), whatever EN_MAX_BODIES (the clears below go that far, not to EN_MAX_BODIES, so that a larger
 * maximum costs a run of one or two bodies nothing). */
#define EN_READ_BODIES (EN_MAX_BODIES < 2 ? EN_MAX_BODIES : 2)

/* Every force and acceleration of f zero, field by field: memset's string store, on every evaluation, cost more than the
 * chain's own arithmetic and kept the stores that follow it from reaching the loads that read them soon after. */
static inline void forces_clear(EnForces *f) {
    for (int q = 0; q < EN_NQ; q++) f->qdd[q] = 0.0;
    for (int k = 0; k < EN_MAX_BODIES; k++) f->N[k][0] = f->N[k][1] = f->T[k] = f->xidd[k] = 0.0;
}

/* The chain of one body on the ground, written out (the right-hand side of most runs): flat, or on its
 * corner c (X = D - r, with D the corner's place on the ground and r its offset from the centre), the contact
 * sticking or sliding (sigma: the slip xi then a second coordinate, X'' gains xi'' along the ground, and the
 * friction -sigma mu N works on it). As chain_nd for one body, its terms of the support dropped (the ground
 * does not turn); tests/c/engine_chain.c checks both against the constrained system. */
/* Body k of a chain placed from its support a (centre Xa, velocity Va, rate wa): its contact point D from the support's
 * centre and r from its own centre (their perpendiculars JD, Jr), its rate wb and slip rate xid along the tangent t:
 * its centre and velocity to Xb, Vb and yout. */
static inline __attribute__((always_inline)) void place(double Xb[2], double Vb[2], double *yout, int nb, int k,
                                                        const double Xa[2], const double Va[2], double wa, double wb,
                                                        const double D[2], const double JD[2], const double *r,
                                                        const double Jr[2], double xid, const double t[2]) {
    for (int i = 0; i < 2; i++) {
        Xb[i] = yout[EN_POS(nb, k, i)] = Xa[i] + D[i] - r[i];
        Vb[i] = yout[EN_VEL(nb, k, i)] = Va[i] + wa * JD[i] - wb * Jr[i] + xid * t[i];
    }
}

static inline __attribute__((always_inline)) int chain_one(const int SLIDES, const EnSystem *s, const EnMode *m,
                                                           const double *xi0, const double *yin, double *yout,
                                                           double ah, double av, EnForces *f, double *slipRate,
                                                           EnForces *fa) {
    const EnBody *B = &s->body[0];
    double gv = s->g + av, smu = SLIDES ? m->sigma[0] * s->mu[0] : 0.0;
    /* placed: a sliding contact's slip and slip rate from yin, a sticking one's anchor and no slip rate */
    double xi = xi0 ? (SLIDES ? yin[EN_XI(1, 0)] : xi0[0]) : 0.0, xid = SLIDES && xi0 ? yin[EN_XID(1, 0)] : 0.0;
    if (m->closed[0][0] && m->closed[0][1]) { /* flat: at rest on the ground, or sliding on it */
        if (yout) {
            yout[EN_TH(0)] = yout[EN_W(0)] = 0.0;
            yout[EN_POS(1, 0, 0)] = xi + B->xG; /* the axis at the slip, the centre off it */
            yout[EN_POS(1, 0, 1)] = -B->cy;
            yout[EN_VEL(1, 0, 0)] = xid;
            yout[EN_VEL(1, 0, 1)] = 0.0;
        }
        if (slipRate && SLIDES) slipRate[0] = xi0 ? xid : yin[EN_VEL(1, 0, 0)];
        if (!f) return 1;
        for (int k = 1; k < EN_READ_BODIES; k++) f->N[k][0] = f->N[k][1] = f->T[k] = 0.0;
        for (int q = 3; q < 3 * EN_READ_BODIES; q++) f->qdd[q] = 0.0;
        double N = B->m * gv, T = SLIDES ? -smu * N : B->m * ah;
        f->qdd[0] = SLIDES ? -ah - smu * gv : 0.0;
        f->qdd[1] = f->qdd[2] = 0.0;
        if (SLIDES) f->xidd[0] = f->qdd[0], f->xidd[1] = 0.0;
        f->T[0] = T;
        /* the moment balance about the centre: cx0 N_left + cx1 N_right - cy T = 0 (counter-clockwise) */
        f->N[0][1] = (B->cy * T - B->cx[0] * N) / (B->cx[1] - B->cx[0]);
        f->N[0][0] = N - f->N[0][1];
        if (fa) { /* the slopes in ah: sliding, the centre's -1 and no force; sticking, T's m and its moment */
            forces_clear(fa);
            fa->qdd[0] = SLIDES ? -1.0 : 0.0;
            if (SLIDES) fa->xidd[0] = -1.0;
            fa->T[0] = SLIDES ? 0.0 : B->m;
            fa->N[0][1] = fa->T[0] * B->cy / (B->cx[1] - B->cx[0]);
            fa->N[0][0] = -fa->N[0][1];
        }
        return 1;
    }
    int c = m->closed[0][1] ? 1 : -1;
    double th = yin[EN_TH(0)], w = yin[EN_W(0)], ck = cos(th), sk = sin(th);
    double cx = B->cx[c > 0], cy = B->cy, iIo = B->iIo[c > 0];
    double r[2] = {cx * ck + cy * sk, -cx * sk + cy * ck}; /* the corner from the centre */
    double G[2] = {-r[1], r[0]};                                            /* -J r */
    if (yout) {
        yout[EN_TH(0)] = th;
        yout[EN_W(0)] = w;
        yout[EN_POS(1, 0, 0)] = xi + B->xa[c > 0] - r[0];
        yout[EN_POS(1, 0, 1)] = -r[1];
        yout[EN_VEL(1, 0, 0)] = w * G[0] + xid;
        yout[EN_VEL(1, 0, 1)] = w * G[1];
    }
    /* the corner's slip rate along the ground: the centre's velocity plus w J r */
    if (slipRate && SLIDES) slipRate[0] = xi0 ? xid : yin[EN_VEL(1, 0, 0)] + w * r[1];
    if (!f) return 1;
    for (int k = 1; k < EN_READ_BODIES; k++) f->N[k][0] = f->N[k][1] = f->T[k] = 0.0;
    for (int q = 3; q < 3 * EN_READ_BODIES; q++) f->qdd[q] = 0.0;
    double kap[2] = {w * w * r[0], w * w * r[1]}, al, xdd = 0.0;
    if (!SLIDES) { /* the moment about the corner over the inertia about it (|G| = |r|: the corner's distance) */
        al = -B->m * (G[0] * (ah + kap[0]) + G[1] * (gv + kap[1])) * iIo;
    } else {
        double A = B->m * (G[0] * G[0] + G[1] * G[1]) + B->Ic; /* coordinates (theta, xi): the reduced system of chain_nd, its friction row N = m (Y'' + g + av) */
        double fk0 = -B->m * (ah + kap[0]), fk1 = -B->m * (gv + kap[1]);
        double A01 = B->m * G[0], A10 = B->m * (G[0] + smu * G[1]), A11 = B->m;
        double r0 = G[0] * fk0 + G[1] * fk1, r1 = fk0 + smu * fk1, det = A * A11 - A01 * A10;
        if (!(fabs(det) > 1e-300)) return 0;
        al = (r0 * A11 - A01 * r1) / det;
        xdd = (A * r1 - A10 * r0) / det;
    }
    double acc[2] = {G[0] * al + kap[0] + xdd, G[1] * al + kap[1]};
    f->qdd[0] = acc[0];
    f->qdd[1] = acc[1];
    f->qdd[2] = al;
    if (SLIDES) f->xidd[0] = xdd, f->xidd[1] = 0.0;
    double N = B->m * (acc[1] + gv);
    f->T[0] = SLIDES ? -smu * N : B->m * (acc[0] + ah);
    f->N[0][c > 0] = N;
    f->N[0][c < 0] = 0.0;
    if (fa) { /* the same in ah alone: the right-hand side's -m (1, 0) on the centre */
        double dal, dxdd = 0.0;
        if (!SLIDES) {
            dal = -B->m * G[0] * iIo;
        } else {
            double A = B->m * (G[0] * G[0] + G[1] * G[1]) + B->Ic, A01 = B->m * G[0], A10 = B->m * (G[0] + smu * G[1]);
            double A11 = B->m, det = A * A11 - A01 * A10, dr0 = -B->m * G[0], dr1 = -B->m;
            dal = (dr0 * A11 - A01 * dr1) / det;
            dxdd = (A * dr1 - A10 * dr0) / det;
        }
        forces_clear(fa);
        fa->qdd[0] = G[0] * dal + dxdd;
        fa->qdd[1] = G[1] * dal;
        fa->qdd[2] = dal;
        if (SLIDES) fa->xidd[0] = dxdd;
        double dN = B->m * fa->qdd[1];
        fa->T[0] = SLIDES ? -smu * dN : B->m * (fa->qdd[0] + 1.0);
        fa->N[0][c > 0] = dN;
    }
    return 1;
}

/* The chain (every body on a closed corner of its support, or flat on it; docs/flight.md, "A chain"):
 * reduced coordinates z, the rotations of the bodies that rock (a flat body turns with its support) and the
 * slips of the contacts that slide. Body k's rotation is s_k . z, its centre's acceleration G_k z'' + kappa_k;
 * its closed corner lies on its support's top (a sticking corner is a material point of the support too),
 *     X_k = X_j + D - Rd,
 *     X_k'' = X_j'' + alpha_j J D - w_j^2 D - alpha_k J Rd + w_k^2 Rd (+ xi'' t + 2 xi' w_j J t, sliding),
 * with D the corner's offset from the support's centre, Rd from body k's. Virtual work:
 * sum_k G_k^T (m_k X_k'' - f_k) + s_k Ic_k alpha_k = the sliding contacts' friction on their slips, an
 * nd x nd system. The forces follow body by body from the top: the contact force on body k,
 * F_k = m_k X_k'' - f_k + F_(k+1), split between a flat body's corners by its moment balance. The rotations
 * and rates are read from yin; with anchors xi0 (every contact sticking) the centres and their velocities
 * are placed in yout, with the rotations and rates. ND: the most coordinates; SLIDES: whether a contact
 * may slide; IMP: the plastic impact onto the chain instead (the rates before in yin take the forces' place,
 * without the terms of the rates: the rates after go to f->qdd, the impulses to f->N, f->T). All three are
 * constants where this is inlined, so that its loops unroll and the other form's terms drop out. */
static inline __attribute__((always_inline)) int chain_nd(const int ND, const int SLIDES, const int IMP,
                                                          const EnSystem *s, const EnMode *m, const double *xi0,
                                                          const double *yin, double *yout, double ah, double av,
                                                          EnForces *f, double *slipRate) {
    enum { NB = EN_MAX_BODIES, NDMAX = 2 * EN_MAX_BODIES, NS = EN_MAX_BODIES + 1 };
    int nb = s->nb, nd = 0;
    /* index 0 the ground (fixed: its accelerations are in the forces), body k at k + 1; so every body has
     * a support, and the loops over the coordinates have fixed lengths */
    double G[NS][2][NDMAX], kap[NS][2], sel[NS][NDMAX], w[NS], th[NS], cs[NS][2], X[NS][2], V[NS][2], hs[NS], xs[NS];
    double tms[NS], tws[NS];
    for (int d = 0; d < ND; d++) G[0][0][d] = G[0][1][d] = sel[0][d] = 0.0;
    kap[0][0] = kap[0][1] = X[0][0] = X[0][1] = V[0][0] = V[0][1] = w[0] = th[0] = hs[0] = xs[0] = cs[0][1] = 0.0;
    tms[0] = tws[0] = 0.0;
    cs[0][0] = 1.0;
    double n[NB][2], t[NB][2]; /* each contact's face's normal and tangent (the support's top; overhanging, k's base) */
    double Rd[NB][2][2], D[NB][2], fk[NB][2], rk[NB][2];
    int cor[NB], flat[NB], slip[NB];
    for (int k = 0; k < nb; k++) {
        const EnBody *B = &s->body[k];
        int b = k + 1, a = k; /* the body's and its support's index */
        hs[b] = B->ht; /* its top face above its centre, and its centre from its axis (what a body on it reads) */
        xs[b] = B->xG;
        tms[b] = B->tm;
        tws[b] = B->tw;
        flat[k] = m->closed[k][0] && m->closed[k][1];
        cor[k] = first_closed(m, k);
        if (flat[k]) { /* turning with its support */
            th[b] = th[a];
            w[b] = w[a];
            cs[b][0] = cs[a][0];
            cs[b][1] = cs[a][1];
            for (int d = 0; d < ND; d++) sel[b][d] = sel[a][d];
        } else {
            th[b] = yin[EN_TH(k)];
            w[b] = yin[EN_W(k)];
            cs[b][0] = cos(th[b]);
            cs[b][1] = sin(th[b]);
            for (int d = 0; d < ND; d++) sel[b][d] = 0.0;
            sel[b][nd++] = 1.0;
        }
        if (yout) {
            yout[EN_TH(k)] = th[b];
            yout[EN_W(k)] = w[b];
        }
        slip[k] = SLIDES && m->sigma[k] ? nd++ : -1; /* a sliding contact's slip along the support's top */
        for (int i = 0; i < 2; i++) rot(cs[b][0], cs[b][1], B->cx[i], B->cy, Rd[k][i]);
        /* the contact the chain holds (its first closed end): body k's corner on the support's top, or with an overhang
         * (ov) the support's top corner on k's base (docs/columns.md, "Overhangs"): D the point from the support's
         * centre, r from body k's; n, t the face's normal and tangent (the support's top, or k's base) */
        int ov = k > 0 && m->over[k][cor[k] > 0];
        const double *r = Rd[k][cor[k] > 0];
        double JD[2], Jr[2], rv[2];
        double xid = 0.0; /* a sliding contact's slip rate xi' (along the support's top, relative to it) */
        if (!ov) {
            n[k][0] = cs[a][1], n[k][1] = cs[a][0], t[k][0] = cs[a][0], t[k][1] = -cs[a][1];
            perp(r, Jr);
            if (xi0) { /* the corner at its anchor (or, sliding, its slip) on the support's top: the centre follows */
                int sl = SLIDES && slip[k] >= 0;
                /* the corner along the support's top from the support's centre: slip plus the corner's offset from the
                 * body's axis, less the support's centre's from its axis */
                double xi = (sl ? yin[EN_XI(nb, k)] : xi0[k]) + B->xa[cor[k] > 0] - xs[a];
                if (sl) xid = yin[EN_XID(nb, k)];
                for (int i = 0; i < 2; i++) D[k][i] = xi * t[k][i] + hs[a] * n[k][i];
                perp(D[k], JD);
                place(X[b], V[b], yout, nb, k, X[a], V[a], w[a], w[b], D[k], JD, r, Jr, xid, t[k]);
            } else {
                for (int i = 0; i < 2; i++) {
                    X[b][i] = yin[EN_POS(nb, k, i)];
                    V[b][i] = yin[EN_VEL(nb, k, i)];
                    D[k][i] = X[b][i] + r[i] - X[a][i];
                }
                perp(D[k], JD);
            }
        } else {
            n[k][0] = cs[b][1], n[k][1] = cs[b][0], t[k][0] = cs[b][0], t[k][1] = -cs[b][1];
            /* the support's top corner: fixed on it */
            double xtop = tms[a] + cor[k] * tws[a], dx = xtop - xs[a];
            D[k][0] = dx * cs[a][0] + hs[a] * cs[a][1];
            D[k][1] = -dx * cs[a][1] + hs[a] * cs[a][0];
            perp(D[k], JD);
            if (xi0) { /* the point of k's base at the slip (xtop - xG - slip from k's centre) on it */
                int sl = SLIDES && slip[k] >= 0;
                double sb = xtop - B->xG - (sl ? yin[EN_XI(nb, k)] : xi0[k]);
                if (sl) xid = yin[EN_XID(nb, k)];
                for (int i = 0; i < 2; i++) rv[i] = sb * t[k][i] + B->cy * n[k][i];
                r = rv;
                perp(r, Jr);
                place(X[b], V[b], yout, nb, k, X[a], V[a], w[a], w[b], D[k], JD, r, Jr, xid, t[k]);
            } else {
                for (int i = 0; i < 2; i++) {
                    X[b][i] = yin[EN_POS(nb, k, i)];
                    V[b][i] = yin[EN_VEL(nb, k, i)];
                    rv[i] = D[k][i] + X[a][i] - X[b][i];
                }
                r = rv;
                perp(r, Jr);
            }
        }
        rk[k][0] = r[0], rk[k][1] = r[1];
        /* a sliding contact's slip rate (placed: as given); its Coriolis term 2 xi' w J t, w the face's rate (the
         * support's, or with an overhang k's own) */
        double cor2[2] = {0.0, 0.0};
        if (!IMP && SLIDES && slip[k] >= 0) {
            if (!xi0 && !ov) {
                double Pd[2] = {V[b][0] + w[b] * Jr[0] - V[a][0], V[b][1] + w[b] * Jr[1] - V[a][1]};
                xid = dot(t[k], Pd) - w[a] * dot(n[k], D[k]);
            } else if (!xi0) {
                double Ed[2] = {V[a][0] + w[a] * JD[0] - V[b][0], V[a][1] + w[a] * JD[1] - V[b][1]};
                xid = w[b] * dot(n[k], r) - dot(t[k], Ed);
            }
            double Jt[2], wf = ov ? w[b] : w[a];
            perp(t[k], Jt);
            cor2[0] = 2.0 * xid * wf * Jt[0];
            cor2[1] = 2.0 * xid * wf * Jt[1];
            if (slipRate) slipRate[k] = xid;
        }
        for (int i = 0; i < 2; i++) {
            kap[b][i] = IMP ? 0.0 : kap[a][i] - w[a] * w[a] * D[k][i] + w[b] * w[b] * r[i] + cor2[i];
            for (int d = 0; d < ND; d++) G[b][i][d] = G[a][i][d] + JD[i] * sel[a][d] - Jr[i] * sel[b][d];
            if (SLIDES && slip[k] >= 0) G[b][i][slip[k]] += t[k][i];
        }
        fk[k][0] = IMP ? B->m * V[b][0] : -B->m * (ah + kap[b][0]);
        fk[k][1] = IMP ? B->m * V[b][1] : -B->m * (s->g + av + kap[b][1]);
    }
    if (!f) return 1; /* (the placement alone) */
    /* the reduced system (symmetric positive definite while every contact sticks); a sliding contact's
     * friction -sigma mu N, N linear in the accelerations (N_k = n . sum over i >= k of m_i X_i'' - f_i),
     * works on its slip */
    double A[EN_ROWS][EN_ROWS], r[EN_ROWS], zdd[EN_ROWS] = {0};
    for (int a = 0; a < nd; a++) {
        r[a] = 0.0;
        for (int c = 0; c < nd; c++) A[a][c] = 0.0;
    }
    for (int k = 0; k < nb; k++) {
        const EnBody *B = &s->body[k];
        const double(*g)[NDMAX] = G[k + 1];
        for (int a = 0; a < nd; a++) {
            r[a] += g[0][a] * fk[k][0] + g[1][a] * fk[k][1] + (IMP ? B->Ic * sel[k + 1][a] * yin[EN_W(k)] : 0.0);
            for (int c = 0; c < nd; c++)
                A[a][c] += B->m * (g[0][a] * g[0][c] + g[1][a] * g[1][c]) + B->Ic * sel[k + 1][a] * sel[k + 1][c];
        }
    }
    for (int k = 0; k < nb && SLIDES; k++) {
        if (slip[k] < 0) continue;
        double smu = m->sigma[k] * s->mu[k], c = 0.0;
        for (int i = k; i < nb; i++) {
            c -= dot(n[k], fk[i]);
            for (int b = 0; b < nd; b++)
                A[slip[k]][b] += smu * s->body[i].m * (n[k][0] * G[i + 1][0][b] + n[k][1] * G[i + 1][1][b]);
        }
        r[slip[k]] -= smu * c;
    }
    if (nd && !solve_small(nd, A, r, zdd)) return 0;
    double al[NB], acc[NB][2];
    for (int k = 0; k < nb; k++) {
        al[k] = 0.0;
        acc[k][0] = kap[k + 1][0];
        acc[k][1] = kap[k + 1][1];
        for (int d = 0; d < nd; d++) {
            al[k] += sel[k + 1][d] * zdd[d];
            acc[k][0] += G[k + 1][0][d] * zdd[d];
            acc[k][1] += G[k + 1][1][d] * zdd[d];
        }
        f->qdd[EN_Q(k, 0)] = acc[k][0];
        f->qdd[EN_Q(k, 1)] = acc[k][1];
        f->qdd[EN_Q(k, 2)] = al[k];
        f->xidd[k] = SLIDES && slip[k] >= 0 ? zdd[slip[k]] : 0.0;
    }
    /* the forces, from the top: F the contact force on the body (world frame), tau the torque of the
     * reaction of the contact above on it */
    double F[2] = {0.0, 0.0}, tau = 0.0;
    for (int k = nb - 1; k >= 0; k--) {
        const EnBody *B = &s->body[k];
        F[0] += IMP ? B->m * acc[k][0] - fk[k][0] : B->m * (acc[k][0] + ah);
        F[1] += IMP ? B->m * acc[k][1] - fk[k][1] : B->m * (acc[k][1] + s->g + av);
        double N = dot(F, n[k]), T = SLIDES && m->sigma[k] ? -m->sigma[k] * s->mu[k] * N : dot(F, t[k]);
        f->T[k] = T;
        const double *rf = rk[k];
        /* the contact points of a flat body from its centre (with an overhang, the support's corner there) and from
         * its support's */
        double pc[2][2] = {{0.0}}, pd[2][2] = {{0.0}};
        for (int i = 0; i < 2; i++) {
            if (!(flat[k] || m->closed[k][i])) continue;
            if (k > 0 && m->over[k][i]) {
                double dx = s->body[k - 1].tm + (2 * i - 1) * s->body[k - 1].tw - s->body[k - 1].xG, hh = s->body[k - 1].ht;
                pd[i][0] = dx * cs[k][0] + hh * cs[k][1];
                pd[i][1] = -dx * cs[k][1] + hh * cs[k][0];
                pc[i][0] = pd[i][0] - D[k][0] + rf[0];
                pc[i][1] = pd[i][1] - D[k][1] + rf[1];
            } else {
                pc[i][0] = Rd[k][i][0], pc[i][1] = Rd[k][i][1];
                pd[i][0] = D[k][0] - rf[0] + Rd[k][i][0];
                pd[i][1] = D[k][1] - rf[1] + Rd[k][i][1];
            }
        }
        if (flat[k]) {
            double JL[2], JR[2];
            perp(pc[0], JL);
            perp(pc[1], JR);
            double aL = dot(n[k], JL), aR = dot(n[k], JR), bT = dot(t[k], JL);
            double NR = (B->Ic * (IMP ? al[k] - yin[EN_W(k)] : al[k]) - T * bT - tau - N * aL) / (aR - aL);
            f->N[k][1] = NR;
            f->N[k][0] = N - NR;
        } else {
            f->N[k][cor[k] > 0] = N;
            f->N[k][cor[k] < 0] = 0.0;
        }
        if (k > 0) { /* the torque of this contact's reaction on the support (its force at each closed corner) */
            tau = -T * dot(n[k], D[k]);
            for (int i = 0; i < 2; i++) {
                if (!m->closed[k][i]) continue;
                tau += f->N[k][i] * dot(t[k], pd[i]);
            }
        }
    }
    for (int k = nb; k < EN_READ_BODIES; k++) f->N[k][0] = f->N[k][1] = f->T[k] = f->xidd[k] = 0.0;
    for (int q = 3 * nb; q < 3 * EN_READ_BODIES; q++) f->qdd[q] = 0.0;
    return 1;
}

static int sliding(const EnSystem *s, const EnMode *m) {
    for (int k = 0; k < s->nb; k++)
        if (m->sigma[k]) return 1;
    return 0;
}

static int chain_general(const EnSystem *s, const EnMode *m, const double *xi0, const double *yin, double *yout,
                         double ah, double av, EnForces *f, double *slipRate) {
#if EN_MAX_BODIES > 2 /* (two bodies, the stacks of most runs: loops unrolled to their own coordinates) */
    if (s->nb == 2) {
        if (!sliding(s, m)) return chain_nd(2, 0, 0, s, m, xi0, yin, yout, ah, av, f, slipRate);
        return chain_nd(4, 1, 0, s, m, xi0, yin, yout, ah, av, f, slipRate);
    }
#endif
    if (!sliding(s, m)) return chain_nd(EN_MAX_BODIES, 0, 0, s, m, xi0, yin, yout, ah, av, f, slipRate);
    return chain_nd(2 * EN_MAX_BODIES, 1, 0, s, m, xi0, yin, yout, ah, av, f, slipRate);
}

/* The plastic impact onto the chain m at the state y (chain_nd's IMP form): the rates after to f->qdd, the
 * impulses (N s) to f->N, f->T. */
static int chain_impulse(const EnSystem *s, const EnMode *m, const double *y, EnForces *f) {
    if (!sliding(s, m)) return chain_nd(EN_MAX_BODIES, 0, 1, s, m, NULL, y, NULL, 0.0, 0.0, f, NULL);
    return chain_nd(2 * EN_MAX_BODIES, 1, 1, s, m, NULL, y, NULL, 0.0, 0.0, f, NULL);
}

/* The chain (chain_nd): one body written out (chain_one), else chain_general. */
static inline __attribute__((always_inline)) int chain(const EnSystem *s, const EnMode *m, const double *xi0,
                                                       const double *yin, double *yout, double ah, double av,
                                                       EnForces *f, double *slipRate) {
    if (s->nb == 1)
        return m->sigma[0] ? chain_one(1, s, m, xi0, yin, yout, ah, av, f, slipRate, NULL)
                           : chain_one(0, s, m, xi0, yin, yout, ah, av, f, slipRate, NULL);
    return chain_general(s, m, xi0, yin, yout, ah, av, f, slipRate);
}

int engine_chain(const EnSystem *s, const EnMode *m, const double *xi0, double *y, double ah, double av,
                 EnForces *f) {
    return chain(s, m, xi0, y, y, ah, av, f, NULL);
}

/* Every body on a corner of its support (none flies): the mode is a chain. */
static int all_touch(const EnSystem *s, const EnMode *m) {
    for (int k = 0; k < s->nb; k++)
        if (!(m->closed[k][0] || m->closed[k][1])) return 0;
    return 1;
}

int engine_touches(const EnSystem *s, const EnMode *m) { return all_touch(s, m); }

int engine_solve(const EnSystem *s, const EnMode *m, const double *y, double ah, double av, EnForces *f) {
    if (all_touch(s, m)) return chain(s, m, NULL, y, NULL, ah, av, f, NULL);
    double Minv[EN_NQ], fext[EN_NQ], a0[EN_NQ];
    free_terms(s, ah, av, Minv, fext);
    for (int q = 0; q < 3 * s->nb; q++) a0[q] = Minv[q] * fext[q];
    return solve_set(s, m, y, a0, 1, f);
}

int engine_plastic(const EnSystem *s, const EnMode *m, double *y) {
    double v0[EN_NQ] = {0};
    EnForces f;
    gather(s, y, 1, v0);
    if (all_touch(s, m) ? !chain_impulse(s, m, y, &f) : !solve_set(s, m, y, v0, 0, &f)) return 0;
    for (int k = 0; k < s->nb; k++)
        for (int i = 0; i < 3; i++) y[EN_VEL(s->nb, k, i)] = f.qdd[EN_Q(k, i)];
    return 1;
}

/* The slip rate of body k's contact (along its support's top) in mode m: its closed corner's. */
static double slip_rate(const EnSystem *s, const EnMode *m, int k, const double *y) {
    int c = first_closed(m, k);
    if (!c) return 0.0;
    EnPoint p;
    engine_corner_m(s, m, k, c, y, &p);
    return p.xid;
}

/* A chain's derivatives from its reduced coordinates y, its placed state yc and its forces f under (ah, av): the
 * rotations' rates and accelerations, the work of the support's motion, and where a contact slides (slides:
 * sliding(s, m)) its loss, slip and slip acceleration (no friction works where every contact sticks). */
static inline __attribute__((always_inline)) void chain_rates(const EnSystem *s, const EnMode *m, int slides,
                                                              const double *y, const double *yc, double ah, double av,
                                                              const EnForces *f, double *dy) {
    int nb = s->nb;
    double work = 0.0;
    for (int k = 0; k < nb; k++) {
        work -= s->body[k].m * (ah * yc[EN_VEL(nb, k, 0)] + av * yc[EN_VEL(nb, k, 1)]);
        dy[EN_TH(k)] = yc[EN_W(k)];
        dy[EN_W(k)] = f->qdd[EN_Q(k, 2)];
    }
    dy[EN_WORK(nb)] = work;
    if (slides)
        for (int k = 0; k < nb; k++) {
            double v = m->sigma[k] ? y[EN_XID(nb, k)] : 0.0;
            dy[EN_LOSS(nb, k)] = -f->T[k] * v;
            dy[EN_XI(nb, k)] = v;
            dy[EN_XID(nb, k)] = m->sigma[k] ? f->xidd[k] : 0.0;
        }
}

int engine_rhs(const EnSystem *s, const EnMode *m, const double *xi0, const double *y, double ah, double av,
               double *dy, EnForces *fo, double *placed) {
    int nb = s->nb, known = 0;
    EnForces f, *fp = fo ? fo : &f;
    double ycl[NMAX], *yc = placed ? placed : ycl, xid[EN_MAX_BODIES] = {0}; /* (slip rates, where known) */
    if (xi0 && all_touch(s, m)) { /* a chain: its centres placed from its reduced coordinates, which it integrates */
        if (!chain(s, m, xi0, y, yc, ah, av, fp, NULL)) return 0;
        chain_rates(s, m, sliding(s, m), y, yc, ah, av, fp, dy);
        return 1;
    }
    if (all_touch(s, m)) { /* the chain, which gives the slip rates too */
        if (!chain(s, m, NULL, y, NULL, ah, av, fp, xid)) return 0;
        known = 1;
    } else if (!engine_solve(s, m, y, ah, av, fp)) {
        return 0;
    }
    double work = 0.0;
    for (int k = 0; k < nb; k++) {
        work -= s->body[k].m * (ah * y[EN_VEL(nb, k, 0)] + av * y[EN_VEL(nb, k, 1)]);
        dy[EN_TH(k)] = y[EN_W(k)];
        dy[EN_W(k)] = fp->qdd[EN_Q(k, 2)];
        for (int i = 0; i < 2; i++) {
            dy[EN_POS(nb, k, i)] = y[EN_VEL(nb, k, i)];
            dy[EN_VEL(nb, k, i)] = fp->qdd[EN_Q(k, i)];
        }
        dy[EN_LOSS(nb, k)] = m->sigma[k] ? -fp->T[k] * (known ? xid[k] : slip_rate(s, m, k, y)) : 0.0;
        dy[EN_XI(nb, k)] = dy[EN_XID(nb, k)] = 0.0; /* (held by a sliding chain alone) */
    }
    dy[EN_WORK(nb)] = work;
    return 1;
}

int engine_rhs_slope(const EnSystem *s, const EnMode *m, const double *xi0, const double *y, double ah, double av,
                     double *dy, EnForces *f, double *placed, double *dya, EnForces *fa) {
    if (s->nb != 1 || !xi0 || !all_touch(s, m)) return -1;
    int slides = m->sigma[0] != 0;
    if (!(slides ? chain_one(1, s, m, xi0, y, placed, ah, av, f, NULL, fa)
                 : chain_one(0, s, m, xi0, y, placed, ah, av, f, NULL, fa)))
        return 0;
    chain_rates(s, m, slides, y, placed, ah, av, f, dy);
    /* the same rates are affine in ah with the slopes fa and the work's -m X': the kinematic rates do not move */
    chain_rates(s, m, slides, y, placed, 1.0, 0.0, fa, dya);
    dya[EN_TH(0)] = 0.0;
    if (slides) dya[EN_XI(1, 0)] = 0.0;
    return 1;
}

/* engine_jam_margin from the corner's rows (any body). */
static double jam_margin_rows(const EnSystem *s, const EnMode *m, int k, int c, const double *y) {
    int nq = 3 * s->nb;
    double Minv[EN_NQ], fext[EN_NQ], col[EN_NQ];
    free_terms(s, 0.0, 0.0, Minv, fext);
    EnPoint p;
    engine_point_m(s, m, k, c, y, &p);
    for (int q = 0; q < nq; q++) col[q] = p.wN[q] - m->sigma[k] * s->mu[k] * p.wT[q];
    return wdot(p.wN, Minv, col, nq) / wdot(p.wN, Minv, p.wN, nq);
}

double engine_jam_margin(const EnSystem *s, const EnMode *m, int k, const double *y) {
    int c = first_closed(m, k);
    if (!c || (m->closed[k][0] && m->closed[k][1]) || !m->sigma[k]) return 1.0;
    if (k > 0) return jam_margin_rows(s, m, k, c, y);
    /* on the ground (its rows (0, 1, -r_x) and (1, 0, r_y), r the corner from the centre): the same, written out */
    const EnBody *B = &s->body[0];
    double th = y[EN_TH(0)], ck = cos(th), sk = sin(th);
    double cx = B->cx[c > 0], rx = cx * ck + B->cy * sk, ry = -cx * sk + B->cy * ck;
    return 1.0 + m->sigma[0] * s->mu[0] * B->m * rx * ry / (B->Ic + B->m * rx * rx);
}

int engine_beyond_edge(const EnSystem *s, int k, double xi) {
    const EnBody *S = &s->body[k - 1];
    return fabs(xi - S->tm) > S->tw * (1.0 + EN_EDGE_MARGIN);
}

/* Body k (k > 0) on its support's top (docs/columns.md, "Overhangs"): at each end c its corner's overhang u (how far
 * it lies beyond the support's top corner c, engine_overhang) against the pair of that end: the support's corner on
 * k's base (over) holds while u > -EN_EDGE_MARGIN tw, k's corner on the support's top while u < EN_EDGE_MARGIN tw (a
 * hysteresis far above rounding, far below any size: a block as wide as the one below keeps its pair, and at a switch
 * the two pairs' contact points lie within it of each other). Then the fall off the support: where one end
 * overhangs, the other corner passing the support's corner at that end (k's base has left the support's top). Three
 * indicators always, each 1 where there is nothing to watch (a contact that sticks keeps its corner's place: a
 * sticking corner on the top, or a support's corner at a sticking point of k's base, turning with k), so that each
 * keeps its place along a step. */
static int edge_indicators(const EnSystem *s, const EnMode *m, int k, const double *y, double *ind, int *kind,
                           int *body, int *corner) {
    double b = s->body[k - 1].tw, tol = EN_EDGE_MARGIN * b;
    int sticks = (m->closed[k][0] || m->closed[k][1]) && m->sigma[k] == 0;
    double u[2] = {0.0, 0.0};
    if (!sticks)
        for (int i = 0; i < 2; i++) u[i] = engine_overhang(s, k, 2 * i - 1, y);
    for (int i = 0; i < 2; i++) {
        ind[i] = sticks ? 1.0 : (m->over[k][i] ? u[i] + tol : tol - u[i]) / b;
        kind[i] = EN_IND_OVERHANG;
        body[i] = k;
        corner[i] = 2 * i - 1;
    }
    /* the fall: end i overhangs and the other corner passes the support's corner i (its overhang there, u + the base's
     * width along the top, reaches ... ): measured as the other corner's place beyond the support's corner i */
    ind[2] = 1.0;
    corner[2] = 1;
    if (!sticks && m->over[k][0] != m->over[k][1]) {
        int i = m->over[k][1], c = 2 * i - 1;
        EnPoint p;
        engine_corner(s, k, -c, y, &p);
        const EnBody *S = &s->body[k - 1];
        ind[2] = (S->tw + tol - c * (p.xi - S->tm)) / b;
        corner[2] = c;
    }
    kind[2] = EN_IND_FELL_OFF;
    body[2] = k;
    return 3;
}

/* The indicators of the forces, over the weight the contact carries: a closed corner's normal force, a sticking
 * contact's friction margin. */
static double open_margin(const EnSystem *s, const EnForces *f, int k, int i) { return f->N[k][i] / s->weight[k]; }
static double slip_margin(const EnSystem *s, const EnForces *f, int k) {
    return (s->mu[k] * (f->N[k][0] + f->N[k][1]) - fabs(f->T[k])) / s->weight[k];
}

double engine_force_margin(const EnSystem *s, const EnMode *m, const EnForces *f) {
    double least = INFINITY;
    for (int k = 0; k < s->nb; k++) {
        for (int i = 0; i < 2; i++)
            if (m->closed[k][i]) least = fmin(least, open_margin(s, f, k, i));
        if ((m->closed[k][0] || m->closed[k][1]) && m->sigma[k] == 0) least = fmin(least, slip_margin(s, f, k));
    }
    return least;
}

int engine_indicators(const EnSystem *s, const EnMode *m, const double *y, const EnForces *f, double *ind,
                      int *kind, int *body, int *corner) {
    int n = 0, nb = s->nb;
    for (int k = 0; k < nb; k++) {
        const EnBody *B = &s->body[k];
        double R = sqrt(B->b * B->b + B->h * B->h); /* the farther base corner's distance from the centre */
        int c = first_closed(m, k);
        for (int i = 0; i < 2; i++) {
            if (m->closed[k][i]) {
                ind[n] = open_margin(s, f, k, i);
                kind[n] = EN_IND_OPEN;
            } else if (c) {
                /* rocking on its other corner: this one lands when the rotation relative to the support
                 * returns to zero (exact for a flat base on a flat face, and free of the cancellation of
                 * the gap, a difference of lengths of the body's size) */
                double rel = y[EN_TH(k)] - (k > 0 ? y[EN_TH(k - 1)] : 0.0);
                ind[n] = c * rel;
                kind[n] = EN_IND_LAND;
            } else {
                EnPoint p;
                engine_corner_m(s, m, k, 2 * i - 1, y, &p);
                ind[n] = p.g / R; /* (beyond the support's corner, the gap of that corner below k's base: over) */
                kind[n] = EN_IND_LAND;
            }
            body[n] = k;
            corner[n++] = 2 * i - 1;
        }
        if (k > 0) n += edge_indicators(s, m, k, y, ind + n, kind + n, body + n, corner + n);
        if (c && m->sigma[k] == 0) {
            ind[n] = slip_margin(s, f, k);
            kind[n] = EN_IND_SLIP;
            body[n] = k;
            corner[n++] = c;
        } else if (c) { /* (a chain holds its slip rates: EN_XID) */
            ind[n] = m->sigma[k] * (all_touch(s, m) ? y[EN_XID(nb, k)] : slip_rate(s, m, k, y)) / sqrt(s->g * R);
            kind[n] = EN_IND_STOP;
            body[n] = k;
            corner[n++] = c;
            /* on one corner; on the ground the margin is at least 1 - 3 mu / 4 at every rotation (docs/flight.md,
             * "Painleve"), so below mu = 4/3 there is nothing to watch */
            if (m->closed[k][0] != m->closed[k][1] && !(k == 0 && 1.0 - 0.75 * s->mu[0] > EN_JAM_MARGIN)) {
                ind[n] = engine_jam_margin(s, m, k, y) - EN_JAM_MARGIN;
                kind[n] = EN_IND_JAM;
                body[n] = k;
                corner[n++] = c;
            }
        }
        /* rocking on its right corner (rel > 0) or its left one, it lands on the hull edge next to that corner */
        double rel = y[EN_TH(k)] - (k > 0 ? y[EN_TH(k - 1)] : 0.0);
        ind[n] = B->over[rel > 0] - fabs(rel);
        kind[n] = EN_IND_OVERTURN;
        body[n] = k;
        corner[n++] = rel > 0 ? 1 : -1;
    }
    return n;
}

/* ------------------------------------------------------------------ complementarity */

/* The candidate corners of a problem: body and corner index. */
typedef struct {
    int nc, ns;
    int k[EN_CORNERS], i[EN_CORNERS]; /* corner j: body k[j], index i[j] */
    int sk[EN_MAX_BODIES];            /* friction unknown s: body sk[s] */
    int sOf[EN_MAX_BODIES];           /* body -> friction index, or -1 */
    EnPoint P[EN_CORNERS];
} Candidates;

static void candidates(const EnSystem *s, const EnMode *cur, const double *y, const int touching[][2], const int *withFriction,
                       Candidates *c) {
    memset(c, 0, sizeof(*c));
    for (int k = 0; k < s->nb; k++) {
        c->sOf[k] = -1;
        int any = 0;
        for (int i = 0; i < 2; i++)
            if (touching[k][i]) {
                c->k[c->nc] = k;
                c->i[c->nc] = i;
                engine_point_m(s, cur, k, 2 * i - 1, y, &c->P[c->nc]);
                c->nc++;
                any = 1;
            }
        if (any && withFriction[k]) {
            c->sOf[k] = c->ns;
            c->sk[c->ns++] = k;
        }
    }
}

/* The tangential row of body k: its first candidate corner's. */
static const EnPoint *friction_point(const Candidates *c, int k) {
    for (int j = 0; j < c->nc; j++)
        if (c->k[j] == k) return &c->P[j];
    return NULL;
}

/* Assemble the Pfeiffer-Glocker problem: unknowns z = (normal forces (nc), lambda0+ (ns),
 * tangential a- (ns)), w = (normal accelerations, tangential a+, lambda0-); the forces of
 * body k's contact in units of fu[k] (each contact's own scale: a light block 2 on a heavy block 1
 * keeps its digits), accelerations (or rates) in units of au. base[q]: the free motion's generalised
 * acceleration (or rate); sig[k] the given sigma of a sliding body (0 for friction unknowns). */
static int assemble(const EnSystem *s, const Candidates *c, const double *Minv, const double *base,
                    const int *sig, const double *fu, double au, double *A, double *q) {
    int nc = c->nc, ns = c->ns, n = nc + 2 * ns, nq = 3 * s->nb;
    double col[EN_CORNERS + EN_MAX_BODIES][EN_NQ];
    double row[EN_CORNERS + EN_MAX_BODIES][EN_NQ];
    /* force columns: normal forces carry the friction they imply */
    for (int j = 0; j < nc; j++) {
        int k = c->k[j];
        const EnPoint *pt = friction_point(c, k);
        double mu = s->mu[k], fr = c->sOf[k] >= 0 ? mu : sig[k] * mu;
        for (int q2 = 0; q2 < nq; q2++) col[j][q2] = c->P[j].wN[q2] - fr * pt->wT[q2];
        for (int q_ = 0; q_ < nq; q_++) row[j][q_] = c->P[j].wN[q_];
    }
    for (int t = 0; t < ns; t++) {
        const EnPoint *pt = friction_point(c, c->sk[t]);
        for (int q_ = 0; q_ < nq; q_++) col[nc + t][q_] = pt->wT[q_];
        for (int q_ = 0; q_ < nq; q_++) row[nc + t][q_] = pt->wT[q_];
    }
    for (int i = 0; i < n * n; i++) A[i] = 0.0;
    for (int i = 0; i < nc + ns; i++) {
        double b = 0.0;
        for (int q2 = 0; q2 < nq; q2++) b += row[i][q2] * base[q2];
        q[i] = b / au;
        for (int j = 0; j < nc + ns; j++)
            A[i * n + j] = wdot(row[i], Minv, col[j], nq) * fu[j < nc ? c->k[j] : c->sk[j - nc]] / au;
    }
    for (int t = 0; t < ns; t++) {
        int r = nc + t, k = c->sk[t];
        A[r * n + nc + ns + t] = 1.0; /* a+ = a + a- */
        int r2 = nc + ns + t;
        q[r2] = 0.0;
        for (int j = 0; j < nc; j++)
            if (c->k[j] == k) A[r2 * n + j] = 2.0 * s->mu[k];
        A[r2 * n + nc + t] = -1.0;
    }
    return n;
}

/* The biases of the candidates' rows added to the free accelerations (their rows' values at a = base). */
static void add_bias(const Candidates *c, double au, double *q) {
    for (int j = 0; j < c->nc; j++) q[j] += c->P[j].bN / au;
    for (int t = 0; t < c->ns; t++) q[c->nc + t] += friction_point(c, c->sk[t])->bT / au;
}

/* Whether the forces (or impulses) f of the set m satisfy the complementarity conditions strictly: every closed
 * corner carries a positive normal force, every sticking contact's friction lies strictly inside its cone. */
static int strictly_consistent(const EnSystem *s, const EnMode *m, const EnForces *f) {
    for (int k = 0; k < s->nb; k++) {
        for (int i = 0; i < 2; i++)
            if (m->closed[k][i] && !(f->N[k][i] > 0.0)) return 0;
        if (m->sigma[k] == 0 && !(fabs(f->T[k]) < s->mu[k] * (f->N[k][0] + f->N[k][1]))) return 0;
    }
    return 1;
}

/* The impacts' unit of velocity, sqrt(g R) of the largest body (m/s). */
static double velocity_unit(const EnSystem *s) {
    double Rmax = 0.0;
    for (int k = 0; k < s->nb; k++) Rmax = fmax(Rmax, hypot(s->body[k].b, s->body[k].h));
    return sqrt(s->g * Rmax);
}

int engine_choose(const EnSystem *s, const double *y, double ah, double av, const int touching[][2],
                  const int stuck[], EnMode *out, EnForces *f) {
    return engine_choose_m(s, NULL, y, ah, av, touching, stuck, out, f);
}

int engine_choose_m(const EnSystem *s, const EnMode *cur, const double *y, double ah, double av,
                    const int touching[][2], const int stuck[], EnMode *out, EnForces *f) {
    int nb = s->nb, nq = 3 * nb;
    /* a body that slides keeps the sign of its slip rate (at its first touching corner) */
    int sig[EN_MAX_BODIES] = {0};
    for (int k = 0; k < nb; k++) {
        int i = touching[k][0] ? 0 : touching[k][1] ? 1 : -1;
        if (i < 0 || stuck[k]) continue;
        EnPoint p;
        engine_corner_m(s, cur, k, 2 * i - 1, y, &p);
        sig[k] = p.xid > 0 ? 1 : p.xid < 0 ? -1 : 0;
    }
    /* the likely set first: every touching corner closed, every candidate sticking. Where every closed corner
     * carries a positive normal force and every sticking contact's friction lies strictly inside its cone, it
     * solves the problem (its other solutions, if any, need a force or margin at zero) */
    EnMode guess;
    memset(&guess, 0, sizeof(guess));
    if (cur) memcpy(guess.over, cur->over, sizeof(guess.over));
    for (int k = 0; k < nb; k++) {
        guess.closed[k][0] = touching[k][0];
        guess.closed[k][1] = touching[k][1];
        guess.sigma[k] = sig[k];
    }
    if (all_touch(s, &guess) && chain(s, &guess, NULL, y, NULL, ah, av, f, NULL) && strictly_consistent(s, &guess, f)) {
        *out = guess;
        return 0;
    }
    Candidates c;
    candidates(s, cur, y, touching, stuck, &c);
    double Minv[EN_NQ], fext[EN_NQ], a0[EN_NQ];
    free_terms(s, ah, av, Minv, fext);
    for (int q = 0; q < nq; q++) a0[q] = Minv[q] * fext[q];
    double A[LCP_MAX * LCP_MAX], q[LCP_MAX], z[LCP_MAX], w[LCP_MAX];
    double au = s->g;
    int n = assemble(s, &c, Minv, a0, sig, s->weight, au, A, q);
    add_bias(&c, au, q);
    memset(out, 0, sizeof(*out));
    if (cur) memcpy(out->over, cur->over, sizeof(out->over));
    int status = n ? lcp_solve(n, A, q, z, w, NULL) : LCP_SOLVED;
    if (status != LCP_SOLVED) return 1;
    /* a corner that carries nothing and does not separate (to rounding) stays closed: a statue in free fall
     * with its plinth keeps with it, rather than leave it by rounding */
    for (int j = 0; j < c.nc; j++) out->closed[c.k[j]][c.i[j]] = z[j] > 0.0 || fabs(w[j]) <= EN_ROUNDING;
    for (int k = 0; k < nb; k++) out->sigma[k] = sig[k];
    const double small = 1e-12; /* of g: a tangential acceleration below it is a stick */
    for (int t = 0; t < c.ns; t++) {
        int k = c.sk[t];
        double aPlus = w[c.nc + t], aMinus = z[c.nc + c.ns + t];
        out->sigma[k] = aPlus > small ? 1 : aMinus > small ? -1 : 0;
    }
    /* a body none of whose corners stays closed flies: no friction */
    for (int k = 0; k < nb; k++)
        if (!out->closed[k][0] && !out->closed[k][1]) out->sigma[k] = 0;
    if (!engine_solve(s, out, y, ah, av, f)) return 1;
    return 0;
}

/* The impact's likely outcome, tried before its complementarity problem: each corner that approaches its
 * support closes, a body's other touching corners open (it rocks onto the corner it lands on; a body none of
 * whose corners approaches keeps its touching ones closed), every contact sticks, and every body touches (a
 * chain: chain_impulse). Where every closed corner takes a positive normal impulse, every friction impulse lies
 * strictly inside its cone and every touching corner left open separates, it solves the problem: then the
 * rates in y become the rates after, with the impulses and the sets after as engine_impact's, and it returns
 * 1; else 0 with nothing changed. */
static int impact_guess(const EnSystem *s, const EnMode *cur, double *y, int touching[][2], int stuck[], double PN[][2],
                        double PT[]) {
    int nb = s->nb, approach[EN_MAX_BODIES] = {0};
    EnMode m;
    memset(&m, 0, sizeof(m));
    if (cur) memcpy(m.over, cur->over, sizeof(m.over));
    double gd[EN_MAX_BODIES][2] = {{0}};
    double slow = -1e-9 * velocity_unit(s); /* (a corner on the constraint has a normal rate of rounding) */
    for (int k = 0; k < nb; k++)
        for (int i = 0; i < 2; i++) {
            if (!touching[k][i]) continue;
            EnPoint p;
            engine_corner_m(s, cur, k, 2 * i - 1, y, &p);
            gd[k][i] = p.gd;
            approach[k] |= p.gd < slow;
        }
    for (int k = 0; k < nb; k++)
        for (int i = 0; i < 2; i++) m.closed[k][i] = touching[k][i] && (!approach[k] || gd[k][i] < slow);
    EnForces f;
    if (!all_touch(s, &m) || !chain_impulse(s, &m, y, &f) || !strictly_consistent(s, &m, &f)) return 0;
    double ya[NMAX];
    memcpy(ya, y, sizeof(ya));
    for (int k = 0; k < nb; k++)
        for (int i = 0; i < 3; i++) ya[EN_VEL(nb, k, i)] = f.qdd[EN_Q(k, i)];
    int sep[EN_MAX_BODIES][2] = {{0}};
    for (int k = 0; k < nb; k++)
        for (int i = 0; i < 2; i++) {
            if (!touching[k][i] || m.closed[k][i]) continue;
            EnPoint p;
            engine_corner_m(s, cur, k, 2 * i - 1, ya, &p);
            if (p.gd < 0.0) return 0;
            sep[k][i] = p.gd > 0.0;
        }
    memcpy(y, ya, sizeof(ya));
    for (int k = 0; k < nb; k++) {
        PN[k][0] = f.N[k][0];
        PN[k][1] = f.N[k][1];
        PT[k] = f.T[k];
        stuck[k] = 1;
        for (int i = 0; i < 2; i++) touching[k][i] = touching[k][i] && !sep[k][i];
    }
    return 1;
}

int engine_impact(const EnSystem *s, double *y, int touching[][2], int stuck[], double PN[][2], double PT[]) {
    return engine_impact_m(s, NULL, y, touching, stuck, PN, PT);
}

int engine_impact_m(const EnSystem *s, const EnMode *cur, double *y, int touching[][2], int stuck[], double PN[][2],
                    double PT[]) {
    int nb = s->nb;
    int all[EN_MAX_BODIES];
    for (int k = 0; k < EN_MAX_BODIES; k++) all[k] = 1;
    memset(PN, 0, sizeof(double) * 2 * (size_t)nb);
    memset(PT, 0, sizeof(double) * (size_t)nb);
    if (impact_guess(s, cur, y, touching, stuck, PN, PT)) return 0;
    Candidates c;
    candidates(s, cur, y, touching, all, &c);
    double Minv[EN_NQ], fext[EN_NQ], v0[EN_NQ];
    free_terms(s, 0.0, 0.0, Minv, fext);
    gather(s, y, 1, v0);
    double vu = velocity_unit(s), pu[EN_MAX_BODIES];
    for (int k = 0; k < nb; k++) pu[k] = s->weight[k] / s->g * vu; /* the momentum of what contact k carries */
    int sig[EN_MAX_BODIES] = {0};
    double A[LCP_MAX * LCP_MAX], q[LCP_MAX], z[LCP_MAX], w[LCP_MAX];
    int n = assemble(s, &c, Minv, v0, sig, pu, vu, A, q);
    if (!n) return 0;
    if (lcp_solve(n, A, q, z, w, NULL) != LCP_SOLVED) return 1;
    /* the problem chose the contact set after the impact; its impulses come from that set's own
     * equations (the problem's friction unknowns differ by mu times the normal ones, which would
     * cost digits for a large mu) */
    EnMode m;
    memset(&m, 0, sizeof(m));
    if (cur) memcpy(m.over, cur->over, sizeof(m.over));
    for (int j = 0; j < c.nc; j++) m.closed[c.k[j]][c.i[j]] = z[j] > 0.0;
    const double small = 1e-14; /* of the velocity unit: a slip rate after below it is a stick */
    for (int t = 0; t < c.ns; t++) {
        int k = c.sk[t];
        double vPlus = w[c.nc + t], vMinus = z[c.nc + c.ns + t];
        m.sigma[k] = vPlus > small ? 1 : vMinus > small ? -1 : 0;
    }
    EnForces f;
    if (!solve_set(s, &m, y, v0, 0, &f)) return 1;
    for (int k = 0; k < nb; k++) {
        PN[k][0] = f.N[k][0];
        PN[k][1] = f.N[k][1];
        PT[k] = f.T[k];
        for (int i = 0; i < 3; i++) y[EN_VEL(nb, k, i)] = f.qdd[EN_Q(k, i)];
        touching[k][0] = touching[k][1] = 0;
        stuck[k] = 0;
    }
    for (int j = 0; j < c.nc; j++) touching[c.k[j]][c.i[j]] = w[j] == 0.0 || m.closed[c.k[j]][c.i[j]];
    for (int t = 0; t < c.ns; t++) stuck[c.sk[t]] = m.sigma[c.sk[t]] == 0;
    return 0;
}

/* ----------------------------------------------------------------------- energy */

double engine_kinetic(const EnSystem *s, const double *y) {
    double E = 0.0;
    int nb = s->nb;
    for (int k = 0; k < s->nb; k++) {
        const EnBody *B = &s->body[k];
        double vx = y[EN_VEL(nb, k, 0)], vy = y[EN_VEL(nb, k, 1)], w = y[EN_W(k)];
        E += 0.5 * B->m * (vx * vx + vy * vy) + 0.5 * B->Ic * w * w;
    }
    return E;
}

/* The height of body k's centre at rest (stacked, flat): each support's base-to-top height, then its own centre's. */
static double rest_height(const EnSystem *s, int k) {
    double Y = 0.0;
    for (int j = 0; j < k; j++) Y += s->body[j].ht - s->body[j].cy;
    return Y - s->body[k].cy;
}

double engine_energy(const EnSystem *s, const double *y) {
    double E = engine_kinetic(s, y);
    int nb = s->nb;
    for (int k = 0; k < s->nb; k++) E += s->body[k].m * s->g * (y[EN_POS(nb, k, 1)] - rest_height(s, k));
    return E;
}

void engine_rest_state(const EnSystem *s, double *y) {
    int nb = s->nb;
    for (int k = 0; k < nb; k++) {
        y[EN_POS(nb, k, 1)] = rest_height(s, k);
        y[EN_TH(k)] = 0.0;
        for (int i = 0; i < 3; i++) y[EN_VEL(nb, k, i)] = 0.0;
    }
}

/* ------------------------------------------------------------------- projection */

/* Rows (and residuals) of the constraints of m: closed corners' gaps, sticking contacts' slips, in the
 * centres' coordinates only (the rotations are not moved). A flat body's relative rotation is set exactly
 * (flatten): one gap row then holds both corners. */
static int constraint_rows(const EnSystem *s, const EnMode *m, const double *y, const double *xi0,
                           double row[][EN_NQ], double *res, double *rate) {
    int nr = 0, nq = 3 * s->nb;
    for (int k = 0; k < s->nb; k++) {
        int done = 0, flat = m->closed[k][0] && m->closed[k][1];
        for (int i = 0; i < 2; i++) {
            if (!m->closed[k][i]) continue;
            EnPoint p;
            engine_point_m(s, m, k, 2 * i - 1, y, &p);
            /* the rotations stay as integrated (they carry the error control; the centres follow) */
            for (int j = 0; j < s->nb; j++) p.wN[EN_Q(j, 2)] = p.wT[EN_Q(j, 2)] = 0.0;
            if (flat && i == 1) { /* the right corner's gap is the left one's */
                if (m->sigma[k] == 0 && !done) {
                    for (int q_ = 0; q_ < nq; q_++) row[nr][q_] = p.wT[q_];
                    res[nr] = xi0 ? p.xi - (xi0[k] + s->body[k].xa[1]) : 0.0;
                    rate[nr++] = p.xid;
                }
                continue;
            }
            for (int q_ = 0; q_ < nq; q_++) row[nr][q_] = p.wN[q_];
            res[nr] = p.g;
            rate[nr++] = p.gd;
            if (m->sigma[k] == 0 && !done) {
                for (int q_ = 0; q_ < nq; q_++) row[nr][q_] = p.wT[q_];
                res[nr] = xi0 ? p.xi - (xi0[k] + s->body[k].xa[i]) : 0.0;
                rate[nr++] = p.xid;
                done = 1;
            }
        }
    }
    return nr;
}

/* y -= Minv W^T (W Minv W^T)^-1 r on the positions (rates = 0) or the rates (rates = 1). */
static void correct(const EnSystem *s, double row[][EN_NQ], int nr, const double *r, double *y, int rates) {
    int nq = 3 * s->nb;
    double Minv[EN_NQ], fext[EN_NQ], A[EN_ROWS][EN_ROWS], rr[EN_ROWS], x[EN_ROWS];
    free_terms(s, 0.0, 0.0, Minv, fext);
    for (int i = 0; i < nr; i++) {
        rr[i] = r[i];
        for (int j = 0; j < nr; j++) A[i][j] = wdot(row[i], Minv, row[j], nq);
    }
    if (!solve_dense(nr, A, rr, x)) return;
    double d[EN_NQ];
    for (int q = 0; q < nq; q++) {
        d[q] = 0.0;
        for (int i = 0; i < nr; i++) d[q] -= row[i][q] * x[i];
        d[q] *= Minv[q];
    }
    scatter_add(s, y, rates, d);
}

/* Flat bodies turn exactly with their support (and on the ground stand at their rest height). */
static void flatten(const EnSystem *s, const EnMode *m, double *y, int rates) {
    int nb = s->nb;
    for (int k = 0; k < nb; k++) {
        if (!(m->closed[k][0] && m->closed[k][1])) continue;
        y[EN_TH(k)] = k > 0 ? y[EN_TH(k - 1)] : 0.0;
        if (k == 0) y[EN_POS(nb, 0, 1)] = -s->body[0].cy;
        if (!rates) continue;
        y[EN_W(k)] = k > 0 ? y[EN_W(k - 1)] : 0.0;
        if (k == 0) y[EN_VEL(nb, 0, 1)] = 0.0;
    }
}

void engine_hold_slips(const EnSystem *s, const EnMode *m, double *y) {
    for (int k = 0; k < s->nb; k++) {
        int c = first_closed(m, k);
        EnPoint p;
        if (!c) continue;
        engine_corner_m(s, m, k, c, y, &p);
        y[EN_XI(s->nb, k)] = p.xi - s->body[k].xa[c > 0];
        y[EN_XID(s->nb, k)] = m->sigma[k] ? p.xid : 0.0;
    }
}

void engine_project(const EnSystem *s, const EnMode *m, double *y, const double *xi0, int rates) {
    if (all_touch(s, m)) { /* a chain: placed exactly from the rotations (and rates), anchors and slip rates */
        int nb = s->nb;
        double a[EN_MAX_BODIES] = {0}, v[EN_MAX_BODIES] = {0}, yp[NMAX];
        EnMode st = *m;
        for (int k = 0; k < nb; k++) { /* the anchors given (a contact that sticks), or the current slips */
            int c = first_closed(m, k);
            EnPoint p;
            if (!xi0 || m->sigma[k]) engine_corner_m(s, m, k, c, y, &p);
            a[k] = xi0 && !m->sigma[k] ? xi0[k] : p.xi - s->body[k].xa[c > 0];
            v[k] = m->sigma[k] ? p.xid : 0.0; /* a sliding contact's slip rate, as it is */
            st.sigma[k] = 0;
        }
        if (rates) /* the slips and slip rates a sliding chain holds */
            for (int k = 0; k < nb; k++) {
                y[EN_XI(nb, k)] = a[k];
                y[EN_XID(nb, k)] = v[k];
            }
        memcpy(yp, y, sizeof(yp));
        chain(s, &st, a, yp, yp, 0.0, 0.0, NULL, NULL);
        for (int k = 0; k < nb; k++) {
            y[EN_TH(k)] = yp[EN_TH(k)];
            for (int i = 0; i < 2; i++) y[EN_POS(nb, k, i)] = yp[EN_POS(nb, k, i)];
            if (!rates) continue;
            y[EN_W(k)] = yp[EN_W(k)];
            for (int i = 0; i < 2; i++) y[EN_VEL(nb, k, i)] = yp[EN_VEL(nb, k, i)];
        }
        /* a contact that slides at xi' along its support's top t carries the bodies above it along */
        for (int k = 0; k < nb && rates; k++) {
            if (!v[k]) continue;
            double th = k > 0 ? y[EN_TH(k - 1)] : 0.0, t[2] = {cos(th), -sin(th)};
            for (int j = k; j < nb; j++)
                for (int i = 0; i < 2; i++) y[EN_VEL(nb, j, i)] += v[k] * t[i];
        }
        return;
    }
    double row[EN_ROWS][EN_NQ], res[EN_ROWS], rate[EN_ROWS];
    flatten(s, m, y, rates);
    for (int it = 0; it < 3; it++) {
        int nr = constraint_rows(s, m, y, xi0, row, res, rate);
        if (!nr) return;
        double big = 0.0;
        for (int i = 0; i < nr; i++) big = fmax(big, fabs(res[i]));
        if (big == 0.0) break;
        correct(s, row, nr, res, y, 0);
    }
    if (!rates) return;
    int nr = constraint_rows(s, m, y, xi0, row, res, rate);
    correct(s, row, nr, rate, y, 1);
}
