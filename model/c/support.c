/* Supports under one-way coupling: the exact motion of a linear shear building's floor or of an
 * isolation platform under a piecewise-linear base acceleration (support.h, docs/supports.md). */
#include "support.h"
#include "model.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#define FAIL(...)                      \
    do {                               \
        snprintf(msg, n, __VA_ARGS__); \
        return 1;                      \
    } while (0)

/* After the record the free vibration's cells are this many periods of the fastest mode long. */
#define SUPPORT_FREE_CELL 0.125
/* Dyadic levels of the search for the floor acceleration's extrema in one cell (2^-60 of a cell is
 * below the rounding of any time): deeper, a double root of the slope (an inflexion with zero slope,
 * not an extremum) is left uncut. */
#define SUPPORT_MAX_DEPTH 60

static void masses(const Variables *v, double *m) {
    const double a[SUPPORT_MAX_STOREYS] = {v->storeyMass1, v->storeyMass2, v->storeyMass3, v->storeyMass4,
                                           v->storeyMass5, v->storeyMass6, v->storeyMass7, v->storeyMass8,
                                           v->storeyMass9, v->storeyMass10};
    memcpy(m, a, sizeof(a));
}

static void stiffnesses(const Variables *v, double *k) {
    const double a[SUPPORT_MAX_STOREYS] = {v->storeyStiffness1, v->storeyStiffness2, v->storeyStiffness3,
                                           v->storeyStiffness4, v->storeyStiffness5, v->storeyStiffness6,
                                           v->storeyStiffness7, v->storeyStiffness8, v->storeyStiffness9,
                                           v->storeyStiffness10};
    memcpy(k, a, sizeof(a));
}

int support_validate(const Variables *v, char *msg, size_t n) {
    if (v->supportKind < 0 || v->supportKind > 2)
        FAIL("support.kind = %d must be 0 (the ground), 1 (a shear building) or 2 (an isolation platform)",
             v->supportKind);
    if (v->supportCoupling < 0 || v->supportCoupling > 1)
        FAIL("support.coupling = %d must be 0 (one-way) or 1 (two-way)", v->supportCoupling);
    if (v->supportForce != 0.0 && (v->supportKind == SUPPORT_GROUND || v->supportCoupling != 1))
        FAIL("support.force = %g N acts on a two-way support (support.kind 1 or 2 with support.coupling = 1), not with "
             "support.kind = %d, support.coupling = %d", v->supportForce, v->supportKind, v->supportCoupling);
    if (v->supportKind == SUPPORT_GROUND) return 0;
    if (v->kind != KIND_RECORD && v->kind != KIND_NONE)
        FAIL("support.kind = %d moves with a record at its base: excitation.kind must be 4 (a record file) or 0, "
             "not %d (give the pulse as a record file)", v->supportKind, v->kind);
    if (v->supportKind == SUPPORT_BUILDING) {
        if (v->storeys < 1 || v->storeys > SUPPORT_MAX_STOREYS)
            FAIL("building.storeys = %d must be 1 to %d", v->storeys, SUPPORT_MAX_STOREYS);
        if (v->buildingFloor < 0 || v->buildingFloor > v->storeys)
            FAIL("building.floor = %d must be 1 to building.storeys = %d (0: the top floor)", v->buildingFloor,
                 v->storeys);
        if (!(v->dampingRatio >= 0 && v->dampingRatio < 1))
            FAIL("building.dampingRatio = %g must be in [0, 1)", v->dampingRatio);
        double m[SUPPORT_MAX_STOREYS], k[SUPPORT_MAX_STOREYS];
        masses(v, m);
        stiffnesses(v, k);
        for (int i = 0; i < v->storeys; i++) {
            if (!(m[i] > 0)) FAIL("building.storey[%d].mass = %g must be > 0 kg", i + 1, m[i]);
            if (!(k[i] > 0)) FAIL("building.storey[%d].stiffness = %g must be > 0 N/m", i + 1, k[i]);
        }
    } else {
        if (!(v->platformMass > 0)) FAIL("platform.mass = %g must be > 0 kg", v->platformMass);
        if (!(v->platformStiffness >= 0)) FAIL("platform.stiffness = %g must be >= 0 N/m", v->platformStiffness);
        if (!(v->platformDamping >= 0)) FAIL("platform.damping = %g must be >= 0 N s/m", v->platformDamping);
    }
    return 0;
}

/* ------------------------------------------------------------------ modes */

/* Eigenvalues w and orthonormal eigenvectors (columns of V, row-major n x n) of the symmetric A (destroyed):
 * cyclic Jacobi rotations (Golub & Van Loan 2013, section 8.5), to rounding. */
static void jacobi(int n, double *A, double *w, double *V) {
    for (int i = 0; i < n * n; i++) V[i] = 0.0;
    for (int i = 0; i < n; i++) V[i * n + i] = 1.0;
    for (int sweep = 0; sweep < 100; sweep++) {
        double off = 0.0, diag = 0.0;
        for (int i = 0; i < n; i++)
            for (int j = 0; j < n; j++) *(i == j ? &diag : &off) += A[i * n + j] * A[i * n + j];
        if (off <= 1e-34 * diag) break;
        for (int p = 0; p < n - 1; p++)
            for (int q = p + 1; q < n; q++) {
                double apq = A[p * n + q];
                if (apq == 0.0) continue;
                double theta = (A[q * n + q] - A[p * n + p]) / (2.0 * apq);
                double t = (theta >= 0 ? 1.0 : -1.0) / (fabs(theta) + sqrt(theta * theta + 1.0));
                double c = 1.0 / sqrt(t * t + 1.0), s = t * c;
                for (int k = 0; k < n; k++) { /* A <- A J */
                    double akp = A[k * n + p], akq = A[k * n + q];
                    A[k * n + p] = c * akp - s * akq;
                    A[k * n + q] = s * akp + c * akq;
                }
                for (int k = 0; k < n; k++) { /* A <- J^T A */
                    double apk = A[p * n + k], aqk = A[q * n + k];
                    A[p * n + k] = c * apk - s * aqk;
                    A[q * n + k] = s * apk + c * aqk;
                }
                for (int k = 0; k < n; k++) { /* V <- V J */
                    double vkp = V[k * n + p], vkq = V[k * n + q];
                    V[k * n + p] = c * vkp - s * vkq;
                    V[k * n + q] = s * vkp + c * vkq;
                }
            }
    }
    for (int i = 0; i < n; i++) w[i] = A[i * n + i];
}

/* The exponential terms of mode r (k1, k2) appended to sm. */
static void mode_terms(SupportModes *sm, double k1, double k2) {
    if (k2 > 0) {
        double disc = k1 * k1 - 4.0 * k2;
        if (disc < 0) { /* underdamped: one complex pair, taken as Re */
            sm->lre[sm->nt] = -0.5 * k1;
            sm->lim[sm->nt++] = 0.5 * sqrt(-disc);
        } else if (disc == 0) { /* critically damped: one double root */
            sm->lre[sm->nt] = -0.5 * k1;
            sm->lim[sm->nt++] = 0.0;
        } else { /* overdamped: two real roots, the small one without cancellation */
            double sq = sqrt(disc);
            sm->lre[sm->nt] = -2.0 * k2 / (k1 + sq);
            sm->lim[sm->nt++] = 0.0;
            sm->lre[sm->nt] = -0.5 * (k1 + sq);
            sm->lim[sm->nt++] = 0.0;
        }
    } else if (k1 > 0) { /* a damper without spring */
        sm->lre[sm->nt] = -k1;
        sm->lim[sm->nt++] = 0.0;
    }
}

void support_derive(const Variables *v, SupportModes *sm) {
    memset(sm, 0, sizeof(*sm));
    if (v->supportKind == SUPPORT_PLATFORM) {
        sm->nm = 1;
        sm->k2[0] = v->platformStiffness / v->platformMass;
        sm->k1[0] = v->platformDamping / v->platformMass;
        sm->c[0] = 1.0;
        sm->freq[0] = sqrt(sm->k2[0]) / (2.0 * M_PI);
        sm->ns = 1;
        sm->mass[0] = v->platformMass;
        sm->stiff[0] = v->platformStiffness;
        sm->a0 = v->platformDamping / v->platformMass;
    } else if (v->supportKind == SUPPORT_BUILDING) {
        int N = v->storeys, j = (v->buildingFloor == 0 ? N : v->buildingFloor) - 1;
        double m[SUPPORT_MAX_STOREYS], k[SUPPORT_MAX_STOREYS + 1] = {0};
        double A[SUPPORT_MAX_STOREYS * SUPPORT_MAX_STOREYS] = {0}, V[SUPPORT_MAX_STOREYS * SUPPORT_MAX_STOREYS];
        double w2[SUPPORT_MAX_STOREYS];
        masses(v, m);
        stiffnesses(v, k);
        k[N] = 0.0;
        /* A = M^-1/2 K M^-1/2, tridiagonal */
        for (int i = 0; i < N; i++) {
            A[i * N + i] = (k[i] + (i + 1 < N ? k[i + 1] : 0.0)) / m[i];
            if (i + 1 < N) A[i * N + i + 1] = A[(i + 1) * N + i] = -k[i + 1] / sqrt(m[i] * m[i + 1]);
        }
        jacobi(N, A, w2, V);
        /* modes in increasing frequency */
        int order[SUPPORT_MAX_STOREYS];
        for (int i = 0; i < N; i++) order[i] = i;
        for (int i = 1; i < N; i++)
            for (int p = i; p > 0 && w2[order[p]] < w2[order[p - 1]]; p--) {
                int t = order[p];
                order[p] = order[p - 1];
                order[p - 1] = t;
            }
        double w1 = sqrt(w2[order[0]]), wB = N > 1 ? sqrt(w2[order[1]]) : w1, zeta = v->dampingRatio;
        /* Rayleigh C = a0 M + a1 K with zeta at modes 1 and 2 (Chopra 2012, section 11.4); one storey:
         * stiffness-proportional */
        double a0 = N > 1 ? 2.0 * zeta * w1 * wB / (w1 + wB) : 0.0, a1 = N > 1 ? 2.0 * zeta / (w1 + wB) : 2.0 * zeta / w1;
        sm->nm = sm->ns = N;
        sm->j = j;
        memcpy(sm->mass, m, sizeof(sm->mass));
        memcpy(sm->stiff, k, sizeof(sm->stiff));
        sm->a0 = a0;
        sm->a1 = a1;
        for (int r = 0; r < N; r++) {
            int c = order[r];
            double om2 = w2[c], gamma = 0.0;
            /* phi_r = M^-1/2 psi_r: u_j = sum_r phi_jr Gamma_r x_r, Gamma_r = phi_r^T M 1 */
            for (int i = 0; i < N; i++) gamma += sqrt(m[i]) * V[i * N + c];
            sm->k2[r] = om2;
            sm->k1[r] = a0 + a1 * om2;
            sm->c[r] = V[j * N + c] / sqrt(m[j]) * gamma;
            sm->freq[r] = sqrt(om2) / (2.0 * M_PI);
        }
    }
    sm->twoWay = sm->ns > 0 && v->supportCoupling == 1;
    for (int r = 0; r < sm->nm; r++) mode_terms(sm, sm->k1[r], sm->k2[r]);
    for (int t = 0; t < sm->nt; t++) {
        sm->labs[t] = hypot(sm->lre[t], sm->lim[t]);
        sm->fastest = fmax(sm->fastest, sm->labs[t]);
    }
}

/* ------------------------------------------------------------------ one segment */

typedef struct {
    double re, im;
} Cx;

static Cx cx(double re, double im) {
    Cx z = {re, im};
    return z;
}
static Cx cmul(Cx a, Cx b) { return cx(a.re * b.re - a.im * b.im, a.re * b.im + a.im * b.re); }
static Cx cadd(Cx a, Cx b) { return cx(a.re + b.re, a.im + b.im); }
static Cx cscale(Cx a, double s) { return cx(a.re * s, a.im * s); }
static Cx csub(Cx a, Cx b) { return cx(a.re - b.re, a.im - b.im); }
static Cx cdiv(Cx a, Cx b) {
    double d = b.re * b.re + b.im * b.im;
    return cx((a.re * b.re + a.im * b.im) / d, (a.im * b.re - a.re * b.im) / d);
}
static Cx cexpi(double re, double im) { /* e^(re + i im) */
    double e = exp(re);
    return cx(e * cos(im), e * sin(im));
}

/* Mode r's displacement on a segment from (x0, v0) under a_g = a0 + a1 s: its polynomial q[4] (zeroed by the
 * caller) and, for each of its terms (starting at term index t), (Z, Y). Returns its
 * number of terms. */
static int mode_segment(const SupportModes *sm, int r, int t, double x0, double v0, double a0, double a1, double *q,
                        Cx *Z, Cx *Y) {
    double k1 = sm->k1[r], k2 = sm->k2[r];
    if (k2 > 0) {
        /* particular solution p0 + p1 s */
        double p1 = -a1 / k2, p0 = -(a0 - k1 * a1 / k2) / k2, H0 = x0 - p0, H1 = v0 - p1;
        q[0] = p0;
        q[1] = p1;
        double lr = sm->lre[t], li = sm->lim[t];
        if (li > 0) { /* Re(Z e^(lambda s)) with Re Z = H0, Re(Z lambda) = H1 */
            Z[t] = cx(H0, (H0 * lr - H1) / li);
            Y[t] = cx(0.0, 0.0);
            return 1;
        }
        if (k1 * k1 == 4.0 * k2) { /* (Z + Y s) e^(lambda s) */
            Z[t] = cx(H0, 0.0);
            Y[t] = cx(H1 - lr * H0, 0.0);
            return 1;
        }
        double l1 = sm->lre[t], l2 = sm->lre[t + 1], z1 = (H1 - l2 * H0) / (l1 - l2);
        Z[t] = cx(z1, 0.0);
        Z[t + 1] = cx(H0 - z1, 0.0);
        Y[t] = Y[t + 1] = cx(0.0, 0.0);
        return 2;
    }
    if (k1 > 0) { /* v' + k1 v = -a_g: v = r0 + r1 s + Zv e^(-k1 s) */
        double r1 = -a1 / k1, r0 = -(a0 - a1 / k1) / k1, Zv = v0 - r0;
        q[0] = x0 + Zv / k1;
        q[1] = r0;
        q[2] = 0.5 * r1;
        Z[t] = cx(-Zv / k1, 0.0);
        Y[t] = cx(0.0, 0.0);
        return 1;
    }
    /* a free mass: x'' = -a_g */
    q[0] = x0;
    q[1] = v0;
    q[2] = -0.5 * a0;
    q[3] = -a1 / 6.0;
    return 0;
}

/* The k-th derivative of Re((Z + Y s) e^(lambda s)) at s: (lambda^k Z + k lambda^(k-1) Y + lambda^k Y s) e^(lambda s). */
static double term_derivative(double lr, double li, Cx Z, Cx Y, int k, double s) {
    Cx lam = cx(lr, li), pk = cx(1.0, 0.0), pk1 = cx(0.0, 0.0);
    for (int i = 0; i < k; i++) {
        pk1 = pk;
        pk = cmul(pk, lam);
    }
    Cx c = cadd(cmul(pk, cadd(Z, cscale(Y, s))), cscale(cmul(pk1, Y), (double)k));
    double e = exp(lr * s);
    return e * (c.re * cos(li * s) - c.im * sin(li * s));
}

static double poly_derivative(const double *q, int k, double s) {
    switch (k) {
    case 0: return q[0] + s * (q[1] + s * (q[2] + s * q[3]));
    case 1: return q[1] + s * (2.0 * q[2] + 3.0 * s * q[3]);
    case 2: return 2.0 * q[2] + 6.0 * s * q[3];
    case 3: return 6.0 * q[3];
    default: return 0.0;
    }
}

/* u^(k)(s) of table entry e. */
static double entry_derivative(const SupportModes *sm, const double *e, int k, double s) {
    double sum = poly_derivative(e, k, s);
    const double *z = e + 4;
    for (int t = 0; t < sm->nt; t++, z += 4)
        if (z[0] != 0.0 || z[1] != 0.0 || z[2] != 0.0 || z[3] != 0.0)
            sum += term_derivative(sm->lre[t], sm->lim[t], cx(z[0], z[1]), cx(z[2], z[3]), k, s);
    return sum;
}

/* A bound on |u^(k)| over [s0, s1] (0 <= s0 <= s1) of entry e: the polynomial's sum over p >= k of
 * |q_p| p! / (p - k)! s1^(p - k), and each term's (|lambda|^k |Z| + k |lambda|^(k-1) |Y| + |lambda|^k |Y| s1)
 * e^(Re lambda s0) (Re lambda <= 0). */
static double entry_bound(const SupportModes *sm, const double *e, int k, double s0, double s1) {
    static const double fall[4][4] = {{1, 1, 1, 1}, {0, 1, 2, 3}, {0, 0, 2, 6}, {0, 0, 0, 6}};
    double b = 0.0, sp = 1.0;
    for (int p = k; p < 4; p++, sp *= s1) b += fabs(e[p]) * fall[k][p] * sp;
    const double *z = e + 4;
    for (int t = 0; t < sm->nt; t++, z += 4) {
        double L = sm->labs[t], Lk1 = 1.0;
        for (int i = 1; i < k; i++) Lk1 *= L;
        double zz = sqrt(z[0] * z[0] + z[1] * z[1]), yy = sqrt(z[2] * z[2] + z[3] * z[3]);
        if (zz == 0.0 && yy == 0.0) continue;
        b += Lk1 * (L * (zz + yy * s1) + k * yy) * exp(sm->lre[t] * s0);
    }
    return b;
}

/* u^(k)(s) and u^(k+1)(s) of entry e, with one exponential per term. */
static void entry_derivative2(const SupportModes *sm, const double *e, int k, double s, double *d0, double *d1) {
    *d0 = poly_derivative(e, k, s);
    *d1 = poly_derivative(e, k + 1, s);
    const double *z = e + 4;
    for (int t = 0; t < sm->nt; t++, z += 4) {
        if (z[0] == 0.0 && z[1] == 0.0 && z[2] == 0.0 && z[3] == 0.0) continue;
        Cx lam = cx(sm->lre[t], sm->lim[t]), pk = cx(1.0, 0.0), pk1 = cx(0.0, 0.0);
        for (int i = 0; i < k; i++) {
            pk1 = pk;
            pk = cmul(pk, lam);
        }
        Cx Z = cx(z[0], z[1]), Y = cx(z[2], z[3]), ZY = cadd(Z, cscale(Y, s));
        /* order k: lambda^k (Z + Y s) + k lambda^(k-1) Y; order k + 1: lambda^(k+1) (Z + Y s) + (k + 1) lambda^k Y */
        Cx c0 = cadd(cmul(pk, ZY), cscale(cmul(pk1, Y), (double)k));
        Cx c1 = cadd(cmul(cmul(pk, lam), ZY), cscale(cmul(pk, Y), (double)(k + 1)));
        double ex = exp(sm->lre[t] * s), cs = cos(sm->lim[t] * s), sn = sin(sm->lim[t] * s);
        *d0 += ex * (c0.re * cs - c0.im * sn);
        *d1 += ex * (c1.re * cs - c1.im * sn);
    }
}

/* ------------------------------------------------------------------ the table */

int support_needed(const Model *M) {
    return M->v.supportKind != SUPPORT_GROUND && M->v.kind == KIND_RECORD && M->rec && M->d.sup.nm > 0;
}

/* (M->sup is set only to a table built for M's parameters and record: instance.c) */
int support_moves(const Model *M) { return M->sup != NULL; }

/* What a table is built from: the modes, the record's samples (count and hash), their scale and placement. */
static int table_matches(const Model *M, const SupportTable *T, const SupportModes *sm) {
    return T->data && T->n == M->rec->n && T->recHash == M->rec->hash &&
           T->startTime == M->v.startTime && memcmp(&T->modes, sm, sizeof(SupportModes)) == 0;
}

int support_matches(const Model *M, const SupportTable *T) { return table_matches(M, T, &M->d.sup); }

int support_rest_matches(const Model *M, const SupportTable *T) { return table_matches(M, T, &M->d.supRest); }

void support_free(SupportTable *T, RecordFree release) {
    if (T->data) release(T->data);
    memset(T, 0, sizeof(*T));
}

/* e^(lambda_j L) of every term, for one segment length L: computed at a reference length L0, and for lengths that
 * differ from it by rounding (a record's uniform samples: their differences take a dozen values within 1e-15 of each
 * other) multiplied by e^(lambda_j (L - L0)) from its series to second order, exact to rounding there. */
typedef struct {
    double L, L0;
    Cx e[SUPPORT_MAX_TERMS], e0[SUPPORT_MAX_TERMS];
} Powers;

static void powers_at(const SupportModes *sm, double L, Powers *P) {
    if (P->L == L) return;
    P->L = L;
    double d = L - P->L0;
    if (!(fabs(d) <= 1e-9 * L)) {
        P->L0 = L;
        d = 0.0;
        for (int j = 0; j < sm->nt; j++) {
            double ex = exp(sm->lre[j] * L);
            P->e0[j] = cx(ex * cos(sm->lim[j] * L), ex * sin(sm->lim[j] * L));
        }
    }
    for (int j = 0; j < sm->nt; j++) {
        Cx x = cx(sm->lre[j] * d, sm->lim[j] * d), x2 = cmul(x, x);
        P->e[j] = cmul(P->e0[j], cx(1.0 + x.re + 0.5 * x2.re, x.im + 0.5 * x2.im));
    }
}

/* A mode's displacement and velocity at the end (s = L) of its segment (its polynomial q and terms t .. t + nt - 1,
 * at scale 1): they become the next segment's start. */
static void propagate(const SupportModes *sm, int t, int nt, const double *q, const Cx *Z, const Cx *Y, double L,
                      const Powers *P, double *x, double *v) {
    double xe = poly_derivative(q, 0, L), ve = poly_derivative(q, 1, L);
    for (int j = t; j < t + nt; j++) {
        /* Re((Z + Y L) E) and Re((lambda (Z + Y L) + Y) E) */
        Cx lam = cx(sm->lre[j], sm->lim[j]), ZY = cadd(Z[j], cscale(Y[j], L));
        Cx d0 = cmul(ZY, P->e[j]), d1 = cmul(cadd(cmul(lam, ZY), Y[j]), P->e[j]);
        xe += d0.re;
        ve += d1.re;
    }
    *x = xe;
    *v = ve;
}

/* Where an entry's parts start after its polynomial and terms (support.h's SupportTable): the extrema and peak of
 * the floor's acceleration, then the sum of its terms' magnitudes |lambda^2 Z| + |2 lambda Y| (the rounding scale of
 * the polynomial of u'' that follows it). */
#define KNOWN_AT(nt) (4 + 4 * (nt))
#define TERMS_AT(nt) (KNOWN_AT(nt) + 2 + SUPPORT_EDGES)
/* then acc_bound over the whole segment, with the length it was taken at (the one support_acceleration_bound passes:
 * a resting block's every step asks for it), then the polynomial */
#define BOUND_AT(nt) (TERMS_AT(nt) + 1)
#define ACC_AT(nt) (TERMS_AT(nt) + 3)
/* a first-order table (support_rest_attach): each term's modal coordinate at the segment's start, after the
 * polynomial of degree deg */
#define MODAL_AT(nt, deg) (ACC_AT(nt) + (deg) + 1)
/* known[0] of a segment whose extrema are not searched yet (they are searched when first needed: edges_of) */
#define EDGES_PENDING -2.0

/* The degree of the Taylor polynomials that replace the exponentials of u'' on segments of at most Lmax (rho = the
 * fastest |lambda| times Lmax): the least whose remainder bound rho^(D+1) e^rho / (D+1)! is below 2^-54 of the terms
 * (-1 where none up to SUPPORT_ACC_MAX is). */
static int acc_degree(double rho) {
    if (!(rho >= 0.0 && rho < 4.0)) return -1;
    double rem = exp(rho) * rho; /* rho^(D+1) e^rho / (D+1)! at D = 0 */
    for (int D = 0; D <= SUPPORT_ACC_MAX; D++) {
        if (rem <= 0x1p-54) return D;
        rem *= rho / (D + 2);
    }
    return -1;
}

/* The powers lambda_t^k (k = 0 .. SUPPORT_ACC_MAX + 2) of every term, and 1 / m!, that every segment's polynomial
 * shares (acc_polynomial). */
typedef struct {
    Cx pw[SUPPORT_MAX_TERMS][SUPPORT_ACC_MAX + 3];
    double invFact[SUPPORT_ACC_MAX + 1];
} AccPowers;

static void acc_powers(const SupportModes *sm, int deg, AccPowers *A) {
    for (int t = 0; t < sm->nt; t++) {
        Cx lam = cx(sm->lre[t], sm->lim[t]);
        A->pw[t][0] = cx(1.0, 0.0);
        for (int k = 1; k <= deg + 2; k++) A->pw[t][k] = cmul(A->pw[t][k - 1], lam);
    }
    A->invFact[0] = 1.0;
    for (int m = 1; m <= deg; m++) A->invFact[m] = A->invFact[m - 1] / m;
}

/* u''(s) of entry e as a polynomial of degree deg, written after its extrema: coefficient m is u^(2+m)(0) / m!, each
 * term's Re(lambda^(2+m) Z + (2+m) lambda^(1+m) Y) / m! plus the polynomial's own; and before it, the terms'
 * magnitudes |lambda^2 Z| + |2 lambda Y|. */
static void acc_polynomial(const SupportModes *sm, double *e, int deg, const AccPowers *A) {
    double *c = e + ACC_AT(sm->nt);
    if (deg < 0) return;
    for (int m = 0; m <= deg; m++) c[m] = poly_derivative(e, 2 + m, 0.0);
    const double *z = e + 4;
    for (int t = 0; t < sm->nt; t++, z += 4) {
        const Cx *pw = A->pw[t];
        double L = sm->labs[t], zr = z[0], zi = z[1], yr = z[2], yi = z[3];
        e[TERMS_AT(sm->nt)] += L * (L * sqrt(zr * zr + zi * zi) + 2.0 * sqrt(yr * yr + yi * yi));
        for (int m = 0; m <= deg; m++) c[m] += pw[m + 2].re * zr - pw[m + 2].im * zi;
        if (yr != 0.0 || yi != 0.0)
            for (int m = 0; m <= deg; m++) c[m] += (2.0 + m) * (pw[m + 1].re * yr - pw[m + 1].im * yi);
    }
    for (int m = 0; m <= deg; m++) c[m] *= A->invFact[m];
}

static double table_peak(const Model *M, const SupportTable *T);
static double acc_bound(const SupportTable *T, const double *e, double s);
static void segment_edges(const SupportModes *sm, double *e, double a0, double a1, double L);

double support_peak(const Model *M, SupportTable *T) {
    if (!T->data) return 0.0;
    if (!T->peakKnown) {
        T->peak = table_peak(M, T);
        T->peakKnown = 1;
    }
    return T->peak;
}

/* A first-order term's constants: 1 / lambda, beta / lambda, beta / lambda^2 (its particular solutions), lambda mu
 * (the base's work). */
typedef struct {
    Cx il, b1, b2, lm;
} FirstTerm;

static void first_terms(const SupportModes *sm, FirstTerm *w) {
    for (int t = 0; t < sm->nt; t++) {
        Cx lam = cx(sm->lre[t], sm->lim[t]), beta = cx(sm->bre[t], sm->bim[t]);
        w[t].il = cdiv(cx(1.0, 0.0), lam);
        w[t].b1 = cmul(beta, w[t].il);
        w[t].b2 = cmul(w[t].b1, w[t].il);
        w[t].lm = cmul(lam, cx(sm->mure[t], sm->muim[t]));
    }
}

/* z' = lambda z + beta (a0 + a1 s) has the particular solution p0 + p1 s: p1 = -a1 beta / lambda,
 * p0 = -a0 beta / lambda - a1 beta / lambda^2. */
static void particular(const FirstTerm *c, double a0, double a1, Cx *p0, Cx *p1) {
    *p1 = cscale(c->b1, -a1);
    *p0 = csub(cscale(c->b1, -a0), cscale(c->b2, a1));
}

/* A first-order table's segment for term t (constants c) from its modal coordinate z under a_g = a0 + a1 s: its share
 * of the floor's u (polynomial q, term Z) and z at s = L (E = e^(lambda L)). */
static Cx first_segment(const SupportModes *sm, const FirstTerm *c, int t, Cx z, double a0, double a1, double L, Cx E,
                        double *q, Cx *Z) {
    Cx Yj = cx(sm->yjre[t], sm->yjim[t]), p0, p1;
    particular(c, a0, a1, &p0, &p1);
    q[0] += cmul(Yj, p0).re;
    q[1] += cmul(Yj, p1).re;
    *Z = cmul(Yj, csub(z, p0));
    return cadd(cadd(p0, cscale(p1, L)), cmul(csub(z, p0), E));
}

/* H(x) = (A0 + A1 x) / lambda - A1 / lambda^2: G(x) = e^(lambda x) H(x) has the derivative (A0 + A1 x) e^(lambda x). */
static Cx H_at(const FirstTerm *c, double A0, double A1, double x) {
    return csub(cscale(c->il, A0 + A1 * x), cscale(cmul(c->il, c->il), A1));
}

/* The base's work over [0, s] of record segment i of the first-order table whose entry is e (J, at the record's scale
 * 1 from rest): -int a_g 1^T M' u' with a_g = A0 + A1 s and 1^T M' u' = sum_t Re(lambda_t mu_t z_t), each
 * z_t = p0 + p1 s + (z_t(0) - p0) e^(lambda s) there (p1 = -A1 beta / lambda, p0 = -A0 beta / lambda - A1 beta /
 * lambda^2). Es[t] = e^(lambda_t s). And B_t at s (when B is given): int_(ts + s)^end a_g e^(lambda_t (tau - ts - s))
 * dtau from its value at the segment's end (the next sample's Bn), e^(-lambda s) (G(L) - G(s)) + e^(lambda (L - s)) B_t(L)
 * = e^(lambda (L - s)) (H(L) + B_t(L)) - H(s), each factor at most 1 in size (ELs[t] = e^(lambda_t (L - s)): an
 * overdamped mode's lambda can be large, and e^(-lambda s) would overflow). */
static double segment_work(const SupportTable *T, const double *e, double A0, double A1, double s, const Cx *Es,
                           const FirstTerm *w, double L, const Cx *ELs, const double *Bn, Cx *B) {
    const double *z = e + MODAL_AT(T->nt, T->accDeg);
    double W = 0.0, ps = A0 * s + 0.5 * A1 * s * s, qs = 0.5 * A0 * s * s + A1 * s * s * s / 3.0;
    for (int t = 0; t < T->nt; t++) {
        const FirstTerm *c = &w[t];
        Cx p0, p1;
        particular(c, A0, A1, &p0, &p1);
        /* int (A0 + A1 x)(p0 + p1 x) dx, and (z(0) - p0) int (A0 + A1 x) e^(lambda x) dx = (z(0) - p0) [G(s) - G(0)],
         * G(x) = e^(lambda x) ((A0 + A1 x) / lambda - A1 / lambda^2) */
        Cx Hs = H_at(c, A0, A1, s), G0 = H_at(c, A0, A1, 0.0), Gs = cmul(Es[t], Hs);
        Cx I0 = cadd(cadd(cscale(p0, ps), cscale(p1, qs)), cmul(csub(cx(z[2 * t], z[2 * t + 1]), p0), csub(Gs, G0)));
        W -= cmul(c->lm, I0).re;
        if (B) B[t] = csub(cmul(ELs[t], cadd(H_at(c, A0, A1, L), cx(Bn[2 * t], Bn[2 * t + 1]))), Hs);
    }
    return W;
}

/* The table of the modes sm under M's record (support_attach, support_rest_attach). */
static int build_table(const Model *M, const SupportModes *sm, SupportTable *T, RecordAlloc alloc, char *msg, size_t n) {
    const Record *r = M->rec;
    double Lmax = 0.0;
    for (int i = 0; i + 1 < r->n; i++) Lmax = fmax(Lmax, r->t[i + 1] - r->t[i]);
    int deg = acc_degree(sm->fastest * Lmax);
    /* a first-order table keeps at each sample its modal coordinates, the base's work since the record's start and
     * each term's B (segment_work) */
    int stride = MODAL_AT(sm->nt, deg) + (sm->first ? 4 * sm->nt + 1 : 0);
    T->data = (double *)alloc((size_t)r->n * (size_t)stride, sizeof(double));
    if (!T->data) FAIL("out of memory for the support's table (%d samples x %d values)", r->n, stride);
    T->n = r->n;
    T->nt = sm->nt;
    T->stride = stride;
    T->accDeg = deg;
    T->recHash = r->hash;
    T->startTime = M->v.startTime;
    T->modes = *sm;
    /* every mode starts at rest at the first sample and is carried exactly from sample to sample; entry
     * n - 1 is the free vibration after the last one (a_g = 0). The table is the record's at scale 1: the
     * support is linear and starts at rest, so the motion under excitation.scale is the table's times it
     * (a sweep over scales builds it once). */
    double x[SUPPORT_MAX_STOREYS] = {0}, v[SUPPORT_MAX_STOREYS] = {0};
    Cx zf[SUPPORT_MAX_TERMS];
    for (int t = 0; t < sm->nt; t++) zf[t] = cx(0.0, 0.0);
    FirstTerm W[SUPPORT_MAX_TERMS];
    if (sm->first) first_terms(sm, W);
    double work = 0.0;
    Powers P;
    P.L = P.L0 = NAN;
    AccPowers A;
    acc_powers(sm, deg, &A);
    for (int i = 0; i < r->n; i++) {
        int last = i == r->n - 1;
        double L = last ? 0.0 : r->t[i + 1] - r->t[i];
        double a0 = last ? 0.0 : r->ah[i], a1 = last ? 0.0 : (r->ah[i + 1] - r->ah[i]) / L;
        double *e = T->data + (size_t)i * stride;
        if (!last) powers_at(sm, L, &P);
        if (sm->first) {
            double *z = e + MODAL_AT(sm->nt, deg);
            z[2 * sm->nt] = work;
            for (int t = 0; t < sm->nt; t++) {
                Cx Z;
                z[2 * t] = zf[t].re;
                z[2 * t + 1] = zf[t].im;
                Cx end = first_segment(sm, &W[t], t, zf[t], a0, a1, L, last ? cx(1.0, 0.0) : P.e[t], e, &Z);
                e[4 + 4 * t] = Z.re;
                e[4 + 4 * t + 1] = Z.im;
                if (!last) zf[t] = end;
            }
            if (!last) work += segment_work(T, e, a0, a1, L, P.e, W, L, NULL, NULL, NULL);
        }
        for (int m = 0, t = 0; m < sm->nm && !sm->first; m++) {
            /* the mode's own segment, its share c_m of the floor's into the entry, and its state at the end */
            double q[4] = {0};
            Cx Z[SUPPORT_MAX_TERMS], Y[SUPPORT_MAX_TERMS];
            int nt = mode_segment(sm, m, t, x[m], v[m], a0, a1, q, Z, Y);
            for (int k = 0; k < 4; k++) e[k] += sm->c[m] * q[k];
            for (int j = t; j < t + nt; j++) {
                double *z = e + 4 + 4 * j;
                z[0] = sm->c[m] * Z[j].re;
                z[1] = sm->c[m] * Z[j].im;
                z[2] = sm->c[m] * Y[j].re;
                z[3] = sm->c[m] * Y[j].im;
            }
            if (!last) propagate(sm, t, nt, q, Z, Y, L, &P, &x[m], &v[m]);
            t += nt;
        }
        if (!last) {
            e[KNOWN_AT(sm->nt)] = EDGES_PENDING;
            acc_polynomial(sm, e, deg, &A);
            double whole = (T->startTime + r->t[i + 1]) - (T->startTime + r->t[i]); /* (as record times subtract) */
            e[BOUND_AT(sm->nt)] = NAN;
            if (deg >= 0) e[BOUND_AT(sm->nt) + 1] = acc_bound(T, e, whole), e[BOUND_AT(sm->nt)] = whole;
        }
    }
    /* a first-order table's B_t (segment_work) from the record's end (0: the base is still after it) backwards */
    Cx one[SUPPORT_MAX_TERMS];
    for (int t = 0; t < sm->nt; t++) one[t] = cx(1.0, 0.0);
    for (int i = r->n - 2; i >= 0 && sm->first; i--) {
        double L = r->t[i + 1] - r->t[i], a0 = r->ah[i], a1 = (r->ah[i + 1] - a0) / L;
        double *b = T->data + (size_t)i * stride + MODAL_AT(sm->nt, deg) + 2 * sm->nt + 1;
        const double *bn = b + stride;
        Cx B[SUPPORT_MAX_TERMS];
        powers_at(sm, L, &P);
        segment_work(T, T->data + (size_t)i * stride, a0, a1, 0.0, one, W, L, P.e, bn, B);
        for (int t = 0; t < sm->nt; t++) {
            b[2 * t] = B[t].re;
            b[2 * t + 1] = B[t].im;
        }
    }
    T->peak = 0.0;
    T->peakKnown = 0;
    return 0;
}

/* T built for the modes sm under M's record where it is needed (kept where it already was), else emptied. */
static int attach(const Model *M, int needed, const SupportModes *sm, SupportTable *T, RecordAlloc alloc,
                  RecordFree release, char *msg, size_t n) {
    if (needed && table_matches(M, T, sm)) return 0;
    support_free(T, release);
    return needed ? build_table(M, sm, T, alloc, msg, n) : 0;
}

int support_attach(const Model *M, SupportTable *T, RecordAlloc alloc, RecordFree release, char *msg, size_t n) {
    return attach(M, support_needed(M), &M->d.sup, T, alloc, release, msg, n);
}

int support_rest_needed(const Model *M) { return M->d.supRest.first && M->v.kind == KIND_RECORD && M->rec; }

int support_rest_attach(const Model *M, SupportTable *T, RecordAlloc alloc, RecordFree release, char *msg, size_t n) {
    return attach(M, support_rest_needed(M), &M->d.supRest, T, alloc, release, msg, n);
}

/* ------------------------------------------------------------------ evaluation */

static double record_time(const Model *M, int i) { return M->v.startTime + M->rec->t[i]; }

/* The entry of piece (NULL before the record: the support rests) and its start time, in M->sup. */
static const double *entry_of(const Model *M, int piece, double *t0) {
    if (!support_moves(M) || piece < 1 || piece > M->rec->n) return NULL;
    *t0 = record_time(M, piece - 1);
    return M->sup->data + (size_t)(piece - 1) * M->sup->stride;
}

/* Blocks at rest on a two-way support in closed form (support.h's SupportRest): M->sup is then the table of the
 * support with them, whose u times the record's scale is joined by the free vibration sum_t Re(F_t e^(lambda_t
 * (t - t0))), F_t = Y_tj d_t. */
static int resting(const Model *M) { return M->s.rest.on; }

static Cx free_amplitude_of(const SupportModes *sm, const SupportRest *R, int t) {
    return cmul(cx(sm->yjre[t], sm->yjim[t]), cx(R->dre[t], R->dim[t]));
}

static Cx free_amplitude(const Model *M, int t) { return free_amplitude_of(&M->sup->modes, &M->s.rest, t); }

/* The free vibration's k-th derivative at t. */
static double free_derivative(const Model *M, int k, double t) {
    const SupportModes *sm = &M->sup->modes;
    double sum = 0.0, s = t - M->s.rest.t0;
    for (int j = 0; j < sm->nt; j++) {
        Cx lam = cx(sm->lre[j], sm->lim[j]), c = cmul(free_amplitude(M, j), cexpi(sm->lre[j] * s, sm->lim[j] * s));
        for (int i = 0; i < k; i++) c = cmul(c, lam);
        sum += c.re;
    }
    return sum;
}

/* A bound on |its second derivative| at and after t: its terms decay at least as the slowest (Re lambda <= 0), and
 * e^(-x) <= 1 / (1 + x + x^2/2 + x^3/6 + x^4/24) for x >= 0 (e^x exceeds its series): no exponential per call. */
static double free_bound(const Model *M, double t) {
    const SupportRest *R = &M->s.rest;
    double x = R->decay * fmax(t - R->t0, 0.0);
    return R->accBound / (1.0 + x * (1.0 + x * (0.5 + x * (1.0 / 6.0 + x / 24.0))));
}

/* Piece's entry as one entry of scale 1 (into buf): the table's at the record's scale, and at rest in closed form
 * the free vibration's terms moved to the piece's start; with no known extrema (searched each time). */
static const double *entry_scaled(const Model *M, int piece, double *t0, double *buf, double *amp) {
    const double *e = entry_of(M, piece, t0);
    *amp = M->d.accAmp;
    if (!e || !resting(M)) return e;
    const SupportModes *sm = &M->sup->modes;
    int nt = sm->nt;
    for (int k = 0; k < KNOWN_AT(nt); k++) buf[k] = M->d.accAmp * e[k];
    /* the entry's origin moved to the rest's start where the piece began before it (the free vibration's terms
     * there are e^(lambda (t - t0)), whose value at an earlier origin can overflow): the cubic re-expanded, the
     * table's terms times e^(lambda delta) */
    double delta = M->s.rest.t0 - *t0;
    if (delta > 0.0) {
        double *q = buf, d2 = delta * delta;
        q[0] += delta * q[1] + d2 * q[2] + d2 * delta * q[3];
        q[1] += 2.0 * delta * q[2] + 3.0 * d2 * q[3];
        q[2] += 3.0 * delta * q[3];
        for (int j = 0; j < nt; j++) {
            Cx E = cexpi(sm->lre[j] * delta, sm->lim[j] * delta), Z = cmul(cx(buf[4 + 4 * j], buf[4 + 4 * j + 1]), E);
            Cx Y = cmul(cx(buf[4 + 4 * j + 2], buf[4 + 4 * j + 3]), E);
            Z = cadd(Z, cscale(Y, delta)); /* (Z + Y (s + delta)) e^(lambda (s + delta)) */
            buf[4 + 4 * j] = Z.re;
            buf[4 + 4 * j + 1] = Z.im;
            buf[4 + 4 * j + 2] = Y.re;
            buf[4 + 4 * j + 3] = Y.im;
        }
        *t0 = M->s.rest.t0;
    }
    double s = *t0 - M->s.rest.t0;
    for (int j = 0; j < nt; j++) {
        Cx F = cmul(free_amplitude(M, j), cexpi(sm->lre[j] * s, sm->lim[j] * s));
        buf[4 + 4 * j] += F.re;
        buf[4 + 4 * j + 1] += F.im;
    }
    buf[KNOWN_AT(nt)] = -1.0;
    buf[KNOWN_AT(nt) + 1 + SUPPORT_EDGES] = -1.0;
    *amp = 1.0;
    return buf;
}

#define ENTRY_BUF (KNOWN_AT(SUPPORT_MAX_TERMS) + 2 + SUPPORT_EDGES)

/* Record segment i's extrema and peak of the floor's acceleration (segment_edges), searched when first needed and
 * kept in T: they depend on the entry alone, so when they are searched changes nothing. */
static const double *edges_of(const Model *M, const SupportTable *T, int i) {
    double *e = T->data + (size_t)i * T->stride;
    if (e[KNOWN_AT(T->nt)] == EDGES_PENDING) {
        const Record *r = M->rec;
        double L = r->t[i + 1] - r->t[i], a0 = r->ah[i], a1 = (r->ah[i + 1] - a0) / L;
        segment_edges(&T->modes, e, a0, a1, L);
    }
    return e + KNOWN_AT(T->nt);
}

/* u''(s) of a record segment's entry e from its polynomial (T->accDeg >= 0), and a bound on |u''| over [0, s]: the sum
 * of |c_m| s^m and the polynomial's distance to u'' (2^-54 of the terms' magnitudes, times 4). */
static double acc_poly(const SupportTable *T, const double *e, double s) {
    const double *c = e + ACC_AT(T->nt);
    double sum = c[T->accDeg];
    for (int m = T->accDeg - 1; m >= 0; m--) sum = sum * s + c[m];
    return sum;
}

static double acc_bound(const SupportTable *T, const double *e, double s) {
    if (s == e[BOUND_AT(T->nt)]) return e[BOUND_AT(T->nt) + 1];
    const double *c = e + ACC_AT(T->nt);
    double b = fabs(c[T->accDeg]);
    for (int m = T->accDeg - 1; m >= 0; m--) b = b * s + fabs(c[m]);
    return b + 0x1p-52 * e[TERMS_AT(T->nt)];
}

double support_relative_acceleration(const Model *M, double t, int piece) {
    double t0;
    const double *e = entry_of(M, piece, &t0);
    if (!e) return 0.0;
    double a = M->sup->accDeg < 0 || piece >= M->rec->n ? entry_derivative(&M->sup->modes, e, 2, t - t0)
                                                        : acc_poly(M->sup, e, t - t0);
    return M->d.accAmp * a + (resting(M) ? free_derivative(M, 2, t) : 0.0);
}

void support_motion(const Model *M, double t, int piece, double *u, double *v) {
    double t0;
    const double *e = entry_of(M, piece, &t0);
    *u = e ? M->d.accAmp * entry_derivative(&M->sup->modes, e, 0, t - t0) : 0.0;
    *v = e ? M->d.accAmp * entry_derivative(&M->sup->modes, e, 1, t - t0) : 0.0;
    if (e && resting(M)) {
        *u += free_derivative(M, 0, t);
        *v += free_derivative(M, 1, t);
    }
}

double support_acceleration_bound(const Model *M, int piece, double t0, double t1) {
    double te;
    const double *e = entry_of(M, piece, &te);
    if (!e) return 0.0;
    double b = M->sup->accDeg < 0 || piece >= M->rec->n ? entry_bound(&M->sup->modes, e, 2, t0 - te, t1 - te)
                                                        : acc_bound(M->sup, e, t1 - te);
    return fabs(M->d.accAmp) * b + (resting(M) ? free_bound(M, t0) : 0.0);
}

void support_series(const Model *M, double t, int piece, int nc, double *c) {
    double t0, buf[ENTRY_BUF], amp;
    const double *e = entry_scaled(M, piece, &t0, buf, &amp);
    if (!e) return;
    double f = 1.0;
    for (int k = 0; k <= nc; k++) {
        c[k] += amp * entry_derivative(&M->sup->modes, e, k + 2, t - t0) / f;
        f *= k + 1;
    }
}

/* ------------------------------------------------------------------ cells */

/* The floor's absolute acceleration's slope on entry e: aBase1 + u'''(s); its extrema are its roots. */
typedef struct {
    const SupportModes *sm;
    const double *e;
    double a1, scale; /* the base's slope (m/s3) and the record's scale (the table's at scale 1) */
} Slope;

static double slope_at(const Slope *S, double s) { return S->a1 + S->scale * entry_derivative(S->sm, S->e, 3, s); }

/* The root of the slope in [lo, hi], where it is monotone and changes sign: bisection. */
static double slope_root(const Slope *S, double lo, double hi) {
    double flo = slope_at(S, lo);
    for (int it = 0; it < 200; it++) {
        double mid = 0.5 * (lo + hi);
        if (!(mid > lo && mid < hi)) break;
        double fm = slope_at(S, mid);
        if ((fm > 0) == (flo > 0)) {
            lo = mid;
            flo = fm;
        } else {
            hi = mid;
        }
    }
    return 0.5 * (lo + hi);
}

/* Search the dyadic interval [s0, s1] of a cell for the slope's roots: the first one above x (forward) or
 * the last one at or below x (backward), written to *root; returns 1 if found. Each dyadic interval is
 * judged by itself alone, so a root found does not depend on x (results do not depend on the
 * communication points). */
static int search(const Slope *S, double s0, double s1, double x, int forward, int depth, double *root) {
    if (forward ? s1 <= x : s0 > x) return 0;
    double c = 0.5 * (s0 + s1), rad = 0.5 * (s1 - s0), f, d, b4 = fabs(S->scale) * entry_bound(S->sm, S->e, 4, s0, s1);
    entry_derivative2(S->sm, S->e, 3, c, &f, &d);
    f = S->a1 + S->scale * f;
    d *= S->scale;
    if (b4 == 0.0 || fabs(f) > b4 * rad) return 0; /* no root (or a constant slope: no extremum) */
    double b5 = fabs(S->scale) * entry_bound(S->sm, S->e, 5, s0, s1);
    int monotone = fabs(d) > b5 * rad;
    if (!monotone) {
        /* the same tests to second order about c, which the bounds alone fail near a multiple root (an undamped
         * support starting from rest has a double one: its slope's bounds sum modes that cancel there) */
        if (fabs(f) > (fabs(d) + b5 * rad) * rad) return 0;
        double d2 = S->scale * entry_derivative(S->sm, S->e, 5, c), b6 = fabs(S->scale) * entry_bound(S->sm, S->e, 6, s0, s1);
        monotone = fabs(d) > (fabs(d2) + b6 * rad) * rad;
    }
    if (monotone) { /* one root at most */
        double f0 = slope_at(S, s0), f1 = slope_at(S, s1);
        double r;
        if (f0 == 0.0) r = s0;
        else if (f1 == 0.0) r = s1;
        else if ((f0 > 0) == (f1 > 0)) return 0;
        else r = slope_root(S, s0, s1);
        if (forward ? r > x : r <= x) {
            *root = r;
            return 1;
        }
        return 0;
    }
    if (depth >= SUPPORT_MAX_DEPTH) return 0; /* a double root: an inflexion, not an extremum */
    if (forward) return search(S, s0, c, x, 1, depth + 1, root) || search(S, c, s1, x, 1, depth + 1, root);
    return search(S, c, s1, x, 0, depth + 1, root) || search(S, s0, c, x, 0, depth + 1, root);
}

void support_free_cell(const Model *M, double a, double tEnd, double *t0, double *t1) {
    double L = SUPPORT_FREE_CELL * 2.0 * M_PI / M->sup->modes.fastest, k = floor((a - tEnd) / L);
    if (k < 0) k = 0;
    if (tEnd + (k + 1.0) * L <= a) k += 1.0;
    *t0 = tEnd + k * L;
    *t1 = tEnd + (k + 1.0) * L;
}

static int cell_search(const Model *M, double a, int piece, double t0, double t1, double aBase1, int forward,
                       double *edge) {
    double te, buf[ENTRY_BUF], amp;
    const double *e = entry_scaled(M, piece, &te, buf, &amp);
    if (!e || !(M->sup->modes.fastest > 0)) return 0;
    const double *known = piece < M->rec->n && !resting(M) ? edges_of(M, M->sup, piece - 1) : NULL;
    if (known && known[0] >= 0) { /* a record segment: its edges, found once (edges_of) */
        int n = (int)known[0];
        double x = a - te;
        for (int i = forward ? 0 : n - 1; forward ? i < n : i >= 0; i += forward ? 1 : -1)
            if (forward ? known[1 + i] > x : known[1 + i] <= x) {
                *edge = te + known[1 + i];
                return 1;
            }
        return 0;
    }
    Slope S = {&M->sup->modes, e, aBase1, amp};
    double r;
    if (!search(&S, t0 - te, t1 - te, a - te, forward, 0, &r)) return 0;
    *edge = te + r;
    return 1;
}

double support_next_edge(const Model *M, double a, int piece, double t0, double t1, double aBase1) {
    double edge;
    if (cell_search(M, a, piece, t0, t1, aBase1, 1, &edge) && edge > a && edge < t1) return edge;
    return t1;
}

double support_cell_start(const Model *M, double a, int piece, double t0, double t1, double aBase1) {
    double edge;
    if (cell_search(M, a, piece, t0, t1, aBase1, 0, &edge) && edge <= a && edge > t0) return edge;
    return t0;
}

/* ------------------------------------------------------------------ peak floor acceleration */

/* Samples per period of the support's fastest mode at which the peak floor acceleration is sought (each sampled
 * maximum then refined by Newton's method on the slope); runners.engine.floor_motion samples the same way. */
#define SUPPORT_PEAK_GRID 64

/* |a_f| = |a_g + u''| on entry e at s (a_g = a0 + a1 s, at scale 1). */
static double floor_abs(const SupportModes *sm, const double *e, double a0, double a1, double s) {
    return fabs(a0 + a1 * s + entry_derivative(sm, e, 2, s));
}

/* The largest |a_f| on entry e over [0, L]: sampled at n + 1 points, each sampled local maximum refined by Newton's
 * method on its slope a1 + u''' (its derivative u'''') inside the samples around it; a value is kept only where it
 * is evaluated, so the result is exact at the peak found. */
static double entry_peak(const SupportModes *sm, const double *e, double a0, double a1, double L, int n) {
    double best = 0.0, prev = -1.0, cur = floor_abs(sm, e, a0, a1, 0.0);
    for (int i = 0; i <= n; i++) {
        double next = i < n ? floor_abs(sm, e, a0, a1, L * (i + 1) / n) : -1.0;
        best = fmax(best, cur);
        if (cur >= prev && cur >= next && cur > 0.0) { /* a sampled local maximum: refine */
            double lo = L * (i > 0 ? i - 1 : 0) / n, hi = L * (i < n ? i + 1 : n) / n, x = L * i / n;
            for (int it = 0; it < 20; it++) {
                double f = a1 + entry_derivative(sm, e, 3, x), d = entry_derivative(sm, e, 4, x);
                if (d == 0.0) break;
                double xn = x - f / d;
                if (!(xn >= lo && xn <= hi)) break;
                int done = fabs(xn - x) <= 8.0 * DBL_EPSILON * fmax(fabs(x), L);
                x = xn;
                best = fmax(best, floor_abs(sm, e, a0, a1, x));
                if (done) break;
            }
        }
        prev = cur;
        cur = next;
    }
    return best;
}

/* The bare support's peak floor acceleration under M's record at scale 1 (m/s^2): on every record segment at its
 * ends and at the extrema of a_f the table keeps (segment_edges; where it keeps none, more than SUPPORT_EDGES,
 * sampled and refined as below); then the free vibration (a_g = 0) for SUPPORT_TAIL_PERIODS of its slowest mode (at
 * most SUPPORT_TAIL_MAX s), sampled at SUPPORT_PEAK_GRID points per period of its fastest mode and refined
 * (entry_peak). */
static double table_peak(const Model *M, const SupportTable *T) {
    const SupportModes *sm = &T->modes;
    const Record *r = M->rec;
    double slowest = INFINITY;
    for (int m = 0; m < sm->nm; m++)
        if (sm->freq[m] > 0) slowest = fmin(slowest, sm->freq[m]);
    double tail = fmin(SUPPORT_TAIL_PERIODS / slowest, SUPPORT_TAIL_MAX);
    double dt = sm->fastest > 0 ? 2.0 * M_PI / sm->fastest / SUPPORT_PEAK_GRID : tail;
    double best = 0.0, under = 0.0;
    if (T->accDeg >= 0) /* a value under the peak: the largest |a_f| at the segments' starts, from their polynomials */
        for (int i = 0; i + 1 < r->n; i++) {
            const double *e = T->data + (size_t)i * T->stride;
            under = fmax(under, fabs(r->ah[i] + acc_poly(T, e, 0.0)));
        }
    for (int i = 0; i + 1 < r->n; i++) {
        double L = r->t[i + 1] - r->t[i], a0 = r->ah[i], a1 = (r->ah[i + 1] - a0) / L;
        const double *e = T->data + (size_t)i * T->stride;
        /* a segment whose bound is below that does not hold the peak: its extrema are not searched */
        if (T->accDeg >= 0 && fmax(fabs(r->ah[i]), fabs(r->ah[i + 1])) + acc_bound(T, e, L) < under) continue;
        const double *known = edges_of(M, T, i);
        if (known[0] >= 0) { /* the segment's peak at its ends and extrema (segment_edges): exact */
            best = fmax(best, known[1 + SUPPORT_EDGES]);
            continue;
        }
        int n = (int)fmin(ceil(L / dt), 1e6);
        best = fmax(best, entry_peak(sm, e, a0, a1, L, n < 1 ? 1 : n));
    }
    int n = (int)fmin(ceil(tail / dt), 1e7);
    return fmax(best, entry_peak(sm, T->data + (size_t)(r->n - 1) * T->stride, 0.0, 0.0, tail, n < 1 ? 1 : n));
}

/* The floor acceleration's extrema on a record segment's entry e (length L, the base's a0 + a1 s at scale 1), found
 * once, when first needed (edges_of), and kept after its terms: their count, then each s in (0, L) ascending (-1: more than
 * SUPPORT_EDGES, searched for each time), then the segment's peak |a_f| (its ends' and extrema's; -1 where the
 * extrema are not kept). They do not depend on the record's scale (the floor's acceleration is the table's times
 * it), so a sweep over scales searches each segment once. The search is the cells' own (search): each dyadic
 * interval judged alone. */
static void segment_edges(const SupportModes *sm, double *e, double a0, double a1, double L) {
    double *known = e + KNOWN_AT(sm->nt), x = 0.0, r;
    Slope S = {sm, e, a1, 1.0};
    int n = 0;
    known[0] = 0.0;
    known[1 + SUPPORT_EDGES] = fmax(floor_abs(sm, e, a0, a1, 0.0), floor_abs(sm, e, a0, a1, L));
    if (!(sm->fastest > 0)) return;
    while (search(&S, 0.0, L, x, 1, 0, &r) && r > x && r < L) {
        if (n == SUPPORT_EDGES) {
            known[0] = -1.0;
            known[1 + SUPPORT_EDGES] = -1.0;
            return;
        }
        known[1 + n++] = r;
        known[1 + SUPPORT_EDGES] = fmax(known[1 + SUPPORT_EDGES], floor_abs(sm, e, a0, a1, r));
        x = r;
    }
    known[0] = n;
}

double support_segment_peak(const Model *M, int piece) {
    double te;
    const double *e = entry_of(M, piece, &te);
    if (!e || piece >= M->rec->n) return -1.0;
    double peak = edges_of(M, M->sup, piece - 1)[1 + SUPPORT_EDGES];
    if (!(peak >= 0)) return -1.0;
    /* at rest in closed form a bound: the table's exact peak at the record's scale and the free vibration's bound */
    return fabs(M->d.accAmp) * peak + (resting(M) ? free_bound(M, te) : 0.0);
}

/* ------------------------------------------------------------------ blocks at rest, two-way */

/* The record's sample at or before t (the entry holding t: n - 1 after the last sample), t at or after the first. */
static int sample_at(const Model *M, double t) {
    const Record *r = M->rec;
    int lo = 0, hi = r->n - 1;
    if (t >= record_time(M, hi)) return hi;
    while (hi - lo > 1) {
        int mid = lo + (hi - lo) / 2;
        if (record_time(M, mid) <= t) lo = mid;
        else hi = mid;
    }
    return lo;
}

/* Every term's modal coordinate z of the rest table at time t times the record's scale, plus (free) the free
 * vibration from the rest's start: from their values at the sample at or before t. */
static void rest_modals(const Model *M, double t, int free, Cx *z) {
    const Record *r = M->rec;
    const SupportTable *T = M->restTable;
    const SupportModes *sm = &T->modes;
    int i = sample_at(M, t);
    const double *e = T->data + (size_t)i * T->stride + MODAL_AT(T->nt, T->accDeg);
    double L = t - record_time(M, i), a0 = 0.0, a1 = 0.0, q[4] = {0}, s = t - M->s.rest.t0;
    if (i < r->n - 1) {
        a0 = r->ah[i];
        a1 = (r->ah[i + 1] - a0) / (r->t[i + 1] - r->t[i]);
    }
    FirstTerm c[SUPPORT_MAX_TERMS];
    first_terms(sm, c);
    for (int k = 0; k < sm->nt; k++) {
        Cx Z, E = cexpi(sm->lre[k] * L, sm->lim[k] * L);
        z[k] = cscale(first_segment(sm, &c[k], k, cx(e[2 * k], e[2 * k + 1]), a0, a1, L, E, q, &Z), M->d.accAmp);
        if (free)
            z[k] = cadd(z[k], cmul(cx(M->s.rest.dre[k], M->s.rest.dim[k]), cexpi(sm->lre[k] * s, sm->lim[k] * s)));
    }
}

static double work_at(const Model *M, double t, Cx *B, FirstTerm *w);

int support_rest_start(Model *M, double t, const double *z) {
    const SupportTable *T = M->restTable;
    if (!T || !T->data || !M->rec || t < M->d.excStart) return 1;
    const SupportModes *sm = &T->modes;
    SupportRest *R = &M->s.rest;
    memset(R, 0, sizeof(*R));
    double zre[SUPPORT_MAX_TERMS], zim[SUPPORT_MAX_TERMS];
    Cx zt[SUPPORT_MAX_TERMS], B[SUPPORT_MAX_TERMS];
    support_rest_coordinates(sm, &M->d.restShapes, z, zre, zim);
    rest_modals(M, t, 0, zt);
    for (int k = 0; k < sm->nt; k++) {
        R->dre[k] = zre[k] - zt[k].re;
        R->dim[k] = zim[k] - zt[k].im;
    }
    R->workA0 = work_at(M, t, B, NULL);
    for (int k = 0; k < sm->nt; k++) {
        R->b0re[k] = B[k].re;
        R->b0im[k] = B[k].im;
    }
    R->t0 = t;
    R->on = 1;
    R->decay = INFINITY;
    for (int k = 0; k < sm->nt; k++) {
        Cx F = free_amplitude_of(sm, R, k);
        R->accBound += hypot(F.re, F.im) * sm->labs[k] * sm->labs[k];
        R->decay = fmin(R->decay, -sm->lre[k]);
    }
    if (!(R->decay >= 0.0)) R->decay = 0.0;
    M->sup = T;
    return 0;
}

void support_rest_floors(const Model *M, double t, double *z) {
    const SupportModes *sm = &M->restTable->modes;
    Cx zt[SUPPORT_MAX_TERMS];
    rest_modals(M, t, 1, zt);
    for (int i = 0; i < sm->ns; i++) z[2 * i] = z[2 * i + 1] = 0.0;
    for (int k = 0; k < sm->nt; k++) {
        Cx lam = cx(sm->lre[k], sm->lim[k]);
        for (int i = 0; i < sm->ns; i++) {
            Cx Yc = cmul(cx(M->d.restShapes.Yre[k][i], M->d.restShapes.Yim[k][i]), zt[k]);
            z[2 * i] += Yc.re;
            z[2 * i + 1] += cmul(lam, Yc).re;
        }
    }
}

/* The base's work since the record's start at scale 1 from rest (the table's) and each term's B at t; w (when given):
 * the terms' constants, written. */
static double work_at(const Model *M, double t, Cx *B, FirstTerm *w) {
    const Record *r = M->rec;
    const SupportTable *T = M->restTable;
    const SupportModes *sm = &T->modes;
    int i = sample_at(M, t);
    const double *e = T->data + (size_t)i * T->stride;
    double s = t - record_time(M, i), A0 = 0.0, A1 = 0.0;
    if (i < r->n - 1) {
        A0 = r->ah[i];
        A1 = (r->ah[i + 1] - A0) / (r->t[i + 1] - r->t[i]);
    }
    Cx Es[SUPPORT_MAX_TERMS], ELs[SUPPORT_MAX_TERMS];
    FirstTerm own[SUPPORT_MAX_TERMS];
    if (!w) w = own;
    first_terms(sm, w);
    double L = i < r->n - 1 ? r->t[i + 1] - r->t[i] : s; /* (after the record: B = 0, the base still) */
    for (int k = 0; k < sm->nt; k++) {
        Es[k] = cexpi(sm->lre[k] * s, sm->lim[k] * s);
        ELs[k] = cexpi(sm->lre[k] * (L - s), sm->lim[k] * (L - s));
    }
    static const double zero[2 * SUPPORT_MAX_TERMS];
    const double *bn = i < r->n - 1 ? e + T->stride + MODAL_AT(T->nt, T->accDeg) + 2 * T->nt + 1 : zero;
    return e[MODAL_AT(T->nt, T->accDeg) + 2 * T->nt] + segment_work(T, e, A0, A1, s, Es, w, L, ELs, bn, B);
}

/* W(t0, t) = k^2 (W_A(t) - W_A(t0)) - k sum_t Re(lambda_t mu_t d_t X_t) for the record's scale k, the free vibration
 * d_t e^(lambda_t (tau - t0)) adding -k int a_g Re(lambda mu d e^(lambda (tau - t0))) dtau with
 * X_t = int_t0^t a_g e^(lambda_t (tau - t0)) dtau = B_t(t0) - e^(lambda_t (t - t0)) B_t(t): each term's weight decays
 * forward in time, so B (the integral to the record's end) is the sum that stays bounded. */
double support_rest_work(const Model *M, double t) {
    const SupportRest *R = &M->s.rest;
    const SupportModes *sm = &M->restTable->modes;
    Cx B[SUPPORT_MAX_TERMS];
    FirstTerm c[SUPPORT_MAX_TERMS];
    double k = M->d.accAmp, W = k * k * (work_at(M, t, B, c) - R->workA0), s = t - R->t0;
    for (int j = 0; j < sm->nt; j++) {
        Cx X = csub(cx(R->b0re[j], R->b0im[j]), cmul(cexpi(sm->lre[j] * s, sm->lim[j] * s), B[j]));
        W -= k * cmul(c[j].lm, cmul(cx(R->dre[j], R->dim[j]), X)).re;
    }
    return W;
}
