/* Contact reactions from Newton's second law for the centres of mass
 * (docs/contact.md). rot(theta) = [[cos, sin], [-sin, cos]] turns a body
 * vector clockwise; a point at rot(theta) u from a pivot fixed to the ground
 * accelerates, relative to the ground, by rot'(theta) u theta'' - rot(theta) u
 * theta'^2, rot' = [[-sin, cos], [-cos, -sin]]. In the inertial frame add the
 * ground's acceleration (ah, av). */
#include "contact.h"

#include <float.h>
#include <math.h>

#include "events.h"
#include "ground.h"
#include "stack.h"
#include "taylor.h"

/* Acceleration relative to the ground of the point rot(theta) (ux, uy). */
static void arm_accel(double theta, double omega, double alpha, double ux, double uy, double a[2]) {
    double c = cos(theta), s = sin(theta);
    double w2 = omega * omega;
    a[0] = (-s * ux + c * uy) * alpha - (c * ux + s * uy) * w2;
    a[1] = (-c * ux - s * uy) * alpha - (-s * ux + c * uy) * w2;
}

/* Velocity relative to the ground of the point rot(theta) (ux, uy). */
static void arm_velocity(double theta, double omega, double ux, double uy, double v[2]) {
    double c = cos(theta), s = sin(theta);
    v[0] = (-s * ux + c * uy) * omega;
    v[1] = (-c * ux - s * uy) * omega;
}

void contact_momenta(const Model *M, Mode mode, int s1, int s2, const double *y, double p[2][2]) {
    const Variables *v = &M->v;
    double v1[2] = {0.0, 0.0}, vK[2] = {0.0, 0.0}, v2[2] = {0.0, 0.0};
    p[0][0] = p[0][1] = p[1][0] = p[1][1] = 0.0;
    if (v->nBlocks != 2) {
        if (mode != MODE_ROCKING) return;
        if (y[0] == 0.0) { /* on the ground, where impacts happen: rot(0) = identity */
            v1[0] = v->halfHeight * y[1];
            v1[1] = s1 * v->halfWidth * y[1];
        } else {
            arm_velocity(y[0], y[1], -s1 * v->halfWidth, v->halfHeight, v1);
        }
        p[0][0] = v->mass * v1[0];
        p[0][1] = v->mass * v1[1];
        return;
    }
    if (mode != MODE_UPPER && mode != MODE_LOCKED && mode != MODE_BOTH) return;
    arm_velocity(y[0], y[1], -s1 * v->halfWidth, v->halfHeight, v1);
    arm_velocity(y[0], y[1], s2 * M->d.c - s1 * v->halfWidth, 2.0 * v->halfHeight, vK);
    arm_velocity(y[2], y[3], -s2 * M->d.c, v->halfHeight2, v2);
    p[0][0] = v->mass * v1[0];
    p[0][1] = v->mass * v1[1];
    p[1][0] = v->mass2 * (vK[0] + v2[0]);
    p[1][1] = v->mass2 * (vK[1] + v2[1]);
}

/* Position relative to the pivot of the point rot(theta) (ux, uy), horizontal (arm_velocity's integral). */
static double arm_x(double theta, double ux, double uy) { return ux * cos(theta) + uy * sin(theta); }

double contact_mass_moment(const Model *M, Mode mode, int s1, int s2, const double *y) {
    const Variables *v = &M->v;
    double b = v->halfWidth;
    if (v->nBlocks != 2) /* the centre of mass: from the pivot at s1 b, at rest above the origin */
        return mode == MODE_ROCKING ? v->mass * (s1 * b + arm_x(y[0], -s1 * b, v->halfHeight)) : 0.0;
    if (mode != MODE_UPPER && mode != MODE_LOCKED && mode != MODE_BOTH) return 0.0;
    double x1 = s1 * b + arm_x(y[0], -s1 * b, v->halfHeight);
    double xK = s1 * b + arm_x(y[0], s2 * M->d.c - s1 * b, 2.0 * v->halfHeight); /* block 2's pivot */
    return v->mass * x1 + v->mass2 * (xK + arm_x(y[2], -s2 * M->d.c, v->halfHeight2));
}

/* One block: the centre of mass sits at R (-sin(phi), cos(phi)) from the pivot,
 * phi = side alpha - theta, so it accelerates relative to the ground by
 * R (cos(phi) theta'' + sin(phi) theta'^2, sin(phi) theta'' - cos(phi) theta'^2). */
void contact_one_block_terms(const Model *M, double omega, double alphaDD, const RhsTerms *k, double *T,
                             double *N) {
    const Variables *v = &M->v;
    double R = M->d.R, w2 = omega * omega;
    *T = v->mass * (k->ah + R * (k->cphi * alphaDD + k->sphi * w2));
    *N = v->mass * (v->g + k->av + R * (k->sphi * alphaDD - k->cphi * w2));
}

void contact_stack(const Model *M, Mode mode, int s1, int s2, const double y[4], const double acc[2],
                   double ah, double av, double *Tg, double *Ng, double *Ti, double *Ni) {
    const Variables *v = &M->v;
    double c = M->d.c;
    double a1[2] = {0.0, 0.0}, aK[2] = {0.0, 0.0}, a2[2] = {0.0, 0.0};
    int moving = mode == MODE_UPPER || mode == MODE_LOCKED || mode == MODE_BOTH;
    if (moving) {
        /* ground pivot (s1 b1, 0) -> centre of block 1, -> pivot K = (s2 c, 2 h1) of block 2;
         * K -> centre of block 2 in block 2's frame */
        arm_accel(y[0], y[1], acc[0], -s1 * v->halfWidth, v->halfHeight, a1);
        arm_accel(y[0], y[1], acc[0], s2 * c - s1 * v->halfWidth, 2.0 * v->halfHeight, aK);
        arm_accel(y[2], y[3], acc[1], -s2 * c, v->halfHeight2, a2);
    }
    /* block 2: m2 (A + aK + a2) = F + m2 (0, -g) */
    double Fx = v->mass2 * (ah + aK[0] + a2[0]);
    double Fy = v->mass2 * (v->g + av + aK[1] + a2[1]);
    /* block 1: m1 (A + a1) = Q - F + m1 (0, -g) */
    *Tg = v->mass * (ah + a1[0]) + Fx;
    *Ng = v->mass * (v->g + av + a1[1]) + Fy;
    /* F in block 1's axes: tangent rot(theta1) (1, 0), normal rot(theta1) (0, 1) */
    double c1 = moving ? cos(y[0]) : 1.0, n1 = moving ? sin(y[0]) : 0.0;
    *Ti = Fx * c1 - Fy * n1;
    *Ni = Fx * n1 + Fy * c1;
}

/* ---------------------------------------------------------------- monitors */

static int contacts(const Model *M) { return M->v.nBlocks == 2 ? 2 : 1; }

static double mu(const Model *M, int c) { return c == 0 ? M->v.muGround : M->v.muInterface; }

/* weight a contact carries: both blocks on the ground, block 2 on block 1 */
static double weight(const Model *M, int c) { return M->d.weight[c]; }

static const char *contact_name(int c) { return c == 0 ? "ground" : "interface"; }

int contact_tipping_side(const Model *M, double t) {
    int piece = model_piece(M, t);
    for (int side = 1; side >= -1; side -= 2) /* in find_uplift's order */
        if (model_uplift_indicator_piece(M, t, side, piece) > 0) return side;
    return 0;
}

void contact_rest(const Model *M, double t, int inStep, double T[2], double N[2]) {
    const Variables *v = &M->v;
    double ah, av;
    (void)inStep;
    /* the contact engine samples the motion it starts itself (its exit is a slip or an opening) */
    int two = contacts(M) == 2, side = v->contactModel == 1 ? 0 : contact_tipping_side(M, t);
    /* The ground tips the body at this very instant (a step of the excitation, or one at the
     * start): it does not stay at rest, so the contacts carry the reactions of the motion that
     * starts from theta = omega = 0 (a stack in the pattern it starts in), not those of a body
     * moving with the ground. At a smooth uplift both are equal. */
    if (side) {
        if (two) {
            double y[4] = {0.0, 0.0, 0.0, 0.0}, acc[2] = {0.0, 0.0};
            Mode mode = stack_start_pattern(M, t, side);
            model_ground(M, t, &ah, &av);
            stack_accel(M, mode, side, side, y, ah, av, acc);
            contact_stack(M, mode, side, side, y, acc, ah, av, &T[0], &N[0], &T[1], &N[1]);
        } else {
            double y[2] = {0.0, 0.0}, dy[2];
            RhsTerms k;
            model_rhs_terms(M, t, y, side, model_piece(M, t), dy, &k);
            contact_one_block_terms(M, 0.0, dy[1], &k, &T[0], &N[0]);
            T[1] = N[1] = 0.0;
        }
        return;
    }
    model_ground(M, t, &ah, &av);
    /* the mass each contact carries, moving with the ground: both blocks on the ground, block 2 on block 1 */
    double carried[2] = {two ? v->mass + v->mass2 : v->mass, two ? v->mass2 : 0.0};
    for (int c = 0; c < 2; c++) {
        T[c] = carried[c] * ah;
        N[c] = carried[c] * (v->g + av);
    }
}

/* slide (kind 0): mu N - |T| < 0; lift (kind 1): N < 0 */
static double indicator(const Model *M, int kind, int c, double T, double N) {
    return kind == 0 ? mu(M, c) * N - fabs(T) : N;
}

/* The indicator of a contact along a path of reactions (first_negative's function). */
typedef struct {
    const Model *M;
    ReactionsFn path;
    int kind, c;
} PathIndicator;

static double along(void *ctx, double t) {
    const PathIndicator *p = ctx;
    double T[2], N[2];
    p->path(p->M, t, 1, T, N);
    return indicator(p->M, p->kind, p->c, T[p->c], N[p->c]);
}

/* First time in (a, b] at which the indicator turns negative along path, given that it is >= 0
 * at a and < 0 at b, to a few units of rounding. */
static double locate(const Model *M, ReactionsFn path, int kind, int c, double a, double b) {
    PathIndicator p = {M, path, kind, c};
    double fa = along(&p, a), fb = along(&p, b);
    if (!(fa >= 0)) fa = 0.0; /* a tie at the previous sample */
    return first_negative(along, &p, a, fa, b, fb, 2.0, 0.0, 1.0, 200);
}

/* The first sliding of contact c, at time `at` with reactions T, N. */
static void report_slide(Model *M, int c, double at, const double T[2], const double N[2], const Logger *log) {
    M->s.slideTime = at;
    say(log, LOG_EVENTS, "slide t=%.17g contact=%s demand=%.17g mu=%.17g", at, contact_name(c), fabs(T[c]) / N[c],
        mu(M, c));
}

/* The first sliding (kind 0) or lift-off (kind 1) of contact c, seen at the sample t. */
static void first_violation(Model *M, int kind, int c, double t, const double T[2], const double N[2],
                            ReactionsFn path, const Logger *log) {
    State *S = &M->s;
    double at = t;
    if (path != NULL && S->monValid && S->monT < t && indicator(M, kind, c, S->monTr[c], S->monN[c]) >= 0)
        at = locate(M, path, kind, c, S->monT, t);
    if (kind == 0) {
        report_slide(M, c, at, T, N, log);
    } else {
        S->liftTime = at;
        say(log, LOG_EVENTS, "lift t=%.17g contact=%s normal=%.17g", at, contact_name(c), N[c] / weight(M, c));
    }
}

/* A contact whose N turned tensile since the last sample needed more than mu N just
 * before, while N was still positive, unless T vanished with N (a block at rest on a
 * ground falling faster than g): the sliding is where mu N - |T| crossed zero, if N > 0
 * there. */
static void slide_before_lift(Model *M, int c, double t, ReactionsFn path, const Logger *log) {
    State *S = &M->s;
    if (path == NULL || !S->monValid || !(S->monT < t) || indicator(M, 0, c, S->monTr[c], S->monN[c]) < 0) return;
    double at = locate(M, path, 0, c, S->monT, t), T[2], N[2];
    path(M, at, 1, T, N);
    if (N[c] > 0) report_slide(M, c, at, T, N, log);
}

/* Take a sample at time t with reactions T, N. path (or NULL) gives the
 * reactions between the previous sample and t if the motion between them is
 * continuous. */
static void contact_sample(Model *M, double t, const double T[2], const double N[2], ReactionsFn path,
                           const Logger *log) {
    State *S = &M->s;
    for (int c = 0; c < contacts(M); c++) {
        /* every step samples: compare by products, divide only for a new extreme */
        double aT = fabs(T[c]), Nc = N[c], W = weight(M, c);
        if (aT > S->demandMax[c] * Nc && Nc > 0) S->demandMax[c] = aT / Nc;
        if (Nc < S->normalMin[c] * W || !S->monValid) S->normalMin[c] = Nc / W;
        if (aT > mu(M, c) * Nc || Nc < 0) { /* rarely */
            /* rocking-sliding: the solver itself records the first sliding */
            int rigid = M->v.contactModel != 1;
            if (rigid && S->slideTime < 0 && Nc > 0) first_violation(M, 0, c, t, T, N, path, log);
            if (rigid && S->slideTime < 0 && Nc <= 0) slide_before_lift(M, c, t, path, log);
            /* the contact engine (rocking-sliding) follows flight: no lift-off to flag */
            int flies = M->v.contactModel == 1;
            if (!flies && S->liftTime < 0 && Nc < 0) first_violation(M, 1, c, t, T, N, path, log);
        }
        S->monTr[c] = T[c];
        S->monN[c] = Nc;
    }
    S->monT = t;
    S->monValid = 1;
}

/* Every block within its stability limit: one block |theta| <= alpha; a stack, block 1
 * within the pair's limit about a ground corner and block 2 (absolute angle) within its
 * limit about an end of the contact. Past it the block falls unless driven back. */
static int within_limits(const Model *M) {
    const State *S = &M->s;
    if (S->mode == MODE_REST || (S->mode == MODE_SLIDE && M->v.nBlocks != 2)) return 1;
    if (M->v.nBlocks != 2) return fabs(S->y[0]) <= M->d.alpha;
    return fabs(S->y[0]) <= M->d.alphaL && fabs(S->y[2]) <= M->d.alphaI;
}

void contact_now(const Model *M, ReactionsFn moving, double T[2], double N[2]) {
    (M->s.mode == MODE_REST ? contact_rest : moving)(M, M->s.t, 0, T, N);
}

/* A Taylor-series step (taylor.h) is several times longer than a Dormand-Prince step at the
 * same tolerance: when its end is sampled (so never past a communication point) the monitors
 * also sample inside it, from its series, at most TAYLOR_MONITOR_SAMPLES - 1 evenly spaced
 * times (fewer in a step an event cut short: the spacing is a quarter of the step the series
 * allowed, S->h), and where a parabola through three samples puts a new largest friction
 * demand or smallest normal reaction of the ground (the extremes of a rocking block's
 * reactions under excitation lie inside its steps). */
#define TAYLOR_MONITOR_SAMPLES 4

typedef struct {
    double t, T[2], N[2], theta;
    int edge; /* the block reaches its stability limit here */
} Sample;

/* Where the parabola through (j - 1, f[j - 1]), (j, f[j]), (j + 1, f[j + 1]) (abscissae in units
 * of the spacing) has its extreme (sign +1 largest, -1 smallest) if that lies strictly between
 * j - 1 and j + 1, off j, and beyond `best`; else -1. */
static double vertex(const double *f, int j, double sign, double best) {
    double l = sign * f[j - 1], m = sign * f[j], r = sign * f[j + 1], c = l - 2.0 * m + r;
    if (!(c < 0)) return -1.0;
    double u = 0.5 * (l - r) / c;
    if (!(fabs(u) < 1.0) || u == 0.0 || !(m - 0.25 * (l - r) * u > sign * best)) return -1.0;
    return j + u;
}

static void sample_taylor_step(Model *M, ReactionsFn moving, const double Tb[2], const double Nb[2],
                               const Logger *log) {
    State *S = &M->s;
    double a = S->monT, b = S->t, u[2];
    int n = S->h > 0 ? (int)ceil(TAYLOR_MONITOR_SAMPLES * (b - a) / S->h) : TAYLOR_MONITOR_SAMPLES;
    if (n > TAYLOR_MONITOR_SAMPLES) n = TAYLOR_MONITOR_SAMPLES;
    Sample x[4 * TAYLOR_MONITOR_SAMPLES]; /* n + 1 nodes, n crossings of alpha, 2 (n - 1) extremes */
    double d[TAYLOR_MONITOR_SAMPLES + 1], w[TAYLOR_MONITOR_SAMPLES + 1], th[TAYLOR_MONITOR_SAMPLES + 1];
    for (int j = 0; j <= n; j++) {
        Sample *p = &x[j];
        p->t = j == 0 ? a : j == n ? b : a + (b - a) * j / n;
        p->edge = 0;
        if (j == n) th[j] = S->y[0]; /* (an event's exact target) */
        else if (p->t == S->tOld) th[j] = S->tay[0];
        else taylor_eval(S->tay, S->tayN, p->t - S->tOld, &th[j], NULL);
        p->theta = th[j];
        if (j == 0) p->T[0] = S->monTr[0], p->N[0] = S->monN[0];
        else if (j == n) p->T[0] = Tb[0], p->N[0] = Nb[0];
        else moving(M, p->t, 1, p->T, p->N);
        d[j] = p->N[0] > 0 ? fabs(p->T[0]) / p->N[0] : INFINITY; /* (a lift-off: no refinement) */
        w[j] = p->N[0];
    }
    int m = n + 1;
    /* fallTime: where the block passes its limit alpha, outwards, between two samples */
    for (int j = 0; j < n; j++) {
        double lim = th[j] > 0 ? M->d.alpha : -M->d.alpha;
        if (fabs(th[j]) <= M->d.alpha && fabs(th[j + 1]) > M->d.alpha && th[j] * th[j + 1] > 0) {
            double s = taylor_solve(S->tay, S->tayN, x[j].t - S->tOld, x[j + 1].t - S->tOld, lim);
            x[m].t = S->tOld + s;
            if (!(x[m].t > x[j].t && x[m].t < x[j + 1].t)) continue;
            x[m].edge = 1;
            x[m].theta = lim;
            moving(M, x[m].t, 1, x[m].T, x[m].N);
            m++;
        }
    }
    for (int j = 1; j < n; j++) {
        u[0] = isfinite(d[j - 1] + d[j] + d[j + 1]) ? vertex(d, j, 1.0, S->demandMax[0]) : -1.0;
        u[1] = vertex(w, j, -1.0, S->normalMin[0] * weight(M, 0));
        for (int k = 0; k < 2; k++)
            if (u[k] > 0 && u[k] < n) {
                x[m].t = a + (b - a) * u[k] / n;
                x[m].edge = 0;
                taylor_eval(S->tay, S->tayN, x[m].t - S->tOld, &x[m].theta, NULL);
                moving(M, x[m].t, 1, x[m].T, x[m].N);
                m++;
            }
    }
    /* inside the step, in time order */
    for (int i = n + 1; i < m; i++)
        for (int k = i; k > 1 && x[k].t < x[k - 1].t; k--) {
            Sample tmp = x[k];
            x[k] = x[k - 1];
            x[k - 1] = tmp;
        }
    for (int i = 1; i < m; i++) {
        if (x[i].t >= b) continue; /* the end: the caller's sample */
        contact_sample(M, x[i].t, x[i].T, x[i].N, moving, log);
        if (x[i].edge || fabs(x[i].theta) <= M->d.alpha) S->withinTime = x[i].t;
    }
}

void contact_sample_state(Model *M, ReactionsFn moving, const Logger *log, int continuous) {
    State *S = &M->s;
    if (S->mode == MODE_OVERTURNED) return;
    double T[2], N[2];
    int rest = S->mode == MODE_REST;
    contact_now(M, moving, T, N);
    ReactionsFn path = NULL;
    if (continuous && rest) path = contact_rest;
    else if (continuous && S->denseValid && S->monValid && S->monT >= S->tOld) path = moving;
    if (path == moving && S->denseTaylor && S->monT < S->t) sample_taylor_step(M, moving, T, N, log);
    contact_sample(M, S->t, T, N, path, log);
    if (within_limits(M)) S->withinTime = S->t;
}

/* The blocks' vertical excitation may vary: a record with a vertical column, a built-in vertical amplitude or the
 * input ground.av. */
static int vertical_motion(const Model *M) {
    return model_input_on(M, 1) || M->v.verticalAmplitude != 0.0 || (M->rec && M->rec->vertical);
}

void contact_sample_rest(Model *M, double end, const Logger *log) {
    double a = M->s.t, T[2], N[2];
    int piece = model_piece(M, a);
    for (;;) {
        /* at rest every contact's friction demand is |a_h| / (g + a_v): a floor's span whose bound stays within the
         * least demand met so far, and within mu, changes no monitor; its cells are skipped (its end is sampled) */
        double least = INFINITY, quiet;
        for (int c = 0; c < contacts(M); c++) least = fmin(least, fmin(M->s.demandMax[c], mu(M, c)));
        int calm = ground_quiet(M, a, piece, least, &quiet);
        double b = calm ? quiet : next_cell_edge(M, a, piece);
        if (!(b > a && b < end)) break;
        if (calm && !vertical_motion(M)) { /* nothing at rest varies but |a_h|: the span's end changes no monitor */
            piece = next_piece(M, piece, b);
            a = b;
            continue;
        }
        contact_rest(M, b, 0, T, N);
        contact_sample(M, b, T, N, contact_rest, log);
        piece = next_piece(M, piece, b);
        a = b;
    }
    contact_rest(M, end, 0, T, N);
    contact_sample(M, end, T, N, contact_rest, log);
    M->s.withinTime = end;
}

void contact_impulse(Model *M, double t, const double *y, Mode om, int o1, int o2, const double wm[2],
                     Mode nm, int n1, int n2, const double wp[2], const Logger *log) {
    State *S = &M->s;
    int two = M->v.nBlocks == 2;
    double ym[4] = {y[0], wm[0], two ? y[2] : 0.0, two ? wm[1] : 0.0};
    double yp[4] = {y[0], wp[0], two ? y[2] : 0.0, two ? wp[1] : 0.0};
    double p0[2][2], p1[2][2];
    contact_momenta(M, om, o1, o2, ym, p0);
    contact_momenta(M, nm, n1, n2, yp, p1);
    double dx2 = p1[1][0] - p0[1][0], dy2 = p1[1][1] - p0[1][1];
    double c1 = two ? cos(y[0]) : 1.0, n1s = two ? sin(y[0]) : 0.0;
    double Pt[2] = {p1[0][0] - p0[0][0] + dx2, dx2 * c1 - dy2 * n1s};
    double Pn[2] = {p1[0][1] - p0[0][1] + dy2, dx2 * n1s + dy2 * c1};
    /* impulses at rounding level of the momenta: that contact took none */
    double scale = 0.0;
    for (int i = 0; i < 2; i++)
        for (int k = 0; k < 2; k++) scale += fabs(p0[i][k]) + fabs(p1[i][k]);
    for (int c = 0; c < contacts(M); c++) {
        if (fabs(Pt[c]) + fabs(Pn[c]) <= 1e-9 * scale) continue;
        if (!(Pn[c] > 0)) {
            if (S->liftTime < 0) {
                S->liftTime = t;
                say(log, LOG_EVENTS, "lift t=%.17g contact=%s impulse=%.17g", t, contact_name(c), Pn[c]);
            }
            continue;
        }
        double d = fabs(Pt[c]) / Pn[c];
        if (d > S->impulseDemandMax) S->impulseDemandMax = d;
        if (d > mu(M, c) && S->slideTime < 0) {
            S->slideTime = t;
            say(log, LOG_EVENTS, "slide t=%.17g contact=%s impulse_demand=%.17g mu=%.17g", t, contact_name(c),
                d, mu(M, c));
        }
    }
}

void contact_outputs(const Model *M, Variables *v) {
    const State *S = &M->s;
    double T[2] = {v->groundT, v->interfaceT}, N[2] = {v->groundN, v->interfaceN};
    double dmax[2] = {0.0, 0.0}, nmin[2] = {1.0, 1.0};
    for (int c = 0; c < contacts(M); c++) {
        dmax[c] = S->demandMax[c];
        nmin[c] = S->monValid ? S->normalMin[c] : INFINITY;
        if (S->mode != MODE_OVERTURNED) { /* the reactions now count as well */
            if (N[c] > 0 && fabs(T[c]) / N[c] > dmax[c]) dmax[c] = fabs(T[c]) / N[c];
            if (N[c] / weight(M, c) < nmin[c]) nmin[c] = N[c] / weight(M, c);
        }
        if (!isfinite(nmin[c])) nmin[c] = 1.0;
    }
    v->demandMaxGround = dmax[0];
    v->demandMaxInterface = dmax[1];
    v->normalMinGround = nmin[0];
    v->normalMinInterface = nmin[1];
    v->slides = S->slideTime >= 0;
    v->slideTime = S->slideTime;
    v->lifts = S->liftTime >= 0;
    v->liftTime = S->liftTime;
    v->fallTime = S->mode == MODE_OVERTURNED ? S->withinTime : -1;
    v->impulseDemandMax = S->impulseDemandMax;
}
