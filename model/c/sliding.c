/* Rocking-sliding of one block: equations of each mode, transitions and the
 * impact law with friction (sliding.h; derivation in docs/sliding.md).
 *
 * Geometry: the pivot corner P on side s is at x = u + s b on the ground; the
 * centre of mass sits at R (-sin(phi), cos(phi)) from it, phi = s alpha - theta.
 * Relative to the ground the centre moves with
 *   X' = u' + R cos(phi) w,           Y' = R sin(phi) w,
 *   X'' = u'' + R (cos(phi) w' + sin(phi) w^2),
 *   Y'' = R (sin(phi) w' - cos(phi) w^2),
 * and Newton-Euler with the ground's reaction (T, N) at P, the weight and the
 * ground's inertial force -m (a_h, a_v) read
 *   m X'' = T - m a_h,   m Y'' = N - m (g + a_v),
 *   Ic w' = -R sin(phi) N - R cos(phi) T      (clockwise moments about the centre).
 */
#include "sliding.h"

#include <math.h>

#include "ground.h"

int sliding_on(const Model *M) { return M->v.contactModel == 1; }

static double sgn(double x) { return x > 0 ? 1.0 : x < 0 ? -1.0 : 0.0; }

int sliding_negligible(const Model *M, double t, double w, double v) {
    /* the rest criterion of an impact (model_rebound_negligible) in energy: the kinetic energy
     * left would lift the centre of mass by less than a rebound to restRatio * alpha does */
    double ah, av;
    model_ground(M, t, &ah, &av);
    double geff = M->v.g + av, alpha = M->d.alpha, m = M->v.mass, R = M->d.R;
    if (!(geff > 0 && fabs(ah) <= geff * M->d.upliftSlope)) return 0;
    double kinetic = 0.5 * m * v * v + 0.5 * M->d.I0 * w * w;
    return kinetic < m * geff * R * (cos(alpha - M->v.restRatio * alpha) - cos(alpha));
}

int sliding_components(Mode mode, int sigma) { return mode == MODE_ROCKING && sigma == 0 ? RS_N_ROCK : RS_N; }

double sliding_rhs(const Model *M, double t, const double *y, Mode mode, int side, int sigma, int piece,
                   double *dy, RhsTerms *k, double *T, double *N) {
    const Variables *v = &M->v;
    const double m = v->mass, R = M->d.R, mu = v->muGround;
    double D = 1.0;
    for (int i = 2; i < RS_N; i++) dy[i] = 0.0;
    if (mode == MODE_ROCKING) {
        /* theta, omega exactly as the rigid model computes them */
        model_rhs_terms(M, t, y, side, piece, dy, k);
        double w = y[1], w2 = w * w, geff = v->g + k->av;
        if (sigma == 0) { /* rock: the pivot sticks, reactions as contact.c's */
            if (T) {
                *T = m * (k->ah + R * (k->cphi * dy[1] + k->sphi * w2));
                *N = m * (geff + R * (k->sphi * dy[1] - k->cphi * w2));
            }
            dy[RS_WORK] = -m * R * w * (k->ah * k->cphi + k->av * k->sphi);
            return D;
        }
        /* slide-rock: T = -sigma mu N; a contact without compression (N < 0: flight, outside the
         * model, flagged by lifts) is held to the ground without friction */
        double q = sigma * mu * k->cphi - k->sphi, Nm;
        D = 1.0 / 3.0 - k->sphi * q;
        dy[1] = q * (geff - R * k->cphi * w2) / (R * D);
        Nm = m * (geff + R * (k->sphi * dy[1] - k->cphi * w2));
        if (Nm < 0) { /* mu = 0: q = -sin(phi), D = 1/3 + sin^2(phi) > 0 */
            q = -k->sphi;
            dy[1] = q * (geff - R * k->cphi * w2) / (R * (1.0 / 3.0 - k->sphi * q));
            Nm = m * (geff + R * (k->sphi * dy[1] - k->cphi * w2));
        }
        double Tm = Nm > 0 ? -sigma * mu * Nm : 0.0, vs = y[RS_RATE];
        dy[RS_SLIP] = vs;
        dy[RS_RATE] = Tm / m - k->ah - R * (k->cphi * dy[1] + k->sphi * w2);
        dy[RS_LOSS] = -Tm * vs;
        dy[RS_WORK] = -m * (k->ah * (vs + R * k->cphi * w) + k->av * R * k->sphi * w);
        if (T) {
            *T = Tm;
            *N = Nm;
        }
        return D;
    }
    dy[0] = dy[1] = 0.0;
    model_ground_piece(M, t, piece, &k->ah, &k->av);
    k->sphi = 0.0;
    k->cphi = 1.0;
    double Nm = m * (v->g + k->av), Tm = m * k->ah;
    if (mode == MODE_SLIDE) {
        double vs = y[RS_RATE];
        Tm = Nm > 0 ? -sigma * mu * Nm : 0.0; /* no friction without compression (flight, lifts) */
        dy[RS_SLIP] = vs;
        dy[RS_RATE] = Tm / m - k->ah;
        dy[RS_LOSS] = -Tm * vs;
        dy[RS_WORK] = -m * k->ah * vs;
    }
    if (T) {
        *T = Tm;
        *N = Nm;
    }
    return D;
}

double sliding_energy(const Model *M, const double *y, Mode mode, int side) {
    const Variables *v = &M->v;
    const double m = v->mass, R = M->d.R;
    double Xd = y[RS_RATE], Yd = 0.0, rise = 0.0, w = 0.0;
    if (mode == MODE_ROCKING || mode == MODE_OVERTURNED) {
        double phi = side * M->d.alpha - y[0];
        w = mode == MODE_ROCKING ? y[1] : 0.0;
        Xd += R * cos(phi) * w;
        Yd = R * sin(phi) * w;
        rise = R * cos(phi) - v->halfHeight;
    }
    double Ic = m * R * R / 3.0;
    return 0.5 * m * (Xd * Xd + Yd * Yd) + 0.5 * Ic * w * w + m * v->g * rise;
}

double sliding_momentum(const Model *M, const double *y, Mode mode, int side) {
    double Xd = y[RS_RATE];
    if (mode == MODE_ROCKING) Xd += M->d.R * cos(side * M->d.alpha - y[0]) * y[1];
    return M->v.mass * Xd;
}

double sliding_stick_margin(const Model *M, double T, double N) { return M->v.muGround * N - fabs(T); }

/* Reactions of a rocking block whose pivot sticks, at (t, y). */
static void rock_reactions(const Model *M, double t, const double *y, int side, double *T, double *N) {
    double dy[RS_N];
    RhsTerms k;
    sliding_rhs(M, t, y, MODE_ROCKING, side, 0, model_piece(M, t), dy, &k, T, N);
}

/* Can a slide-rock with slip direction sigma start at (t, y) (slip rate 0)? The ground must
 * press (N > 0) and the slip accelerate the way it slips. */
static int slide_rock_consistent(const Model *M, double t, const double *y, int side, int sigma) {
    double z[RS_N], dy[RS_N], T, N;
    RhsTerms k;
    for (int i = 0; i < RS_N; i++) z[i] = y[i];
    z[RS_RATE] = 0.0;
    double D = sliding_rhs(M, t, z, MODE_ROCKING, side, sigma, model_piece(M, t), dy, &k, &T, &N);
    return D > 0 && N > 0 && sigma * dy[RS_RATE] > 0;
}

/* The slip a pivot at rest on the ground takes when it cannot stick (reactions T, N of rocking):
 * the consistent slide-rock, first the one against the T rocking needed; 0 if none (held). */
static int slip_direction(const Model *M, double t, const double *z, int side, double T, double N) {
    int first = T > 0 ? -1 : 1;
    if (slide_rock_consistent(M, t, z, side, first)) return first;
    if (slide_rock_consistent(M, t, z, side, -first)) return -first;
    return N < 0 ? 0 : first; /* no consistent slide: held in flight (lifts), or the one T points to */
}

int sliding_settle(const Model *M, double t, const double *y, int side) {
    double z[RS_N], T, N;
    for (int i = 0; i < RS_N; i++) z[i] = y[i];
    z[RS_RATE] = 0.0;
    rock_reactions(M, t, z, side, &T, &N);
    if (N >= 0 && sliding_stick_margin(M, T, N) >= 0) return 0; /* the pivot sticks */
    return slip_direction(M, t, z, side, T, N);
}

int sliding_slip_start(const Model *M, double t, const double *y, int side) {
    double z[RS_N], T, N;
    for (int i = 0; i < RS_N; i++) z[i] = y[i];
    z[RS_RATE] = 0.0;
    rock_reactions(M, t, z, side, &T, &N);
    int sigma = slip_direction(M, t, z, side, T, N);
    return sigma ? sigma : (T > 0 ? -1 : 1);
}

void sliding_start(const Model *M, double t, int side, Mode *mode, int *sigma) {
    if (M->v.muGround <= M->d.tanAlpha) { /* a flat slide holds: the block slides towards side */
        *mode = MODE_SLIDE;
        *sigma = side;
        return;
    }
    double y[RS_N] = {0};
    *mode = MODE_ROCKING;
    *sigma = sliding_settle(M, t, y, side);
}

void sliding_stop(const Model *M, double t, const double *y, Mode mode, int side, Mode *next, int *sigma) {
    double ah, av;
    model_ground(M, t, &ah, &av);
    if (mode == MODE_SLIDE) {
        double geff = M->v.g + av;
        if (fabs(ah) <= M->v.muGround * geff) {
            *next = MODE_REST;
            *sigma = 0;
        } else { /* the ground drags the block the other way at once */
            *next = MODE_SLIDE;
            *sigma = ah > 0 ? -1 : 1;
        }
        return;
    }
    *next = MODE_ROCKING;
    *sigma = sliding_settle(M, t, y, side);
}

void sliding_impact(const Model *M, double t, double wm, double vm, int side, Mode *mode, int *newSide,
                    int *sigma, double *wp, double *vp, double *Pt, double *Pn) {
    const Variables *v = &M->v;
    const double m = v->mass, b = v->halfWidth, h = v->halfHeight, mu = v->muGround;
    const double eta = M->d.eta, a = M->d.I0 / (m * h); /* I0 / (m h) = 4 R^2 / (3 h) */
    int s1 = -side;                                      /* the landing corner */
    double w = eta * wm + vm / a, u = 0.0;              /* sticking: I0 w+ = eta I0 w- + m h v- */
    int sg = 0, flat = !(s1 * w > 0);
    if (!flat) {
        double pt = m * (h * w - (vm + h * wm)), pn = m * s1 * b * (w + wm);
        if (fabs(pt) <= mu * pn) {
            /* a sticking impact; a negligible rebound ends the motion (the rest criterion):
             * the tiny impacts that would follow all stick as well */
            if (model_rebound_negligible(M, t, w)) {
                *mode = MODE_REST;
                *newSide = s1;
                *sigma = 0;
                *wp = *vp = 0.0;
                *Pt = m * (0.0 - (vm + h * wm));
                *Pn = m * (0.0 - side * b * wm);
                return;
            }
        } else { /* the corner cannot stick: a sliding impact, Pt = -sg mu Pn */
            sg = pt > 0 ? -1 : 1;
            double k = sg * mu * s1 * b;
            w = wm * (h - a * eta - k) / (h - a + k);
            u = vm + a * (eta * wm - w);
            flat = !(s1 * w > 0) || model_rebound_negligible(M, t, w);
            sg = u > 0 ? 1 : u < 0 ? -1 : 0;
        }
    }
    if (flat) { /* both corners down: the rotation stops, friction takes what it can of the sliding */
        double vx = vm + h * wm, cap = mu * b * fabs(wm);
        w = 0.0;
        u = fabs(vx) <= cap ? 0.0 : vx - sgn(vx) * cap;
        if (sliding_negligible(M, t, 0.0, u)) u = 0.0;
        sg = u > 0 ? 1 : u < 0 ? -1 : 0;
        *mode = sg ? MODE_SLIDE : MODE_REST;
        *newSide = sg ? sg : s1;
        if (sg && mu > M->d.tanAlpha) *mode = MODE_ROCKING; /* a flat slide tips forward at once */
    } else {
        *mode = MODE_ROCKING;
        *newSide = s1;
    }
    *sigma = sg;
    *wp = w;
    *vp = u;
    /* the ground's impulses: the change of the centre's momentum (at theta = 0: X' = u' + h w,
     * Y' = s b w with s the pivot's side) */
    *Pt = m * ((u + h * w) - (vm + h * wm));
    *Pn = m * ((*newSide) * b * w - side * b * wm);
}
