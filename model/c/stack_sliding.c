/* Rocking-sliding of two stacked blocks: the pattern systems, their consistency,
 * the choice of a pattern and the impact law with friction (stack_sliding.h,
 * docs/stack_sliding.md). */
#include "stack_sliding.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "ground.h"

#define NX 10
#define TOL_OPEN 1e-9     /* normalised end margin below which a flat contact opens */
#define TOL_FORCE 1e-12   /* normalised normal force and friction margin tolerance */
#define TOL_SLIP_ACC 1e-9 /* a slip starting from rest may accelerate against its sign by this much of g */

int ss_on(const Model *M) { return M->v.nBlocks == 2 && M->v.contactModel == 1; }

void ss_qw(const double *y, double q[4], double w[4]) {
    q[0] = y[SS_U1], q[1] = y[0], q[2] = y[SS_U2], q[3] = y[2];
    w[0] = y[SS_V1], w[1] = y[1], w[2] = y[SS_V2], w[3] = y[3];
}

/* ------------------------------------------------------------------ kinematics */

typedef struct {
    double P[2], K[2], r1[2], r2[2]; /* ground pivot, block 2's pivot, centres (m) */
    double J1[2][4], J2[2][4];       /* d r_i / d q */
    double c1[2], c2[2];             /* velocity-product accelerations (m/s^2) */
    double t[2], n[2];               /* block 1's top: tangent and normal */
} Kin;

/* rot(theta) v (clockwise rotation) and d rot / d theta v */
static void rot(double c, double s, const double v[2], double out[2]) {
    out[0] = c * v[0] + s * v[1];
    out[1] = -s * v[0] + c * v[1];
}
static void drot(double c, double s, const double v[2], double out[2]) {
    out[0] = -s * v[0] + c * v[1];
    out[1] = -c * v[0] - s * v[1];
}

static void kinematics(const Model *M, const double q[4], const double w[4], int s1, int s2, Kin *k) {
    const Variables *v = &M->v;
    double b1 = v->halfWidth, h1 = v->halfHeight, b2 = v->halfWidth2, h2 = v->halfHeight2;
    double c1 = cos(q[1]), sn1 = sin(q[1]), c2 = cos(q[3]), sn2 = sin(q[3]);
    double v1[2] = {-s1 * b1, h1}, kk[2] = {s2 * b2 + q[2] - s1 * b1, 2.0 * h1}, v2[2] = {-s2 * b2, h2};
    double ex[2] = {1.0, 0.0}, ey[2] = {0.0, 1.0};
    double R1v1[2], R1k[2], R2v2[2], D1v1[2], D1k[2], D2v2[2], D1ex[2];
    rot(c1, sn1, v1, R1v1);
    rot(c1, sn1, kk, R1k);
    rot(c2, sn2, v2, R2v2);
    drot(c1, sn1, v1, D1v1);
    drot(c1, sn1, kk, D1k);
    drot(c2, sn2, v2, D2v2);
    drot(c1, sn1, ex, D1ex);
    rot(c1, sn1, ex, k->t);
    rot(c1, sn1, ey, k->n);
    k->P[0] = s1 * b1 + q[0], k->P[1] = 0.0;
    for (int i = 0; i < 2; i++) {
        k->r1[i] = k->P[i] + R1v1[i];
        k->K[i] = k->P[i] + R1k[i];
        k->r2[i] = k->K[i] + R2v2[i];
        k->J1[i][0] = ex[i], k->J1[i][1] = D1v1[i], k->J1[i][2] = 0.0, k->J1[i][3] = 0.0;
        k->J2[i][0] = ex[i], k->J2[i][1] = D1k[i], k->J2[i][2] = k->t[i], k->J2[i][3] = D2v2[i];
        k->c1[i] = -R1v1[i] * w[1] * w[1];
        k->c2[i] = -R1k[i] * w[1] * w[1] + 2.0 * D1ex[i] * w[1] * w[2] - R2v2[i] * w[3] * w[3];
    }
}

/* clockwise moment of a unit force along dir applied at offset d */
static double moment(const double d[2], const double dir[2]) { return d[1] * dir[0] - d[0] * dir[1]; }

/* Two rows of one contact: flat (relative rotation fixed) or rocking (no couple); sticking (slip
 * fixed) or sliding (T + sigma mu N = 0). */
static void mode_rows(double A[NX][NX], int row, const ContactKind *c, int rotA, int rotB, int slipCol, int T,
                      int N, int Mc, double mu) {
    if (c->flat) {
        A[row][rotA] = 1.0;
        if (rotB >= 0) A[row][rotB] = -1.0;
    } else {
        A[row][Mc] = 1.0;
    }
    if (c->sigma) {
        A[row + 1][T] = 1.0;
        A[row + 1][N] = c->sigma * mu;
    } else {
        A[row + 1][slipCol] = 1.0;
    }
}

static void pattern_matrix(const Model *M, const Kin *k, const StackPattern *p, double A[NX][NX]) {
    const Variables *v = &M->v;
    const Derived *d = &M->d;
    enum { T0 = 4, N0, M0, T1, N1, M1 };
    double ex[2] = {1.0, 0.0}, ey[2] = {0.0, 1.0}, dP1[2], dK1[2], dK2[2];
    memset(A, 0, sizeof(double) * NX * NX);
    for (int i = 0; i < 2; i++) {
        dP1[i] = k->P[i] - k->r1[i];
        dK1[i] = k->K[i] - k->r1[i];
        dK2[i] = k->K[i] - k->r2[i];
    }
    for (int j = 0; j < 4; j++) {
        A[0][j] = v->mass * k->J1[0][j];
        A[1][j] = v->mass * k->J1[1][j];
        A[3][j] = v->mass2 * k->J2[0][j];
        A[4][j] = v->mass2 * k->J2[1][j];
    }
    A[0][T0] = -1.0, A[1][N0] = -1.0;
    A[0][T1] = k->t[0], A[0][N1] = k->n[0], A[1][T1] = k->t[1], A[1][N1] = k->n[1];
    A[2][1] = d->Ic1;
    A[2][T0] = -moment(dP1, ex), A[2][N0] = -moment(dP1, ey), A[2][M0] = -1.0;
    A[2][T1] = moment(dK1, k->t), A[2][N1] = moment(dK1, k->n), A[2][M1] = 1.0;
    A[3][T1] = -k->t[0], A[3][N1] = -k->n[0], A[4][T1] = -k->t[1], A[4][N1] = -k->n[1];
    A[5][3] = d->Ic2;
    A[5][T1] = -moment(dK2, k->t), A[5][N1] = -moment(dK2, k->n), A[5][M1] = -1.0;
    mode_rows(A, 6, &p->g, 1, -1, 0, T0, N0, M0, v->muGround);
    mode_rows(A, 8, &p->i, 3, 1, 2, T1, N1, M1, v->muInterface);
}

/* Gaussian elimination with partial pivoting; 0 if singular. */
static int solve_linear(double A[NX][NX], double b[NX], double x[NX]) {
    for (int c = 0; c < NX; c++) {
        int piv = c;
        double best = fabs(A[c][c]);
        for (int r = c + 1; r < NX; r++)
            if (fabs(A[r][c]) > best) best = fabs(A[r][c]), piv = r;
        if (!(best > 0.0)) return 0;
        if (piv != c) {
            for (int j = 0; j < NX; j++) {
                double tmp = A[c][j];
                A[c][j] = A[piv][j];
                A[piv][j] = tmp;
            }
            double tb = b[c];
            b[c] = b[piv];
            b[piv] = tb;
        }
        for (int r = c + 1; r < NX; r++) {
            double f = A[r][c] / A[c][c];
            if (f == 0.0) continue;
            for (int j = c; j < NX; j++) A[r][j] -= f * A[c][j];
            b[r] -= f * b[c];
        }
    }
    for (int r = NX - 1; r >= 0; r--) {
        double s = b[r];
        for (int j = r + 1; j < NX; j++) s -= A[r][j] * x[j];
        x[r] = s / A[r][r];
    }
    return 1;
}

/* The components a pattern fixes, exactly (the solve leaves rounding residue). */
static void exact_constraints(const StackPattern *p, double qd[4]) {
    if (p->g.flat) qd[1] = 0.0;
    if (!p->g.sigma) qd[0] = 0.0;
    if (p->i.flat) qd[3] = qd[1];
    if (!p->i.sigma) qd[2] = 0.0;
}

static int solve_with(const Model *M, const StackPattern *p, const double q[4], const double w[4], double ah,
                      double av, SsSolution *sol, Kin *k) {
    const Variables *v = &M->v;
    double A[NX][NX], b[NX] = {0}, x[NX], G = v->g + av;
    kinematics(M, q, w, p->g.s, p->i.s, k);
    pattern_matrix(M, k, p, A);
    b[0] = -v->mass * (k->c1[0] + ah);
    b[1] = -v->mass * (k->c1[1] + G);
    b[3] = -v->mass2 * (k->c2[0] + ah);
    b[4] = -v->mass2 * (k->c2[1] + G);
    if (!solve_linear(A, b, x)) return 0;
    for (int i = 0; i < 4; i++) sol->qdd[i] = x[i];
    for (int i = 0; i < 6; i++) sol->F[i] = x[4 + i];
    exact_constraints(p, sol->qdd);
    return 1;
}

int ss_solve(const Model *M, const StackPattern *p, const double q[4], const double w[4], double ah, double av,
             SsSolution *sol) {
    Kin k;
    return solve_with(M, p, q, w, ah, av, sol, &k);
}

/* ------------------------------------------------------------------ consistency */

static void interface_ends(const Model *M, double u2, double *lo, double *hi) {
    const Variables *v = &M->v;
    *lo = fmax(-v->halfWidth, u2 - v->halfWidth2);
    *hi = fmin(v->halfWidth, u2 + v->halfWidth2);
}

/* moments about the right and left ends of a flat contact's force system (N at the pivot, couple M) */
static void flat_margins(double dLeft, double dRight, double N, double Mc, double *right, double *left) {
    *right = dRight * N + Mc;
    *left = -(dLeft * N + Mc);
}

void ss_indicators(const Model *M, const StackPattern *p, const double q[4], const SsSolution *sol,
                   double ind[SS_IND]) {
    const Variables *v = &M->v;
    const double *F = sol->F;
    double W0 = (v->mass + v->mass2) * v->g, W1 = v->mass2 * v->g, b1 = v->halfWidth, b2 = v->halfWidth2;
    for (int i = 0; i < SS_IND; i++) ind[i] = INFINITY;
    ind[0] = F[1] / W0;
    ind[1] = F[4] / W1;
    if (p->g.flat) {
        double r, l;
        flat_margins(-b1 - p->g.s * b1, b1 - p->g.s * b1, F[1], F[2], &r, &l);
        ind[2] = r / (W0 * b1), ind[3] = l / (W0 * b1);
    }
    if (p->i.flat) {
        double lo, hi, r, l, kk = p->i.s * b2 + q[2];
        interface_ends(M, q[2], &lo, &hi);
        flat_margins(lo - kk, hi - kk, F[4], F[5], &r, &l);
        ind[4] = r / (W1 * b2), ind[5] = l / (W1 * b2);
    }
    if (!p->g.sigma) ind[6] = (v->muGround * F[1] - fabs(F[0])) / W0;
    if (!p->i.sigma) ind[7] = (v->muInterface * F[4] - fabs(F[3])) / W1;
}

/* gap angle, its rate and the slip rate of a contact */
static void gap_of(const double q[4], const double w[4], int contact, double *gap, double *rate, double *slip) {
    if (contact == 0) *gap = q[1], *rate = w[1], *slip = w[0];
    else *gap = q[3] - q[1], *rate = w[3] - w[1], *slip = w[2];
}

int ss_consistent(const Model *M, const StackPattern *p, const double q[4], const double w[4],
                  const SsSolution *sol, int allowOverhang) {
    const Variables *v = &M->v;
    double ind[SS_IND];
    ss_indicators(M, p, q, sol, ind);
    for (int i = 0; i < SS_IND; i++) {
        double tol = (i >= 2 && i <= 5) ? TOL_OPEN : TOL_FORCE;
        if (ind[i] < -tol) return 0;
    }
    if (!p->i.flat && fabs(q[2] + p->i.s * v->halfWidth2) > v->halfWidth && !allowOverhang) return 0;
    double tolAcc = 1e-12 * v->g / hypot(v->halfWidth, M->d.yG);
    for (int c = 0; c < 2; c++) {
        const ContactKind *m = c == 0 ? &p->g : &p->i;
        double gap, rate, slip;
        gap_of(q, w, c, &gap, &rate, &slip);
        double slipAcc = c == 0 ? sol->qdd[0] : sol->qdd[2];
        double gapAcc = c == 0 ? sol->qdd[1] : sol->qdd[3] - sol->qdd[1];
        if (m->sigma && slip == 0.0 && m->sigma * slipAcc < -TOL_SLIP_ACC * v->g) return 0;
        if (!m->flat && gap == 0.0 && rate == 0.0 && m->s * gapAcc < -tolAcc) return 0;
    }
    return 1;
}

int ss_is_rest(const StackPattern *p) { return p->g.flat && p->i.flat && !p->g.sigma && !p->i.sigma; }

static int sgn(double x) { return x > 0 ? 1 : -1; }

/* The modes a contact may take from the state (docs/stack_sliding.md, "Choosing the pattern"),
 * in the reference's order: kinds (flat, rock +1, rock -1) outer, slip signs (0, +1, -1) inner. */
static int candidates(const double q[4], const double w[4], int contact, int exclude, ContactKind out[9]) {
    double gap, rate, slip;
    gap_of(q, w, contact, &gap, &rate, &slip);
    int kinds[3][2], nk = 0, sig[3], ns = 0, n = 0;
    if (gap == 0.0 && rate == 0.0) {
        if (!(exclude & SS_NOT_FLAT)) kinds[nk][0] = 1, kinds[nk][1] = 1, nk++;
        if (!(exclude & SS_NOT_ROCK)) {
            kinds[nk][0] = 0, kinds[nk][1] = 1, nk++;
            kinds[nk][0] = 0, kinds[nk][1] = -1, nk++;
        }
    } else {
        kinds[nk][0] = 0, kinds[nk][1] = gap != 0.0 ? sgn(gap) : sgn(rate), nk++;
    }
    if (slip == 0.0) {
        if (!(exclude & SS_NOT_STICK)) sig[ns++] = 0;
        if (!(exclude & SS_NOT_PLUS)) sig[ns++] = 1;
        if (!(exclude & SS_NOT_MINUS)) sig[ns++] = -1;
    } else {
        sig[ns++] = sgn(slip);
    }
    for (int a = 0; a < nk; a++)
        for (int b = 0; b < ns; b++) {
            out[n].flat = kinds[a][0], out[n].s = kinds[a][1], out[n].sigma = sig[b];
            n++;
        }
    return n;
}

/* least motion first: fewer rocking contacts, fewer sliding ones, the ground rocking first */
static int order_key(const StackPattern *p) {
    int nRock = !p->g.flat + !p->i.flat, nSlide = (p->g.sigma != 0) + (p->i.sigma != 0);
    return nRock * 100 + nSlide * 10 + p->g.flat;
}

int ss_select(const Model *M, double t, const double q[4], const double w[4], const int exclude[2], int allowRest,
              int allowOverhang, StackPattern *out) {
    ContactKind gs[9], is[9];
    int ng = candidates(q, w, 0, exclude ? exclude[0] : 0, gs), ni = candidates(q, w, 1, exclude ? exclude[1] : 0, is);
    StackPattern pats[81];
    int keys[81], n = 0;
    for (int a = 0; a < ng; a++)
        for (int b = 0; b < ni; b++) { /* stable insertion by key */
            StackPattern p = {gs[a], is[b]};
            int key = order_key(&p), j = n++;
            while (j > 0 && keys[j - 1] > key) {
                pats[j] = pats[j - 1];
                keys[j] = keys[j - 1];
                j--;
            }
            pats[j] = p;
            keys[j] = key;
        }
    double ah, av;
    model_ground(M, t, &ah, &av);
    for (int k = 0; k < n; k++) {
        SsSolution sol;
        if (!allowRest && ss_is_rest(&pats[k])) continue;
        if (!ss_solve(M, &pats[k], q, w, ah, av, &sol)) continue;
        if (ss_consistent(M, &pats[k], q, w, &sol, allowOverhang)) {
            *out = pats[k];
            return 1;
        }
    }
    return 0;
}

/* ------------------------------------------------------------------ motion and energy */

int ss_rhs(const Model *M, const StackPattern *p, double t, const double *y, int piece, double *dy, SsSolution *sol) {
    double q[4], w[4], ah, av;
    SsSolution s;
    Kin k;
    ss_qw(y, q, w);
    model_ground_piece(M, t, piece, &ah, &av);
    int ok = solve_with(M, p, q, w, ah, av, &s, &k);
    double v1[2], v2[2];
    for (int i = 0; i < 2; i++) {
        v1[i] = k.J1[i][0] * w[0] + k.J1[i][1] * w[1];
        v2[i] = k.J2[i][0] * w[0] + k.J2[i][1] * w[1] + k.J2[i][2] * w[2] + k.J2[i][3] * w[3];
    }
    dy[0] = w[1];
    dy[1] = s.qdd[1];
    dy[2] = w[3];
    dy[3] = s.qdd[3];
    dy[SS_WORK] = -(M->v.mass * (ah * v1[0] + av * v1[1]) + M->v.mass2 * (ah * v2[0] + av * v2[1]));
    dy[SS_U1] = w[0];
    dy[SS_V1] = s.qdd[0];
    dy[SS_U2] = w[2];
    dy[SS_V2] = s.qdd[2];
    dy[SS_LOSS1] = -s.F[0] * w[0];
    dy[SS_LOSS2] = -s.F[3] * w[2];
    if (sol) *sol = s;
    return ok;
}

static void body_velocities(const Kin *k, const double w[4], double v1[2], double v2[2]) {
    for (int i = 0; i < 2; i++) {
        v1[i] = k->J1[i][0] * w[0] + k->J1[i][1] * w[1];
        v2[i] = k->J2[i][0] * w[0] + k->J2[i][1] * w[1] + k->J2[i][2] * w[2] + k->J2[i][3] * w[3];
    }
}

double ss_kinetic(const Model *M, const double q[4], const double w[4], int s1, int s2) {
    const double zero[4] = {0, 0, 0, 0};
    Kin k;
    double v1[2], v2[2];
    kinematics(M, q, zero, s1, s2, &k);
    body_velocities(&k, w, v1, v2);
    return 0.5 * (M->v.mass * (v1[0] * v1[0] + v1[1] * v1[1]) + M->v.mass2 * (v2[0] * v2[0] + v2[1] * v2[1]) +
                  M->d.Ic1 * w[1] * w[1] + M->d.Ic2 * w[3] * w[3]);
}

double ss_momentum(const Model *M, const double *y, const StackPattern *p) {
    const double zero[4] = {0, 0, 0, 0};
    double q[4], w[4], v1[2], v2[2];
    Kin k;
    ss_qw(y, q, w);
    kinematics(M, q, zero, p->g.s, p->i.s, &k);
    body_velocities(&k, w, v1, v2);
    return M->v.mass * v1[0] + M->v.mass2 * v2[0];
}

double ss_energy(const Model *M, const double *y, const StackPattern *p) {
    const Variables *v = &M->v;
    const double zero[4] = {0, 0, 0, 0};
    double q[4], w[4];
    Kin k;
    ss_qw(y, q, w);
    kinematics(M, q, zero, p->g.s, p->i.s, &k);
    double pot = v->g * (v->mass * (k.r1[1] - v->halfHeight) +
                         v->mass2 * (k.r2[1] - 2.0 * v->halfHeight - v->halfHeight2));
    return ss_kinetic(M, q, w, p->g.s, p->i.s) + pot;
}

/* ------------------------------------------------------------------ impacts */

typedef struct {
    StackPattern p;
    double w[4], P[6];
} Impact;

/* Impulse-momentum with the pattern after the impact: the pattern's matrix with rates for
 * accelerations and impulses for forces; (o1, o2) the pivots the rates before refer to. */
static int solve_impact(const Model *M, const StackPattern *p, const double q[4], const double wm[4], int o1, int o2,
                        Impact *imp) {
    const double zero[4] = {0, 0, 0, 0};
    Kin ko, k;
    double A[NX][NX], b[NX] = {0}, x[NX], v1[2], v2[2];
    kinematics(M, q, zero, o1, o2, &ko);
    kinematics(M, q, zero, p->g.s, p->i.s, &k);
    body_velocities(&ko, wm, v1, v2);
    b[0] = M->v.mass * v1[0], b[1] = M->v.mass * v1[1], b[2] = M->d.Ic1 * wm[1];
    b[3] = M->v.mass2 * v2[0], b[4] = M->v.mass2 * v2[1], b[5] = M->d.Ic2 * wm[3];
    pattern_matrix(M, &k, p, A);
    if (!solve_linear(A, b, x)) return 0;
    imp->p = *p;
    for (int i = 0; i < 4; i++) imp->w[i] = x[i];
    for (int i = 0; i < 6; i++) imp->P[i] = x[4 + i];
    exact_constraints(p, imp->w);
    return 1;
}

static int impact_consistent(const Model *M, const Impact *imp, const double q[4], int landing, double tol,
                             int checkOther) {
    const Variables *v = &M->v;
    const StackPattern *p = &imp->p;
    const double *w = imp->w;
    double PT0 = imp->P[0], PN0 = imp->P[1], PM0 = imp->P[2], PT1 = imp->P[3], PN1 = imp->P[4], PM1 = imp->P[5];
    double b1 = v->halfWidth, b2 = v->halfWidth2;
    if (!checkOther) { /* the contact that does not land is taken as it comes (held, sticking) */
        if (landing == 0) PN1 = fmax(PN1, 0.0) + fabs(PT1) / v->muInterface + 1.0;
        else PN0 = fmax(PN0, 0.0) + fabs(PT0) / v->muGround + 1.0;
    }
    if (PN0 < -tol || PN1 < -tol) return 0;
    if (checkOther && p->g.flat && landing != 0) {
        double r, l;
        flat_margins(-b1 - p->g.s * b1, b1 - p->g.s * b1, PN0, PM0, &r, &l);
        if (fmin(r, l) < -tol * b1) return 0;
    }
    if (checkOther && p->i.flat && landing != 1) {
        double lo, hi, r, l, kk = p->i.s * b2 + q[2];
        interface_ends(M, q[2], &lo, &hi);
        flat_margins(lo - kk, hi - kk, PN1, PM1, &r, &l);
        if (fmin(r, l) < -tol * b2) return 0;
    }
    const ContactKind *ms[2] = {&p->g, &p->i};
    double Ts[2] = {PT0, PT1}, Ns[2] = {PN0, PN1}, mus[2] = {v->muGround, v->muInterface}, slips[2] = {w[0], w[2]};
    for (int c = 0; c < 2; c++) {
        if (!ms[c]->sigma && fabs(Ts[c]) > mus[c] * Ns[c] + tol) return 0;
        if (ms[c]->sigma && ms[c]->sigma * slips[c] < 0.0) return 0;
    }
    const ContactKind *land = landing == 0 ? &p->g : &p->i, *other = landing == 0 ? &p->i : &p->g;
    double rate = landing == 0 ? w[1] : w[3] - w[1];
    if (!land->flat && land->s * rate < 0.0) return 0;
    double orate = landing == 0 ? w[3] - w[1] : w[1], ogap = landing == 0 ? q[3] - q[1] : q[1];
    if (!other->flat && ogap == 0.0 && other->s * orate < 0.0) return 0;
    return 1;
}

static void restitute(const Model *M, Impact *imp, const double q[4], const double wm[4], int o1, int o2,
                      int landing) {
    if (M->v.law != 2) return;
    double eta = landing == 0 ? M->v.etaGround : M->v.etaInterface;
    double Tm = ss_kinetic(M, q, wm, o1, o2), Tp = ss_kinetic(M, q, imp->w, imp->p.g.s, imp->p.i.s);
    double f = Tp > 0 ? eta * sqrt(Tm / Tp) : 0.0;
    for (int i = 0; i < 4; i++) imp->w[i] *= f;
}

static StackPattern make_pattern(int landing, ContactKind lm, ContactKind om) {
    StackPattern p;
    if (landing == 0) p.g = lm, p.i = om;
    else p.g = om, p.i = lm;
    return p;
}

/* The last resort when Coulomb's law leaves no consistent plastic impact: the one-block law's rule
 * contact by contact (docs/stack_sliding.md, "Impacts with friction"). */
static int saturated_impact(const Model *M, int landing, const StackPattern *pat, const double q[4],
                            const double wm[4], Impact *imp) {
    const Variables *v = &M->v;
    const ContactKind *land = landing == 0 ? &pat->g : &pat->i, *other = landing == 0 ? &pat->i : &pat->g;
    ContactKind lm = {0, -land->s, 0}, om = {other->flat, other->s, 0};
    StackPattern trial = make_pattern(landing, lm, om);
    Impact stick;
    if (!solve_impact(M, &trial, q, wm, pat->g.s, pat->i.s, &stick)) return 0;
    StackPattern p = trial;
    double T0 = stick.P[0], N0 = stick.P[1], T1 = stick.P[3], N1 = stick.P[4];
    p.g.sigma = fabs(T0) <= v->muGround * fmax(N0, 0.0) ? 0 : (T0 > 0 ? -1 : 1);
    p.i.sigma = fabs(T1) <= v->muInterface * fmax(N1, 0.0) ? 0 : (T1 > 0 ? -1 : 1);
    if (!solve_impact(M, &p, q, wm, pat->g.s, pat->i.s, imp)) return 0;
    double N = landing == 0 ? imp->P[1] : imp->P[4];
    if (N < 0 || ss_kinetic(M, q, imp->w, p.g.s, p.i.s) > ss_kinetic(M, q, wm, pat->g.s, pat->i.s)) return 0;
    return 1;
}

int ss_impact(const Model *M, int landing, const StackPattern *pat, const double q[4], const double w[4],
              StackPattern *out, double wp[4], double impulses[6]) {
    const ContactKind *land = landing == 0 ? &pat->g : &pat->i, *other = landing == 0 ? &pat->i : &pat->g;
    int o1 = pat->g.s, o2 = pat->i.s;
    /* tolerance: 1e-12 of the largest velocity component times the total mass */
    const double zero[4] = {0, 0, 0, 0};
    Kin ko;
    double v1[2], v2[2], scale = 1e-300;
    kinematics(M, q, zero, o1, o2, &ko);
    body_velocities(&ko, w, v1, v2);
    double comps[6] = {v1[0], v1[1], w[1], v2[0], v2[1], w[3]};
    for (int i = 0; i < 6; i++) scale = fmax(scale, fabs(comps[i]));
    double tol = 1e-12 * scale * (M->v.mass + M->v.mass2);
    /* candidates: the landing contact on its new corner, else flat; the other contact in its kind,
     * else (if flat) opening about either end; fewest sliding contacts first; the slip signs in the
     * order 0, +1, -1. Tried in that order, generated as they are tried (most impacts take the
     * first). */
    ContactKind okinds[3] = {{other->flat, other->s, 0}, {0, 1, 0}, {0, -1, 0}};
    int sig[3] = {0, 1, -1};
    Impact imp;
    int result = 0;
    for (int pass = 0; pass < 2 && !result; pass++) /* pass 1: the other contact held, sticking */
        for (int nk = 0; nk < 2 && !result; nk++)
            for (int open = 0; open < (other->flat && !pass ? 2 : 1) && !result; open++)
                for (int ns = 0; ns < 3 && !result; ns++)
                    for (int ok = open ? 1 : 0; ok < (open ? 3 : 1) && !result; ok++)
                        for (int ia = 0; ia < 3 && !result; ia++)
                            for (int ib = 0; ib < 3 && !result; ib++) {
                                if ((sig[ia] != 0) + (sig[ib] != 0) != ns || (pass && sig[ib] != 0)) continue;
                                ContactKind lm = {nk, -land->s, sig[ia]}, om = okinds[ok];
                                om.sigma = sig[ib];
                                StackPattern cand = make_pattern(landing, lm, om);
                                if (solve_impact(M, &cand, q, w, o1, o2, &imp) &&
                                    impact_consistent(M, &imp, q, landing, tol, !pass))
                                    result = pass ? 2 : 1;
                            }
    if (!result && saturated_impact(M, landing, pat, q, w, &imp)) result = 2;
    if (!result) return 0;
    restitute(M, &imp, q, w, o1, o2, landing);
    *out = imp.p;
    memcpy(wp, imp.w, 4 * sizeof(double));
    if (impulses) memcpy(impulses, imp.P, 6 * sizeof(double));
    return result;
}

double ss_settle_rate(const Model *M, int contact, double av) {
    const Variables *v = &M->v;
    const Derived *d = &M->d;
    /* block 2 about its corner (b2 <= b1: the rigid stack's contact half width c is b2), or the pair
     * as one body about a corner of block 1 (stack_derive) */
    double ge = v->g + av;
    double W = contact == 1 ? v->mass2 * ge : d->mTot * ge, R = contact == 1 ? d->RI : d->RL;
    double a = contact == 1 ? d->alphaI : d->alphaL, I = contact == 1 ? d->II : d->IL;
    double lift = cos(a - v->restRatio * a) - cos(a);
    return lift > 0 ? sqrt(2.0 * W * R * lift / I) : 0.0;
}

void ss_close(const Model *M, const StackPattern *p, const double q[4], const double w[4], int closing,
              StackPattern *out, double wp[4]) {
    StackPattern n = *p;
    Impact imp;
    if (closing & 1) n.g.flat = 1;
    if (closing & 2) n.i.flat = 1;
    if (solve_impact(M, &n, q, w, p->g.s, p->i.s, &imp)) {
        memcpy(wp, imp.w, 4 * sizeof(double));
    } else {
        memcpy(wp, w, 4 * sizeof(double));
    }
    *out = n;
}

static const char *kind_label(const ContactKind *c) {
    return c->flat ? (c->sigma ? "slide" : "stick") : (c->sigma ? "slide-rock" : "rock");
}

const char *ss_label(const StackPattern *p, char buf[40]) {
    snprintf(buf, 40, "%s/%s", kind_label(&p->g), kind_label(&p->i));
    return buf;
}
