/* Two stacked rocking blocks: Lagrange equations in expanded form, contact
 * reactions and the momentum impact map. Derivation: docs/two_blocks.md.
 *
 * Body-frame lever arms for pivots (s1, s2), origin at the bottom centre of
 * block 1 at rest:
 *   u1 = (-s1 b1, h1)          ground pivot -> centre of block 1
 *   uK = (s2 c - s1 b1, 2 h1)  ground pivot -> pivot K of block 2
 *   u2 = (-s2 c, h2)           K -> centre of block 2 (block 2's frame)
 * With phi = theta2 - theta1 the kinetic energy is
 *   T = 1/2 M11 w1^2 + M12(phi) w1 w2 + 1/2 M22 w2^2,
 *   M11 = Ic1 + m1 |u1|^2 + m2 |uK|^2,  M22 = Ic2 + m2 |u2|^2,
 *   M12 = m2 (A cos(phi) + B sin(phi)),  A = uK . u2,  B = uK x u2,
 * and the potential of gravity plus the ground's inertial force is
 *   V = W(theta1, m1 u1 + m2 uK) + m2 W(theta2, u2),
 *   W(theta, u) = ah (cos(theta) uy - sin(theta) ux) - ge (sin(theta) uy + cos(theta) ux),
 * ge = g + av. Lagrange's equations give
 *   M11 a1 + M12 a2 = -M12' w2^2 - dV/dtheta1
 *   M12 a1 + M22 a2 = +M12' w1^2 - dV/dtheta2,    M12' = dM12/dphi.
 */
#include "stack.h"

#include <math.h>

#include "ground.h"

typedef struct {
    double u1x, u1y, uKx, uKy, u2x, u2y;
} Arms;

static Arms arms(const Model *M, int s1, int s2) {
    const Variables *v = &M->v;
    Arms a;
    a.u1x = -s1 * v->halfWidth;
    a.u1y = v->halfHeight;
    a.uKx = s2 * M->d.c - s1 * v->halfWidth;
    a.uKy = 2.0 * v->halfHeight;
    a.u2x = -s2 * M->d.c;
    a.u2y = v->halfHeight2;
    return a;
}

void stack_derive(const Variables *v, Derived *d) {
    double b1 = v->halfWidth, h1 = v->halfHeight, m1 = v->mass;
    double b2 = v->halfWidth2, h2 = v->halfHeight2, m2 = v->mass2;
    d->c = fmin(b1, b2);
    d->Ic1 = m1 * (b1 * b1 + h1 * h1) / 3.0;
    d->Ic2 = m2 * (b2 * b2 + h2 * h2) / 3.0;
    d->mTot = m1 + m2;
    d->yG = (m1 * h1 + m2 * (2.0 * h1 + h2)) / d->mTot;
    /* the pair as one body about a corner of block 1 */
    d->RL = sqrt(b1 * b1 + d->yG * d->yG);
    d->alphaL = atan(b1 / d->yG);
    d->IL = d->Ic1 + m1 * (b1 * b1 + h1 * h1) + d->Ic2 +
            m2 * (b1 * b1 + (2.0 * h1 + h2) * (2.0 * h1 + h2));
    /* block 2 about an end of its contact with block 1 */
    d->RI = sqrt(d->c * d->c + h2 * h2);
    d->alphaI = atan(d->c / h2);
    d->II = d->Ic2 + m2 * d->RI * d->RI;
    /* at rest the ground tips the stack once |ah| > kappa (g + av) */
    d->upliftSlope = fmin(b1 / d->yG, d->c / h2);
}

/* Cosines and sines of theta1, theta2 and phi = theta2 - theta1 (two
 * sincos calls per state; the phi terms by the difference formulas). */
typedef struct {
    double c1, n1, c2, n2, cp, np;
} Trig;

static Trig trig(const double y[4]) {
    Trig T;
    T.c1 = cos(y[0]), T.n1 = sin(y[0]), T.c2 = cos(y[2]), T.n2 = sin(y[2]);
    T.cp = T.c2 * T.c1 + T.n2 * T.n1;
    T.np = T.n2 * T.c1 - T.c2 * T.n1;
    return T;
}

/* Mass matrix (M11, M12, M22) and dM12/dphi. */
static void mass(const Model *M, const Arms *a, const Trig *T, double m[3], double *dm12) {
    const Variables *v = &M->v;
    double A = a->uKx * a->u2x + a->uKy * a->u2y;
    double B = a->uKx * a->u2y - a->uKy * a->u2x;
    double c = T->cp, s = T->np;
    m[0] = M->d.Ic1 + v->mass * (a->u1x * a->u1x + a->u1y * a->u1y) +
           v->mass2 * (a->uKx * a->uKx + a->uKy * a->uKy);
    m[1] = v->mass2 * (A * c + B * s);
    m[2] = M->d.Ic2 + v->mass2 * (a->u2x * a->u2x + a->u2y * a->u2y);
    if (dm12) *dm12 = v->mass2 * (B * c - A * s);
}

/* W = dV/dtheta for a unit mass at rot(theta) u in the field (ah, ge);
 * c, s are cos(theta), sin(theta). */
static double W(double c, double s, double ux, double uy, double ah, double ge) {
    return ah * (c * uy - s * ux) - ge * (s * uy + c * ux);
}

/* Right-hand sides r of M a = r (generalised forces plus velocity terms). */
static void forces(const Model *M, const Arms *a, const Trig *T, const double y[4], double ah,
                   double av, double dm12, double r[2]) {
    const Variables *v = &M->v;
    double ge = v->g + av;
    double V1 = W(T->c1, T->n1, v->mass * a->u1x + v->mass2 * a->uKx,
                  v->mass * a->u1y + v->mass2 * a->uKy, ah, ge);
    double V2 = v->mass2 * W(T->c2, T->n2, a->u2x, a->u2y, ah, ge);
    r[0] = -dm12 * y[3] * y[3] - V1;
    r[1] = dm12 * y[1] * y[1] - V2;
}

/* Solve M x = r for the rates or accelerations the pattern allows:
 * x = L (L^T M L)^-1 L^T r with L = I (both), (1, 1) (locked), (0, 1)
 * (upper block alone); zero at rest. */
static void pattern_solve(Mode mode, const double m[3], const double r[2], double x[2]) {
    switch (mode) {
    case MODE_BOTH: {
        double det = m[0] * m[2] - m[1] * m[1];
        x[0] = (m[2] * r[0] - m[1] * r[1]) / det;
        x[1] = (m[0] * r[1] - m[1] * r[0]) / det;
        break;
    }
    case MODE_LOCKED:
        x[0] = x[1] = (r[0] + r[1]) / (m[0] + 2.0 * m[1] + m[2]);
        break;
    case MODE_UPPER:
        x[0] = 0.0;
        x[1] = r[1] / m[2];
        break;
    default:
        x[0] = x[1] = 0.0;
    }
}

static void accel_arms(const Model *M, Mode mode, const Arms *a, const Trig *T,
                       const double y[4], double ah, double av, double acc[2]) {
    double dm12, m[3], r[2];
    mass(M, a, T, m, &dm12);
    forces(M, a, T, y, ah, av, dm12, r);
    pattern_solve(mode, m, r, acc);
}

static void accel_trig(const Model *M, Mode mode, int s1, int s2, const Trig *T,
                       const double y[4], double ah, double av, double acc[2]) {
    /* an irrelevant pivot follows the relevant one (keeps mirror symmetry exact) */
    if (mode == MODE_LOCKED) s2 = s1;
    if (mode == MODE_UPPER) s1 = s2;
    Arms a = arms(M, s1, s2);
    accel_arms(M, mode, &a, T, y, ah, av, acc);
}

void stack_accel(const Model *M, Mode mode, int s1, int s2, const double y[4],
                 double ah, double av, double acc[2]) {
    Trig T = trig(y);
    accel_trig(M, mode, s1, s2, &T, y, ah, av, acc);
}

void stack_rhs(const Model *M, Mode mode, int s1, int s2, double t, const double y[4],
               int piece, double dy[4]) {
    double ah, av, acc[2];
    model_ground_piece(M, t, piece, &ah, &av);
    stack_accel(M, mode, s1, s2, y, ah, av, acc);
    dy[0] = y[1];
    dy[1] = acc[0];
    dy[2] = y[3];
    dy[3] = acc[1];
}

void stack_rhs_work(const Model *M, Mode mode, int s1, int s2, double t, const double y[4], int piece,
                    double dy[5]) {
    const Variables *v = &M->v;
    double ah, av, acc[2];
    model_ground_piece(M, t, piece, &ah, &av);
    Trig T = trig(y);
    if (mode == MODE_LOCKED) s2 = s1;
    if (mode == MODE_UPPER) s1 = s2;
    Arms a = arms(M, s1, s2);
    accel_arms(M, mode, &a, &T, y, ah, av, acc);
    dy[0] = y[1];
    dy[1] = acc[0];
    dy[2] = y[3];
    dy[3] = acc[1];
    /* the ground's power: minus the rate of the potential of the field (ah, av) at fixed (ah, av) */
    double V1 = W(T.c1, T.n1, v->mass * a.u1x + v->mass2 * a.uKx, v->mass * a.u1y + v->mass2 * a.uKy, ah, av);
    double V2 = v->mass2 * W(T.c2, T.n2, a.u2x, a.u2y, ah, av);
    dy[4] = -(V1 * y[1] + V2 * y[3]);
}

/* Residual M a - r of the pattern's motion in the coordinates of pivots
 * (s1, s2): the generalised forces the closed contacts must supply. */
static void residual(const Model *M, int s1, int s2, const Trig *T, const double acc[2],
                     const double y[4], double ah, double av, double res[2]) {
    double m[3], r[2], dm12;
    Arms a = arms(M, s1, s2);
    mass(M, &a, T, m, &dm12);
    forces(M, &a, T, y, ah, av, dm12, r);
    res[0] = m[0] * acc[0] + m[1] * acc[1] - r[0];
    res[1] = m[1] * acc[0] + m[2] * acc[1] - r[1];
}

void stack_margins(const Model *M, Mode mode, int s1, int s2, const double y[4],
                   double ah, double av, double ground[2], double interface[2]) {
    const Variables *v = &M->v;
    double acc[2], res[2];
    double sg = M->d.mTot * v->g * v->halfWidth, si = v->mass2 * v->g * M->d.c;
    ground[0] = ground[1] = interface[0] = interface[1] = INFINITY;
    if (mode == MODE_BOTH || mode == MODE_OVERTURNED) return;
    Trig T = trig(y);
    accel_trig(M, mode, s1, s2, &T, y, ah, av, acc);
    for (int k = 0; k < 2; k++) {
        int e = k == 0 ? 1 : -1; /* end of the contact */
        switch (mode) {
        case MODE_LOCKED: /* interface closed: reaction torque on phi */
            residual(M, s1, e, &T, acc, y, ah, av, res);
            interface[k] = e * res[1] / si;
            break;
        case MODE_UPPER: /* ground closed: reaction torque on theta1 */
            residual(M, e, s2, &T, acc, y, ah, av, res);
            ground[k] = e * res[0] / sg;
            break;
        case MODE_REST: /* both closed: res = (mu - tau, tau) */
            residual(M, e, e, &T, acc, y, ah, av, res);
            interface[k] = e * res[1] / si;
            ground[k] = e * (res[0] + res[1]) / sg;
            break;
        default:
            break;
        }
    }
}

/* B = V_new^T D V_old: generalised momentum in the new coordinates of the
 * velocity field of the old ones. */
static void cross_mass(const Model *M, const Arms *n, const Arms *o, const Trig *T,
                       double B[2][2]) {
    const Variables *v = &M->v;
    double c = T->cp, s = T->np;
    B[0][0] = M->d.Ic1 + v->mass * (n->u1x * o->u1x + n->u1y * o->u1y) +
              v->mass2 * (n->uKx * o->uKx + n->uKy * o->uKy);
    /* uKn^T rot(phi) u2o and u2n^T rot(-phi) uKo, rot(x) = [[cos, sin], [-sin, cos]] */
    B[0][1] = v->mass2 * (n->uKx * (c * o->u2x + s * o->u2y) + n->uKy * (-s * o->u2x + c * o->u2y));
    B[1][0] = v->mass2 * (n->u2x * (c * o->uKx - s * o->uKy) + n->u2y * (s * o->uKx + c * o->uKy));
    B[1][1] = M->d.Ic2 + v->mass2 * (n->u2x * o->u2x + n->u2y * o->u2y);
}

int stack_impact(const Model *M, Mode mode, int n1, int n2, int o1, int o2,
                 const double y[4], const double wMinus[2], double wPlus[2]) {
    double m[3], B[2][2], p[2];
    Trig T = trig(y);
    if (mode == MODE_LOCKED) n2 = n1;
    if (mode == MODE_UPPER) n1 = n2;
    Arms an = arms(M, n1, n2), ao = arms(M, o1, o2);
    mass(M, &an, &T, m, NULL);
    cross_mass(M, &an, &ao, &T, B);
    p[0] = B[0][0] * wMinus[0] + B[0][1] * wMinus[1];
    p[1] = B[1][0] * wMinus[0] + B[1][1] * wMinus[1];
    pattern_solve(mode, m, p, wPlus);
    if (mode == MODE_BOTH) return 1; /* no closed contact */
    /* impulses on the closed contacts, per end, in that end's coordinates */
    double tol = 1e-12 * (fabs(p[0]) + fabs(p[1]));
    for (int k = 0; k < 2; k++) {
        int e = k == 0 ? 1 : -1;
        int e1 = mode == MODE_LOCKED ? n1 : e, e2 = mode == MODE_LOCKED ? e : n2;
        if (mode == MODE_REST) e1 = e2 = e;
        Arms ae = arms(M, e1, e2);
        mass(M, &ae, &T, m, NULL);
        cross_mass(M, &ae, &ao, &T, B);
        double P0 = m[0] * wPlus[0] + m[1] * wPlus[1] - (B[0][0] * wMinus[0] + B[0][1] * wMinus[1]);
        double P1 = m[1] * wPlus[0] + m[2] * wPlus[1] - (B[1][0] * wMinus[0] + B[1][1] * wMinus[1]);
        if (mode == MODE_LOCKED && e * P1 < -tol) return 0;
        if (mode == MODE_UPPER && e * P0 < -tol) return 0;
        if (mode == MODE_REST && (e * P1 < -tol || e * (P0 + P1) < -tol)) return 0;
    }
    return 1;
}

double stack_kinetic(const Model *M, int s1, int s2, const double y[4], const double w[2]) {
    double m[3];
    Trig T = trig(y);
    Arms a = arms(M, s1, s2);
    mass(M, &a, &T, m, NULL);
    return 0.5 * (m[0] * w[0] * w[0] + 2.0 * m[1] * w[0] * w[1] + m[2] * w[1] * w[1]);
}

double stack_energy(const Model *M, int s1, int s2, const double y[4]) {
    const Variables *v = &M->v;
    Arms a = arms(M, s1, s2);
    double w[2] = {y[1], y[3]};
    double c1 = cos(y[0]), n1 = sin(y[0]), c2 = cos(y[2]), n2 = sin(y[2]);
    /* heights of the centres above their rest heights, rot(theta) u: y = -sin ux + cos uy */
    double dy1 = -n1 * a.u1x + c1 * a.u1y - v->halfHeight;
    double dy2 = -n1 * a.uKx + c1 * a.uKy - n2 * a.u2x + c2 * a.u2y -
                 (2.0 * v->halfHeight + v->halfHeight2);
    return stack_kinetic(M, s1, s2, y, w) + v->g * (v->mass * dy1 + v->mass2 * dy2);
}

/* ------------------------------------------------- patterns from the margins */

double stack_weakest(const Model *M, Mode mode, int s1, int s2, const double y[4],
                     double ah, double av, int *contact, int *end) {
    double g[2], in[2], m = INFINITY;
    stack_margins(M, mode, s1, s2, y, ah, av, g, in);
    for (int k = 0; k < 2; k++) {
        if (g[k] < m) {
            m = g[k];
            *contact = 0;
            *end = k == 0 ? 1 : -1;
        }
        if (in[k] < m) {
            m = in[k];
            *contact = 1;
            *end = k == 0 ? 1 : -1;
        }
    }
    return m;
}

int stack_admissible(const Model *M, Mode mode, int s1, int s2, const double y[4], double ah, double av) {
    int contact, end;
    double acc[2], tol = 1e-12 * M->v.g / M->d.RL;
    if (stack_weakest(M, mode, s1, s2, y, ah, av, &contact, &end) < -STACK_TOL_OPEN) return 0;
    if (mode == MODE_LOCKED) s2 = s1;
    if (mode == MODE_UPPER) s1 = s2;
    stack_accel(M, mode, s1, s2, y, ah, av, acc);
    if ((mode == MODE_LOCKED || mode == MODE_BOTH) && y[0] == 0.0 && y[1] == 0.0 &&
        s1 * acc[0] < -tol)
        return 0;
    if ((mode == MODE_UPPER || mode == MODE_BOTH) && y[2] == y[0] && y[3] == y[1] &&
        s2 * (acc[1] - acc[0]) < -tol)
        return 0;
    return 1;
}

/* the static check of each candidate pattern, least motion first */
Mode stack_start_pattern(const Model *M, double t, int side) {
    static const Mode order[3] = {MODE_LOCKED, MODE_UPPER, MODE_BOTH};
    double ah, av, y[4] = {0.0, 0.0, 0.0, 0.0};
    model_ground(M, t, &ah, &av);
    for (int i = 0; i < 3; i++)
        if (stack_admissible(M, order[i], side, side, y, ah, av)) return order[i];
    return MODE_BOTH;
}

