/* The support with the blocks at rest on it, coupled two ways: its first-order modes (support.h's
 * support_rest_modes; docs/supports.md).
 *
 * With every block flat and sticking on floor j the blocks move with the floor, and the support with them is
 * linear: M' u'' + C u' + K u = -M' 1 a_g, M' = M + mb e_j e_j^T, C = a0 M + a1 K (the bare support's damping,
 * which is not proportional to M'). Its eigenvalues are the roots of det(lambda^2 M' + lambda C + K), a real
 * polynomial of degree 2n, built by the three-term recurrence of a tridiagonal determinant and solved by the
 * Aberth-Ehrlich iteration; each root is then refined with its eigenvector by inverse iteration and the
 * symmetric Rayleigh functional (the root of y^T Q(lambda) y = 0 nearest it, Q = lambda^2 M' + lambda C + K).
 * M', C and K are symmetric, so the state (u, u') expands in the eigenvectors (y, lambda y), orthogonal under
 * B = [[C, M'], [M', 0]]: z = (y^T (lambda M' + C) u + y^T M' u') / N with N = y^T (2 lambda M' + C) y, and
 * the base's acceleration drives z' = lambda z + beta a_g with beta = -y^T M' 1 / N (Tisseur & Meerbergen 2001,
 * section 3). Units SI. */
#include "support.h"

#include <complex.h>
#include <float.h>
#include <math.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif
#define NS SUPPORT_MAX_STOREYS
#define DEG (2 * SUPPORT_MAX_STOREYS)

typedef double complex cplx;

/* The support's matrices with the blocks on floor j: M' (diagonal), C and K (tridiagonal: diagonal d, the
 * entry (i, i + 1) o), divided by kap (K's largest diagonal) and with time in units of 1 / w0. */
typedef struct {
    int n;
    double m[NS], cd[NS], co[NS], kd[NS], ko[NS];
    double w0, kap;
} Scaled;

static int scaled(const SupportModes *sm, double mb, Scaled *S) {
    int n = sm->ns;
    double kd[NS], ko[NS], mp[NS], kmax = 0.0, mmax = 0.0;
    for (int i = 0; i < n; i++) {
        mp[i] = sm->mass[i] + (i == sm->j ? mb : 0.0);
        kd[i] = sm->stiff[i] + (i + 1 < n ? sm->stiff[i + 1] : 0.0);
        ko[i] = i + 1 < n ? -sm->stiff[i + 1] : 0.0;
        kmax = fmax(kmax, kd[i]);
        mmax = fmax(mmax, mp[i]);
    }
    if (!(kmax > 0.0) || !(mmax > 0.0) || !isfinite(kmax)) return 1; /* a support without a spring */
    S->n = n;
    S->kap = kmax;
    S->w0 = sqrt(kmax / mmax);
    for (int i = 0; i < n; i++) {
        S->m[i] = mp[i] * S->w0 * S->w0 / kmax;
        S->kd[i] = kd[i] / kmax;
        S->ko[i] = ko[i] / kmax;
        S->cd[i] = (sm->a0 * sm->mass[i] + sm->a1 * kd[i]) * S->w0 / kmax;
        S->co[i] = sm->a1 * ko[i] * S->w0 / kmax;
    }
    return 0;
}

/* p <- p * (c0 + c1 x + c2 x^2), p of degree d (returns d + 2, or d + 1 when c2 = 0). */
static int poly_mul2(double *p, int d, double c0, double c1, double c2) {
    double r[DEG + 3] = {0};
    for (int i = 0; i <= d; i++) {
        r[i] += p[i] * c0;
        r[i + 1] += p[i] * c1;
        r[i + 2] += p[i] * c2;
    }
    int e = c2 != 0.0 ? d + 2 : d + 1;
    memcpy(p, r, sizeof(double) * (size_t)(e + 1));
    return e;
}

/* det(Q(x)) of the scaled matrices as a polynomial (coefficients p[0..2n]): D_i = q_ii D_(i-1) - o_(i-1)^2 D_(i-2),
 * q_ii = m_i x^2 + cd_i x + kd_i, o_i = co_i x + ko_i. */
static int determinant(const Scaled *S, double *p) {
    double a[DEG + 3] = {1.0}, b[DEG + 3] = {0}; /* D_(i-1), D_(i-2) */
    int da = 0, db = -1;
    for (int i = 0; i < S->n; i++) {
        double c[DEG + 3];
        memcpy(c, a, sizeof(c));
        int dc = poly_mul2(c, da, S->kd[i], S->cd[i], S->m[i]);
        if (i > 0 && db >= 0) {
            double o0 = S->ko[i - 1], o1 = S->co[i - 1], t[DEG + 3];
            memcpy(t, b, sizeof(t));
            int dt = poly_mul2(t, db, o0 * o0, 2.0 * o0 * o1, o1 * o1);
            for (int k = 0; k <= dt; k++) c[k] -= t[k];
            if (dt > dc) dc = dt;
        }
        memcpy(b, a, sizeof(b));
        db = da;
        memcpy(a, c, sizeof(a));
        da = dc;
    }
    memcpy(p, a, sizeof(double) * (size_t)(da + 1));
    return da;
}

static cplx horner(const double *p, int d, cplx x, cplx *dp) {
    cplx v = p[d], w = 0.0;
    for (int k = d - 1; k >= 0; k--) {
        w = w * x + v;
        v = v * x + p[k];
    }
    *dp = w;
    return v;
}

/* The roots of p (degree d, p[d] != 0) by the Aberth-Ehrlich iteration from a circle of the roots' geometric
 * mean radius. Returns 0 when every correction fell below 1e-15 of its root. */
static int aberth(const double *p, int d, cplx *z) {
    double r = pow(fabs(p[0] / p[d]), 1.0 / d);
    if (!(r > 0.0) || !isfinite(r)) return 1;
    for (int k = 0; k < d; k++) z[k] = r * cexp(I * (2.0 * M_PI * k / d + 0.4));
    for (int it = 0; it < 500; it++) {
        int done = 1;
        for (int k = 0; k < d; k++) {
            cplx dp, v = horner(p, d, z[k], &dp);
            if (v == 0.0) continue;
            cplx ratio = v / dp, sum = 0.0;
            for (int l = 0; l < d; l++)
                if (l != k) sum += 1.0 / (z[k] - z[l]);
            cplx w = ratio / (1.0 - ratio * sum);
            z[k] -= w;
            if (!(cabs(w) <= 1e-15 * cabs(z[k]))) done = 0;
        }
        if (done) return 0;
    }
    return 0; /* (the refinement below decides) */
}

/* Solve A x = b (n x n complex, row-major, overwritten) by Gaussian elimination with partial pivoting; 1 if a
 * pivot is zero. */
static int solve(int n, cplx *A, cplx *b) {
    for (int c = 0; c < n; c++) {
        int p = c;
        for (int r = c + 1; r < n; r++)
            if (cabs(A[r * n + c]) > cabs(A[p * n + c])) p = r;
        if (A[p * n + c] == 0.0) return 1;
        if (p != c) {
            for (int k = 0; k < n; k++) {
                cplx t = A[c * n + k];
                A[c * n + k] = A[p * n + k];
                A[p * n + k] = t;
            }
            cplx t = b[c];
            b[c] = b[p];
            b[p] = t;
        }
        for (int r = c + 1; r < n; r++) {
            cplx f = A[r * n + c] / A[c * n + c];
            for (int k = c; k < n; k++) A[r * n + k] -= f * A[c * n + k];
            b[r] -= f * b[c];
        }
    }
    for (int c = n - 1; c >= 0; c--) {
        cplx s = b[c];
        for (int k = c + 1; k < n; k++) s -= A[c * n + k] * b[k];
        b[c] = s / A[c * n + c];
    }
    return 0;
}

/* y^T X y of the scaled tridiagonal X (diagonal d, off-diagonal o), without conjugation. */
static cplx form(int n, const double *d, const double *o, const cplx *y) {
    cplx s = 0.0;
    for (int i = 0; i < n; i++) {
        s += d[i] * y[i] * y[i];
        if (i + 1 < n) s += 2.0 * o[i] * y[i] * y[i + 1];
    }
    return s;
}

/* Root x of det Q refined with its eigenvector y (scaled units): inverse iteration, then the root of
 * y^T Q(x) y = 0 nearest x. Returns 1 if it does not settle. */
static int refine(const Scaled *S, cplx *x, cplx *y) {
    int n = S->n;
    double zero[NS] = {0};
    for (int i = 0; i < n; i++) y[i] = 1.0 + 0.1 * i;
    for (int it = 0; it < 8; it++) {
        cplx A[NS * NS] = {0}, xs = *x * (1.0 + 1e-13);
        for (int i = 0; i < n; i++) {
            A[i * n + i] = S->m[i] * xs * xs + S->cd[i] * xs + S->kd[i];
            if (i + 1 < n) A[i * n + i + 1] = A[(i + 1) * n + i] = S->co[i] * xs + S->ko[i];
        }
        if (solve(n, A, y)) return 1;
        double norm = 0.0;
        for (int i = 0; i < n; i++) norm = fmax(norm, cabs(y[i]));
        if (!(norm > 0.0) || !isfinite(norm)) return 1;
        for (int i = 0; i < n; i++) y[i] /= norm;
        cplx a = form(n, S->m, zero, y), b = form(n, S->cd, S->co, y), c = form(n, S->kd, S->ko, y);
        cplx sq = csqrt(b * b - 4.0 * a * c), r1 = (-b + sq) / (2.0 * a), r2 = (-b - sq) / (2.0 * a);
        cplx next = cabs(r1 - *x) < cabs(r2 - *x) ? r1 : r2;
        double step = cabs(next - *x);
        *x = next;
        if (step <= 4.0 * DBL_EPSILON * cabs(*x) && it >= 2) return 0;
    }
    return 0;
}

int support_rest_modes(const SupportModes *sm, double mb, SupportModes *out, SupportShapes *shapes) {
    memset(out, 0, sizeof(*out));
    memset(shapes, 0, sizeof(*shapes));
    Scaled S;
    if (sm->ns < 1 || !(mb >= 0.0) || scaled(sm, mb, &S)) return 1;
    int n = S.n;
    double p[DEG + 3];
    int d = determinant(&S, p);
    if (d != 2 * n || p[d] == 0.0 || p[0] == 0.0) return 1; /* a zero eigenvalue */
    cplx x[DEG], Y[DEG][NS];
    if (aberth(p, d, x)) return 1;
    for (int k = 0; k < d; k++)
        if (refine(&S, &x[k], Y[k])) return 1;
    double big = 0.0;
    for (int k = 0; k < d; k++) big = fmax(big, cabs(x[k]));
    for (int k = 0; k < d; k++)
        for (int l = k + 1; l < d; l++)
            if (!(cabs(x[k] - x[l]) > 1e-7 * big)) return 1; /* repeated (or lost) roots */
    /* the terms: each complex pair once (its upper root, weight 2), each real root (weight 1) */
    double mp[NS], kd[NS], ko[NS];
    for (int i = 0; i < n; i++) {
        mp[i] = sm->mass[i] + (i == sm->j ? mb : 0.0);
        kd[i] = sm->stiff[i] + (i + 1 < n ? sm->stiff[i + 1] : 0.0);
        ko[i] = i + 1 < n ? -sm->stiff[i + 1] : 0.0;
    }
    int nt = 0, lower = 0, upper = 0;
    for (int k = 0; k < d; k++) {
        double im = cimag(x[k]), tol = 1e-9 * cabs(x[k]);
        if (im < -tol) {
            lower++;
            continue;
        }
        upper += im > tol;
        double w = im > tol ? 2.0 : 1.0;
        cplx lam = S.w0 * (im > tol ? x[k] : creal(x[k]));
        cplx *y = Y[k];
        if (w == 1.0)
            for (int i = 0; i < n; i++) y[i] = creal(y[i]);
        /* N = y^T (2 lambda M' + C) y, and (lambda M' + C) y, M' y, in physical units */
        cplx N = 0.0, Cy[NS], My[NS], m1 = 0.0;
        for (int i = 0; i < n; i++) {
            cplx ky = kd[i] * y[i] + (i > 0 ? ko[i - 1] * y[i - 1] : 0.0) + (i + 1 < n ? ko[i] * y[i + 1] : 0.0);
            Cy[i] = sm->a0 * sm->mass[i] * y[i] + sm->a1 * ky;
            My[i] = mp[i] * y[i];
            m1 += My[i];
        }
        for (int i = 0; i < n; i++) N += y[i] * (2.0 * lam * My[i] + Cy[i]);
        if (!(cabs(N) > 0.0) || !isfinite(cabs(N))) return 1;
        cplx beta = -m1 / N;
        out->lre[nt] = creal(lam);
        out->lim[nt] = cimag(lam);
        out->bre[nt] = creal(beta);
        out->bim[nt] = cimag(beta);
        out->mure[nt] = creal(w * m1);
        out->muim[nt] = cimag(w * m1);
        for (int i = 0; i < n; i++) {
            shapes->Yre[nt][i] = creal(w * y[i]);
            shapes->Yim[nt][i] = cimag(w * y[i]);
        }
        shapes->Nre[nt] = creal(N);
        shapes->Nim[nt] = cimag(N);
        out->yjre[nt] = shapes->Yre[nt][sm->j];
        out->yjim[nt] = shapes->Yim[nt][sm->j];
        nt++;
    }
    if (upper != lower || 2 * upper + (nt - upper) != d) return 1; /* a complex root without its conjugate */
    out->first = 1;
    out->mb = mb;
    out->nt = nt;
    out->nm = 0; /* (its terms are the modes: k1, k2, c and freq, per second-order mode, stay unused) */
    out->ns = n;
    out->j = sm->j;
    out->twoWay = sm->twoWay;
    memcpy(out->mass, sm->mass, sizeof(out->mass));
    memcpy(out->stiff, sm->stiff, sizeof(out->stiff));
    out->a0 = sm->a0;
    out->a1 = sm->a1;
    for (int t = 0; t < nt; t++) {
        out->labs[t] = hypot(out->lre[t], out->lim[t]);
        out->fastest = fmax(out->fastest, out->labs[t]);
    }
    /* checks to full precision: a state rebuilt from its modal coordinates, and the base's acceleration entering
     * the velocities alone with u'' = -a_g at rest (sum Re(Y beta) = 0, sum Re(lambda Y beta) = -1 on every floor) */
    double err = 0.0, zre[SUPPORT_MAX_TERMS], zim[SUPPORT_MAX_TERMS], st[2 * NS];
    for (int k = 0; k < n; k++) {
        st[2 * k] = sin(1.0 + k);
        st[2 * k + 1] = cos(2.0 * k + 1.0);
    }
    support_rest_coordinates(out, shapes, st, zre, zim);
    for (int i = 0; i < n; i++) {
        double u = 0.0, v = 0.0, f0 = 0.0, f1 = 0.0, size = 0.0;
        for (int t = 0; t < nt; t++) {
            cplx z = zre[t] + I * zim[t], Yt = shapes->Yre[t][i] + I * shapes->Yim[t][i], lam = out->lre[t] + I * out->lim[t];
            cplx b = out->bre[t] + I * out->bim[t];
            u += creal(Yt * z);
            v += creal(lam * Yt * z);
            f0 += creal(Yt * b);
            f1 += creal(lam * Yt * b);
            size += cabs(Yt * b);
        }
        err = fmax(err, fmax(fabs(u - sin(1.0 + i)), fabs(v - cos(2.0 * i + 1.0))));
        err = fmax(err, fmax(fabs(f0) / size, fabs(f1 + 1.0)));
    }
    return err < 1e-9 ? 0 : 1;
}

void support_rest_coordinates(const SupportModes *sm, const SupportShapes *sh, const double *z, double *zre,
                              double *zim) {
    int n = sm->ns;
    for (int t = 0; t < sm->nt; t++) {
        double w = sm->lim[t] > 0.0 ? 2.0 : 1.0;
        cplx lam = sm->lre[t] + I * sm->lim[t], s = 0.0;
        for (int i = 0; i < n; i++) {
            /* (lambda M' + C) y and M' y, row i: C = a0 M + a1 K, K tridiagonal; y = Y / w */
            cplx yi = (sh->Yre[t][i] + I * sh->Yim[t][i]) / w;
            cplx ky = (sm->stiff[i] + (i + 1 < n ? sm->stiff[i + 1] : 0.0)) * yi;
            if (i > 0) ky -= sm->stiff[i] * (sh->Yre[t][i - 1] + I * sh->Yim[t][i - 1]) / w;
            if (i + 1 < n) ky -= sm->stiff[i + 1] * (sh->Yre[t][i + 1] + I * sh->Yim[t][i + 1]) / w;
            double mp = sm->mass[i] + (i == sm->j ? sm->mb : 0.0);
            s += (lam * mp * yi + sm->a0 * sm->mass[i] * yi + sm->a1 * ky) * z[2 * i] + mp * yi * z[2 * i + 1];
        }
        cplx c = s / (sh->Nre[t] + I * sh->Nim[t]);
        zre[t] = creal(c);
        zim[t] = cimag(c);
    }
}
