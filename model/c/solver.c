/* Event-driven time stepping: steps, events, rest and uplift. */
#include "solver.h"

#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "events.h"
#include "ground.h"
#include "integrator.h"
#include "stack_solver.h"
#include "taylor.h"

/* Samples per Taylor step when looking for events. */
#define TAYLOR_SAMPLES 16

typedef struct {
    const Model *M;
    int side;
    int piece;
} RhsCtx;

static void rhs_cb(const void *ctx, double t, const double *y, double *dy) {
    const RhsCtx *c = (const RhsCtx *)ctx;
    model_rhs_piece(c->M, t, y, c->side, c->piece, dy);
}

/* Step length so that component comp of the step result equals target. */
static double refine(const RhsCtx *c, double t, const double *y, const double *f0,
                     double h, double hMax, int comp, double target, double *y1,
                     double *f1, double cont[5][NMAX]) {
    double w[2] = {comp == 0, comp == 1};
    return refine_step(rhs_cb, c, 2, t, y, f0, h, hMax, w, target, y1, f1, cont);
}

static void commit_peaks(Model *M, const Logger *log) {
    State *S = &M->s;
    for (int i = 0; i < S->nStepPeaks; i++) {
        S->peaks++;
        S->lastPeakTime = S->stepPeakTime[i];
        S->lastPeakTheta = S->stepPeakTheta[i];
        if (fabs(S->lastPeakTheta) > S->maxAbsTheta) S->maxAbsTheta = fabs(S->lastPeakTheta);
        say(log, LOG_EVENTS, "peak t=%.17g theta=%.17g", S->lastPeakTime, S->lastPeakTheta);
    }
    S->nStepPeaks = 0;
    if (fabs(S->y[0]) > S->maxAbsTheta) S->maxAbsTheta = fabs(S->y[0]);
}

static int apply_event(Model *M, const Logger *log) {
    State *S = &M->s;
    commit_peaks(M, log);
    if (S->pending == EVENT_IMPACT) {
        double wm = S->y[1], wp = M->d.eta * wm;
        S->impacts++;
        S->lastImpactTime = S->t;
        S->y[0] = 0.0;
        S->y[1] = wp;
        S->side = -S->side;
        S->fValid = 0;
        say(log, LOG_EVENTS, "impact t=%.17g omega_minus=%.17g omega_plus=%.17g",
            S->t, wm, wp);
        /* Rest criterion: below the uplift threshold, an impact whose rebound
         * (free rocking with effective gravity g + a_v) would peak below
         * restRatio * alpha ends the rocking. */
        double ah, av;
        model_ground(M, S->t, &ah, &av);
        double geff = M->v.g + av;
        if (geff > 0 && fabs(ah) <= geff * M->d.tanAlpha) {
            double pe2 = M->d.mROverI0 * geff;
            double cmax = cos(M->d.alpha) + wp * wp / (2.0 * pe2);
            if (cmax < 1.0 && M->d.alpha - acos(cmax) < M->v.restRatio * M->d.alpha) {
                S->mode = MODE_REST;
                S->y[1] = 0.0;
                S->restTime = S->t;
                S->h = 0.0;
                say(log, LOG_EVENTS, "rest t=%.17g", S->t);
            }
        }
    } else if (S->pending == EVENT_OVERTURN) {
        S->mode = MODE_OVERTURNED;
        S->overturnTime = S->t;
        S->y[0] = S->side * M_PI / 2;
        S->y[1] = 0.0;
        S->maxAbsTheta = M_PI / 2;
        say(log, LOG_EVENTS, "overturn t=%.17g side=%d", S->t, S->side);
    }
    S->pending = EVENT_NONE;
    return 0;
}

/* Checks after a step, and the early overturn decision. */
static int finish_step(Model *M, const Logger *log, int piece, int side, EventKind ev) {
    State *S = &M->s;
    const Variables *v = &M->v;
    {
        double ah, av;
        model_ground_piece(M, S->t, piece, &ah, &av);
        if (!(M->v.g + av > 0)) {
            say(log, LOG_ERROR,
                "vertical ground acceleration %g <= -g at t=%.17g: the block would leave the ground (not modelled)",
                av, S->t);
            return -1;
        }
    }
    if (!isfinite(S->y[0]) || !isfinite(S->y[1])) {
        say(log, LOG_ERROR, "non-finite state at t=%.17g", S->t);
        return -1;
    }

    /* Early overturn decision once nothing drives the block any more: past
     * alpha it falls if it moves outwards, or if it moves inwards without
     * the energy to get back over the corner (E < p^2). */
    if (ev == EVENT_NONE && v->earlyOverturn && excitation_over(M, S->t) &&
        v->ahIn == 0.0 && v->avIn == 0.0 && fabs(S->y[0]) > M->d.alpha) {
        double E = 0.5 * S->y[1] * S->y[1] + M->d.p2 * cos(M->d.alpha - fabs(S->y[0]));
        if (side * S->y[1] > 0 || E < M->d.p2) S->pending = EVENT_OVERTURN;
    }
    return 0;
}

static int take_step_taylor(Model *M, const Logger *log);

static int take_step(Model *M, const Logger *log) {
    State *S = &M->s;
    const Variables *v = &M->v;
    if (v->method == 1) return take_step_taylor(M, log);
    RhsCtx c = {M, S->side, model_piece(M, S->t)};
    double bp = next_breakpoint(M, S->t, c.piece);
    double hmax = bp - S->t;
    /* zeroed: the step fills components 0 and 1 only, and the whole array goes
     * into the state (no stray stack bytes in a saved state) */
    double y1[NMAX] = {0}, f1[NMAX] = {0}, cont[5][NMAX] = {{0}};
    double h = S->h, hNext;
    int hitBp;

    if (!S->fValid) {
        rhs_cb(&c, S->t, S->y, S->f);
        S->fValid = 1;
    }
    if (adaptive_step(rhs_cb, &c, 2, S->t, S->y, S->f, &h, hmax, v->relTol, v->absTol, y1, f1,
                      cont, &hNext, &hitBp, &S->rejected)) {
        say(log, LOG_ERROR, "no acceptable step size (last tried %g) at t=%.17g", h, S->t);
        return -1;
    }
    S->steps++;

    /* events on the dense output */
    int side = S->side;
    double cth[5], P[5], Q[5];
    dense_poly(cont, 0, cth);
    for (int i = 0; i < 5; i++) {
        P[i] = side * cth[i];
        Q[i] = P[i];
    }
    Q[0] -= M_PI / 2;
    double sImpact = first_crossing(P, -1);
    double sOver = first_crossing(Q, +1);
    EventKind ev = EVENT_NONE;
    double hStep = h, tNew = hitBp ? bp : S->t + h;
    if (sImpact <= 1.0 || sOver <= 1.0) {
        int comp = 0;
        double target;
        if (sImpact <= sOver) {
            ev = EVENT_IMPACT;
            target = 0.0;
        } else {
            ev = EVENT_OVERTURN;
            target = side * M_PI / 2;
        }
        double s = ev == EVENT_IMPACT ? sImpact : sOver;
        hStep = refine(&c, S->t, S->y, S->f, s * h, h, comp, target, y1, f1, cont);
        y1[0] = target;
        tNew = S->t + hStep;
        hitBp = 0;
    }

    /* peaks (omega = 0) inside the step, refined the same way */
    double com[5], roots[4];
    dense_poly(cont, 1, com);
    S->nStepPeaks = 0;
    if (may_have_root(com)) {
        int nr = poly_roots(com, 4, 0.0, 1.0, roots);
        for (int j = 0; j < nr && S->nStepPeaks < MAX_STEP_PEAKS; j++) {
            double r = roots[j], d = com[1] + r * (2 * com[2] + r * (3 * com[3] + r * 4 * com[4]));
            if (r <= 0.0 || d == 0.0) continue;
            if (ev != EVENT_NONE && r >= 1.0) continue;
            double yp[NMAX], fp[NMAX], cp[5][NMAX], yd[NMAX];
            double hp = refine(&c, S->t, S->y, S->f, r * hStep, hStep, 1, 0.0, yp, fp, cp);
            double tp = S->t + hp, thp = yp[0];
            if (fabs(hp - r * hStep) > 1e-3 * hStep) { /* Newton strayed: keep the interpolant */
                dense_eval(cont, 2, r, yd);
                tp = S->t + r * hStep;
                thp = yd[0];
            }
            S->stepPeakTime[S->nStepPeaks] = tp;
            S->stepPeakTheta[S->nStepPeaks] = thp;
            S->nStepPeaks++;
        }
    }

    S->tOld = S->t;
    S->hDense = hStep;
    memcpy(S->cont, cont, sizeof(cont));
    S->denseTaylor = 0;
    S->denseSide = side;
    S->denseValid = 1;
    S->t = tNew;
    S->y[0] = y1[0];
    S->y[1] = y1[1];
    S->f[0] = f1[0];
    S->f[1] = f1[1];
    S->fValid = (ev == EVENT_NONE && !hitBp);
    S->h = hNext;
    S->pending = ev;
    return finish_step(M, log, c.piece, side, ev);
}

/* One step of the Taylor-series integrator (solver.method = 1). */
static int take_step_taylor(Model *M, const Logger *log) {
    State *S = &M->s;
    const Variables *v = &M->v;
    int piece = model_piece(M, S->t), side = S->side, N = taylor_order(v->relTol);
    double x[TAYLOR_MAX + 1] = {0}, bp = next_breakpoint(M, S->t, piece); /* x[N + 1..]: 0 in the state */
    taylor_series(M, S->t, S->y[0], S->y[1], side, piece, N, x);
    double h = taylor_step(x, N, v->absTol + v->relTol * fabs(S->y[0]));
    int hitBp = 0;
    if (S->t + h >= bp) {
        h = bp - S->t;
        hitBp = 1;
    }
    if (!(h > 16.0 * DBL_EPSILON * fmax(1.0, fabs(S->t)))) {
        say(log, LOG_ERROR, "no acceptable step size (last tried %g) at t=%.17g", h, S->t);
        return -1;
    }
    S->steps++;
    double sImpact = taylor_first_crossing(x, N, h, 0, side, 0.0, -1, TAYLOR_SAMPLES);
    double sOver = taylor_first_crossing(x, N, h, 0, side, side * M_PI / 2, +1, TAYLOR_SAMPLES);
    EventKind ev = EVENT_NONE;
    double hStep = h;
    if (sImpact <= h || sOver <= h) {
        ev = sImpact <= sOver ? EVENT_IMPACT : EVENT_OVERTURN;
        hStep = fmin(sImpact, sOver);
        hitBp = 0;
    }
    /* peaks: omega changes sign inside the step (either way) */
    S->nStepPeaks = 0;
    for (int slope = -1; slope <= 1; slope += 2) {
        double sp = taylor_first_crossing(x, N, hStep, 1, side, 0.0, slope, TAYLOR_SAMPLES);
        if (sp > hStep || (ev != EVENT_NONE && sp >= hStep)) continue;
        double thp;
        taylor_eval(x, N, sp, &thp, NULL);
        int k = S->nStepPeaks++;
        if (k == 1 && S->stepPeakTime[0] > S->t + sp) { /* keep them in time order */
            S->stepPeakTime[1] = S->stepPeakTime[0];
            S->stepPeakTheta[1] = S->stepPeakTheta[0];
            k = 0;
        }
        S->stepPeakTime[k] = S->t + sp;
        S->stepPeakTheta[k] = thp;
    }
    double th1, om1;
    taylor_eval(x, N, hStep, &th1, &om1);
    if (ev == EVENT_IMPACT) th1 = 0.0;
    if (ev == EVENT_OVERTURN) th1 = side * M_PI / 2;
    S->tOld = S->t;
    S->hDense = hStep;
    memcpy(S->tay, x, sizeof(x));
    S->tayN = N;
    S->denseTaylor = 1;
    S->denseSide = side;
    S->denseValid = 1;
    S->t = hitBp ? bp : S->t + hStep;
    S->y[0] = th1;
    S->y[1] = om1;
    S->fValid = 0;
    S->pending = ev;
    return finish_step(M, log, piece, side, ev);
}

/* theta, omega at the fraction s of the last step, from its dense output. */
static void dense_state(const State *S, double s, double y[2]) {
    if (S->denseTaylor) taylor_eval(S->tay, S->tayN, s * S->hDense, &y[0], &y[1]);
    else dense_eval(S->cont, 2, s, y);
}

/* The ground tips the block resting at time t over its corner on side. */
static void start_rocking(Model *M, double t, int side, const Logger *log) {
    State *S = &M->s;
    S->t = t;
    S->mode = MODE_ROCKING;
    S->side = side;
    S->y[0] = 0.0;
    S->y[1] = 0.0;
    S->fValid = 0;
    S->h = 0.0;
    say(log, LOG_EVENTS, "uplift t=%.17g side=%d", t, side);
}

static const SolverOps ONE_BLOCK = {apply_event, take_step, start_rocking, commit_peaks};

void solver_initialize(Model *M, double t0) {
    model_initialize(M, t0);
    if (M->v.nBlocks == 2) stack_initialize(M);
}

int solver_advance(Model *M, double tc, const Logger *log) {
    if (M->v.nBlocks == 2) return stack_advance(M, tc, log);
    return advance_to(M, tc, log, &ONE_BLOCK);
}

void solver_outputs(Model *M, double tc) {
    State *S = &M->s;
    Variables *v = &M->v;
    if (v->nBlocks == 2) {
        stack_outputs(M, tc);
        return;
    }
    double y[2] = {S->y[0], S->y[1]};
    int side = S->side;
    if (S->t > tc && S->denseValid) {
        double s = (tc - S->tOld) / S->hDense;
        if (s < 0) s = 0;
        if (s > 1) s = 1;
        dense_state(S, s, y);
        side = S->denseSide;
    }
    v->theta = y[0];
    v->omega = y[1];
    if (S->mode == MODE_ROCKING) {
        double dy[2];
        model_rhs(M, tc, y, side, dy);
        v->alphaDD = dy[1];
    } else {
        v->alphaDD = 0.0;
    }
    int peaks = S->peaks;
    double lastT = S->lastPeakTime, lastTh = S->lastPeakTheta, mx = S->maxAbsTheta;
    for (int i = 0; i < S->nStepPeaks; i++)
        if (S->stepPeakTime[i] <= tc) {
            peaks++;
            lastT = S->stepPeakTime[i];
            lastTh = S->stepPeakTheta[i];
            if (fabs(lastTh) > mx) mx = fabs(lastTh);
        }
    if (fabs(y[0]) > mx) mx = fabs(y[0]);
    v->peaks = peaks;
    v->lastPeakTime = lastT;
    v->lastPeakTheta = lastTh;
    v->maxAbsTheta = mx;
    v->impacts = S->impacts;
    v->lastImpactTime = S->lastImpactTime;
    v->overturned = S->mode == MODE_OVERTURNED;
    v->atRest = S->mode == MODE_REST;
    v->overturnTime = S->overturnTime;
    v->restTime = S->restTime;
    v->pattern = (int)S->mode;
    v->impactsGround = S->impacts; /* one block: every impact is on the ground */
    v->overturned1 = v->overturned;
    /* no block 2 (whatever a former two-block initialisation wrote there) */
    v->theta2 = v->omega2 = v->alphaDD2 = v->maxAbsTheta2 = 0.0;
    v->impactsInterface = 0;
    v->locked = v->overturned2 = 0;
    v->energy = model_energy(M, y[0], y[1]);
    model_ground(M, tc, &v->ahTotal, &v->avTotal);
}

void solver_rollback(Model *M, double tc) {
    State *S = &M->s;
    S->fValid = 0; /* the derivative at (t, y) was for the old inputs */
    if (M->v.nBlocks == 2) {
        stack_rollback(M, tc);
        return;
    }
    if (S->mode != MODE_ROCKING || S->t <= tc || !S->denseValid) return;
    double s = (tc - S->tOld) / S->hDense, y[2];
    if (s < 0) s = 0;
    if (s > 1) s = 1;
    dense_state(S, s, y);
    S->y[0] = y[0];
    S->y[1] = y[1];
    S->t = tc;
    S->side = S->denseSide;
    S->pending = EVENT_NONE;
    S->fValid = 0;
    S->denseValid = 0;
    int k = 0;
    for (int i = 0; i < S->nStepPeaks; i++)
        if (S->stepPeakTime[i] <= tc) {
            S->stepPeakTime[k] = S->stepPeakTime[i];
            S->stepPeakTheta[k] = S->stepPeakTheta[i];
            k++;
        }
    S->nStepPeaks = k;
}
