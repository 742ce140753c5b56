/* Event-driven time stepping: steps, events, rest and uplift. */
#include "solver.h"
#include "support.h"

#include <float.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "contact.h"
#include "coupling.h"
#include "engine_solver.h"
#include "events.h"
#include "ground.h"
#include "integrator.h"
#include "stack_solver.h"
#include "taylor.h"

/* Samples per Taylor step when looking for events. */
#define TAYLOR_SAMPLES 16
/* The shortest Taylor step (before a break point cuts it), in units of the block's time
 * scale 1 / (p + |omega|) (1/p, or the time to turn by a radian): at the tolerances allowed
 * it is at least 0.1 of the series' radius (eps^(1/N) with N <= TAYLOR_MAX), far above this. A
 * shorter one would take 1e6 steps per time scale, a run that never returns: an error. */
#define TAYLOR_STEP_FLOOR 1e-6
/* The longest Taylor step, in units of 1 / p (the series' radius is about 1 / p and the steps
 * a fraction of it; only a series that ends gives more). */
#define TAYLOR_STEP_CAP 1e3

typedef struct {
    const Model *M;
    int side;
    int piece;
    RhsTerms k; /* of the last evaluation */
} RhsCtx;

static void rhs_cb(const void *ctx, double t, const double *y, double *dy) {
    RhsCtx *c = (RhsCtx *)ctx; /* the integrator hands our own (non-const) context back */
    model_rhs_terms(c->M, t, y, c->side, c->piece, dy, &c->k);
}

/* The integrator's context for pivot side at time t. */
static RhsCtx rhs_context(const Model *M, double t, int side) {
    RhsCtx c = {.M = M, .side = side, .piece = model_piece(M, t)};
    return c;
}

/* Step length so that component comp of the step result equals target. */
static double refine(const RhsCtx *c, double t, const double *y, const double *f0,
                     double h, double hMax, int comp, double target, double *y1,
                     double *f1, Dense *cont) {
    double w[NMAX] = {0};
    w[comp] = 1.0;
    return refine_step(RK_DOPRI5, rhs_cb, c, 2, t, y, f0, h, hMax, w, target, y1, f1, cont, NULL);
}

/* Block 1 has fallen over at S->t: it lies on its side. */
static void overturn(Model *M, const Logger *log) {
    State *S = &M->s;
    S->mode = MODE_OVERTURNED;
    S->overturnTime = S->t;
    S->y[0] = S->side * M_PI / 2;
    S->y[1] = 0.0;
    S->maxAbsTheta = M_PI / 2;
    say(log, LOG_EVENTS, "overturn t=%.17g side=%d", S->t, S->side);
}

static int apply_event(Model *M, const Logger *log) {
    State *S = &M->s;
    commit_peaks(M, log);
    if (S->pending == EVENT_IMPACT) {
        double wm = S->y[1], wp;
        int rest = model_impact(M, S->t, wm, &wp);
        {
            double y0[2] = {0.0, 0.0}, w0[2] = {wm, 0.0}, w1[2] = {wp, 0.0};
            contact_impulse(M, S->t, y0, MODE_ROCKING, S->side, 0, w0, MODE_ROCKING, -S->side, 0, w1, log);
        }
        S->impacts++;
        S->lastImpactTime = S->t;
        S->y[0] = 0.0;
        S->y[1] = wp;
        S->side = -S->side;
        S->fValid = 0;
        say(log, LOG_EVENTS, "impact t=%.17g omega_minus=%.17g omega_plus=%.17g",
            S->t, wm, wp);
        if (rest) {
            S->mode = MODE_REST;
            S->y[1] = 0.0;
            S->restTime = S->t;
            S->h = 0.0;
            say(log, LOG_EVENTS, "rest t=%.17g", S->t);
        }
    } else if (S->pending == EVENT_OVERTURN) {
        overturn(M, log);
    }
    S->pending = EVENT_NONE;
    return 0;
}

/* Checks after a step, and the early overturn decision. */
static int finish_step(Model *M, const Logger *log, int side, EventKind ev) {
    State *S = &M->s;
    const Variables *v = &M->v;
    if (!isfinite(S->y[0]) || !isfinite(S->y[1])) {
        say(log, LOG_ERROR, "non-finite state at t=%.17g", S->t);
        return -1;
    }

    /* Early overturn decision once nothing drives the block any more: past
     * alpha it falls if it moves outwards, or if it moves inwards without
     * the energy to get back over the corner (E < p^2). */
    if (ev == EVENT_NONE && v->earlyOverturn && excitation_over(M, S->t) &&
        !model_inputs_on(M) && fabs(S->y[0]) > M->d.alpha) {
        double E = 0.5 * S->y[1] * S->y[1] + M->d.p2 * cos(M->d.alpha - fabs(S->y[0]));
        if (side * S->y[1] > 0 || E < M->d.p2) S->pending = EVENT_OVERTURN;
    }
    return 0;
}

static int take_step_taylor(Model *M, const Logger *log);

static int take_step(Model *M, const Logger *log) {
    State *S = &M->s;
    const Variables *v = &M->v;
    if (taylor_on(M)) return take_step_taylor(M, log);
    RhsCtx c = rhs_context(M, S->t, S->side);
    double bp = next_breakpoint(M, S->t, c.piece);
    double hmax = bp - S->t;
    /* zeroed: the step fills components 0 and 1 only, and the whole array goes into the state
     * (no stray stack bytes in a saved state) */
    double y1[NMAX] = {0}, f1[NMAX] = {0};
    Dense cont = {0};
    double h = S->h, hNext;
    int hitBp;

    if (!S->fValid) {
        rhs_cb(&c, S->t, S->y, S->f);
        S->fValid = 1;
        S->endValid = 0; /* the reactions stored are not this state's */
    }
    if (adaptive_step(rhs_cb, &c, 2, S->t, S->y, S->f, &h, hmax, v->relTol, v->absTol, y1, f1, &cont, &hNext, &hitBp,
                      &S->rejected)) {
        say(log, LOG_ERROR, "no acceptable step size (last tried %g) at t=%.17g", h, S->t);
        return -1;
    }
    S->steps++;
    /* the accepted step's last evaluation was its first-same-as-last stage at its end */
    RhsTerms endTerms = c.k;

    /* events on the dense output */
    int side = S->side;
    double cth[DENSE_ROWS], P[5], Q[5];
    dense_poly(&cont, 0, cth);
    for (int i = 0; i < 5; i++) {
        P[i] = side * cth[i];
        Q[i] = P[i];
    }
    Q[0] -= M_PI / 2;
    double sImpact = first_crossing(P, 4, -1), sOver = first_crossing(Q, 4, +1);
    EventKind ev = EVENT_NONE;
    double hStep = h, tNew = hitBp ? bp : S->t + h;
    double sFirst = fmin(sImpact, sOver);
    if (sFirst <= 1.0) {
        double target = 0.0;
        if (sImpact <= sOver) {
            ev = EVENT_IMPACT;
        } else {
            ev = EVENT_OVERTURN;
            target = side * M_PI / 2;
        }
        hStep = refine(&c, S->t, S->y, S->f, sFirst * h, h, 0, target, y1, f1, &cont);
        y1[0] = target;
        tNew = S->t + hStep;
        hitBp = 0;
    }

    /* peaks (omega = 0) inside the step, refined the same way */
    double com[DENSE_ROWS], roots[4];
    dense_poly(&cont, 1, com);
    S->nStepPeaks = 0;
    if (may_have_root(com, 4)) {
        int nr = poly_roots(com, 4, 0.0, 1.0, roots);
        for (int j = 0; j < nr && S->nStepPeaks < MAX_STEP_PEAKS; j++) {
            double r = roots[j], d = com[1] + r * (2 * com[2] + r * (3 * com[3] + r * 4 * com[4]));
            if (r <= 0.0 || d == 0.0) continue;
            if (ev != EVENT_NONE && r >= 1.0) continue;
            double yp[NMAX], fp[NMAX], yd[NMAX];
            Dense cp;
            double hp = refine(&c, S->t, S->y, S->f, r * hStep, hStep, 1, 0.0, yp, fp, &cp);
            double tp = S->t + hp, thp = yp[0];
            if (fabs(hp - r * hStep) > 1e-3 * hStep) { /* Newton strayed: keep the interpolant */
                dense_eval(&cont, 2, r, yd);
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
    S->cont = cont;
    S->denseTaylor = 0;
    S->denseSide = side;
    S->denseValid = 1;
    S->t = tNew;
    for (int i = 0; i < 2; i++) {
        S->y[i] = y1[i];
        S->f[i] = f1[i];
    }
    S->fValid = ev == EVENT_NONE && (!hitBp || ground_continuous_after(M, c.piece)); /* (the next step's start) */
    S->h = hNext;
    S->pending = ev;
    /* the contact reactions at the step's end, from that evaluation: a few products */
    S->endValid = S->fValid;
    if (S->endValid) contact_one_block_terms(M, S->y[1], S->f[1], &endTerms, &S->endTr, &S->endN);
    return finish_step(M, log, side, ev);
}

/* One step of the Taylor-series integrator (taylor_on: solver.method = 1, or 2 for one rigid block). */
static int take_step_taylor(Model *M, const Logger *log) {
    State *S = &M->s;
    const Variables *v = &M->v;
    int piece = model_piece(M, S->t), side = S->side, N = taylor_order(v->relTol);
    double x[TAYLOR_MAX + 1] = {0}, bp = next_breakpoint(M, S->t, piece); /* x[N + 1..]: 0 in the state */
    taylor_series(M, S->t, S->y[0], S->y[1], side, piece, N, x);
    double h = taylor_step(x, N, v->absTol + v->relTol * fabs(S->y[0]));
    if (!isfinite(x[N]) || !isfinite(x[N - 1]) || isnan(h)) { /* rates beyond double precision's range */
        say(log, LOG_ERROR, "no acceptable step size (the Taylor series of order %d is not finite) at t=%.17g", N, S->t);
        return -1;
    }
    /* a series that ends (all its last terms 0: the block balanced on its corner) is exact for
     * any step: a long one, but finite */
    h = fmin(h, TAYLOR_STEP_CAP / sqrt(M->d.p2));
    double hFloor = TAYLOR_STEP_FLOOR / (sqrt(M->d.p2) + fabs(S->y[1]));
    if (!(h >= hFloor)) {
        say(log, LOG_ERROR,
            "the Taylor step %g s at t=%.17g is below %g s (1e-6 / (p + |omega|)): solver.relTol = %g, solver.absTol = %g cannot "
            "be met here",
            h, S->t, hFloor, v->relTol, v->absTol);
        return -1;
    }
    S->h = h; /* the step the series allows (the monitors' spacing inside it, contact.c) */
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
    S->endValid = 0;
    S->pending = ev;
    return finish_step(M, log, side, ev);
}

/* theta, omega at the fraction s of the last step, from its dense output. */
static void dense_state(const Model *M, double s, double *y) {
    const State *S = &M->s;
    if (S->denseTaylor) taylor_eval(S->tay, S->tayN, s * S->hDense, &y[0], &y[1]);
    else dense_eval(&S->cont, 2, s, y);
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

/* Contact reactions of the rocking block at time t (contact.h). */
static void reactions(const Model *M, double t, int inStep, double T[2], double N[2]) {
    const State *S = &M->s;
    double y[2] = {S->y[0], S->y[1]}, dy[2];
    int side = S->side;
    T[1] = N[1] = 0.0;
    if (!inStep && S->fValid && S->endValid) { /* (t, y) is still the last step's end */
        T[0] = S->endTr;
        N[0] = S->endN;
        return;
    }
    if (inStep && S->denseValid && S->hDense > 0) {
        double s = (t - S->tOld) / S->hDense;
        dense_state(M, s < 0 ? 0 : s > 1 ? 1 : s, y);
        side = S->denseSide;
    }
    RhsTerms k;
    model_rhs_terms(M, t, y, side, model_piece(M, t), dy, &k);
    contact_one_block_terms(M, y[1], dy[1], &k, &T[0], &N[0]);
}

static const SolverOps ONE_BLOCK = {apply_event, take_step, start_rocking, commit_peaks, reactions, NULL, NULL};

void solver_sample_contacts(Model *M, const Logger *log) { contact_sample_state(M, reactions, log, 0); }

void solver_contact_now(const Model *M, double *T, double *N) {
    double Tc[2], Nc[2];
    contact_now(M, reactions, Tc, Nc);
    *T = Tc[0];
    *N = Nc[0];
}

void solver_initialize(Model *M, double t0) {
    model_initialize(M, t0);
    if (engine_on(M)) engine_initialize(M);
    else if (M->v.nBlocks == 2) stack_initialize(M);
}

int solver_advance(Model *M, double tc, const Logger *log, EventStop *stop) {
    if (engine_on(M)) return engine_advance(M, tc, log, stop);
    if (M->v.nBlocks == 2) return stack_advance(M, tc, log, stop);
    return advance_to(M, tc, log, &ONE_BLOCK, stop);
}

static void outputs_at(Model *M, double tc) {
    State *S = &M->s;
    Variables *v = &M->v;
    /* no sliding in the rigid models: block 1's contact mode follows the pattern */
    v->slip = v->slipRate = v->maxAbsSlip = v->slideDuration = v->frictionLoss = v->impactLoss = v->groundWork = 0.0;
    v->slideStartTime = -1.0;
    v->slideStarts = 0;
    /* block 2's sliding outputs: the rocking-sliding stack's only */
    v->slip2 = v->slipRate2 = v->maxAbsSlip2 = v->slideDuration2 = v->frictionLoss2 = 0.0;
    v->slideStartTime2 = v->fellOffTime = -1.0;
    v->slideStarts2 = v->contactMode2 = v->fellOff = 0;
    v->gap = v->maxGap = v->flightTime = 0.0;
    v->flights = v->painleve = 0;
    if (engine_on(M)) {
        engine_outputs(M, tc);
        return;
    }
    if (v->nBlocks == 2) {
        stack_outputs(M, tc);
        v->contactMode2 = S->mode == MODE_OVERTURNED ? 4 : S->mode == MODE_UPPER || S->mode == MODE_BOTH ? 2 : 0;
        v->contactMode = S->mode == MODE_OVERTURNED && S->overturned1  ? 4
                         : S->mode == MODE_LOCKED || S->mode == MODE_BOTH ? 2
                                                                          : 0;
        return;
    }
    double y[NMAX];
    memcpy(y, S->y, sizeof(y));
    int side = S->side;
    Mode mode = S->mode;
    if (S->t > tc && S->denseValid) {
        double s = (tc - S->tOld) / S->hDense;
        if (s < 0) s = 0;
        if (s > 1) s = 1;
        dense_state(M, s, y);
        side = S->denseSide;
    }
    v->theta = y[0];
    v->omega = y[1];
    /* the equation of motion's terms also give the ground's accelerations and the reactions */
    RhsTerms k;
    int rocking = S->mode == MODE_ROCKING;
    if (rocking) {
        double dy[2];
        model_rhs_terms(M, tc, y, side, model_piece(M, tc), dy, &k);
        v->alphaDD = dy[1];
    } else {
        model_ground(M, tc, &k.ah, &k.av);
        k.sphi = 0.0;
        k.cphi = 1.0;
        v->alphaDD = 0.0;
    }
    peak_outputs(S, tc, y[0], v);
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
    v->ahTotal = k.ah;
    v->avTotal = k.av;
    /* at rest or overturned the block moves with the ground (omega = alpha_dd = 0) */
    if (S->mode == MODE_REST && contact_tipping_side(M, tc)) { /* the rocking that starts, if the ground tips it at tc (contact_rest) */
        double T[2], N[2];
        contact_rest(M, tc, 0, T, N);
        v->groundT = T[0];
        v->groundN = N[0];
    } else {
        contact_one_block_terms(M, rocking ? y[1] : 0.0, v->alphaDD, &k, &v->groundT, &v->groundN);
    }
    double p[2][2];
    contact_momenta(M, S->mode, side, 0, y, p);
    v->momentum = p[0][0];
    M->s.massMoment = contact_mass_moment(M, S->mode, side, 0, y);
    v->interfaceT = v->interfaceN = 0.0;
    v->contactMode = mode == MODE_REST ? 0 : mode == MODE_OVERTURNED ? 4 : 2;
    contact_outputs(M, v);
}

void solver_outputs(Model *M, double tc) {
    Variables *v = &M->v;
    outputs_at(M, tc);
    if (!coupling_on(M)) support_motion(M, tc, model_piece(M, tc), &v->supportU, &v->supportV); /* (two-way: the engine's) */
    v->baseAh = ground_base_ah(M, tc);
    /* the last communication step's mean load, else the load on the ground at tc: -(rate of
     * change of the momentum relative to the ground) */
    double mass = v->mass + (v->nBlocks == 2 ? v->mass2 : 0.0);
    v->groundLoad = M->s.loadValid                ? M->s.loadMean
                    : M->s.mode == MODE_OVERTURNED ? 0.0
                                                   : -(v->groundT - mass * v->ahTotal);
    v->groundLoadSlope = M->s.loadValid ? M->s.loadSlope : 0.0;
}

void solver_log_pending(const Model *M, double tc, const Logger *log) {
    const State *S = &M->s;
    if (M->v.nBlocks == 2) return; /* a stack logs its events as it passes them */
    for (int i = 0; i < S->nStepPeaks; i++)
        if (S->stepPeakTime[i] <= tc)
            say(log, LOG_EVENTS, "peak t=%.17g theta=%.17g", S->stepPeakTime[i], S->stepPeakTheta[i]);
}

void solver_rollback(Model *M, double tc) {
    State *S = &M->s;
    S->fValid = 0; /* the derivative at (t, y) was for the old inputs */
    if (engine_on(M)) {
        engine_rollback(M, tc);
        return;
    }
    if (M->v.nBlocks == 2) {
        stack_rollback(M, tc);
        return;
    }
    if (S->mode != MODE_ROCKING || S->t <= tc || !S->denseValid) return;
    double s = (tc - S->tOld) / S->hDense, y[NMAX];
    if (s < 0) s = 0;
    if (s > 1) s = 1;
    memcpy(y, S->y, sizeof(y));
    dense_state(M, s, y);
    memcpy(S->y, y, sizeof(y));
    S->t = tc;
    S->side = S->denseSide;
    S->pending = EVENT_NONE;
    S->fValid = 0;
    S->denseValid = 0;
    keep_peaks_until(S, tc);
}

/* ------------------------------------------------------------ restored states */

/* The derivative at the state's time and values, as a step starting there takes it. */
static void state_rhs(const Model *M, double f[NMAX]) {
    const State *S = &M->s;
    if (M->v.nBlocks == 2) {
        stack_state_rhs(M, f);
        return;
    }
    RhsCtx c = rhs_context(M, S->t, S->side);
    rhs_cb(&c, S->t, S->y, f);
}

/* The last step taken again from its start (tOld, and the dense output at s = 0),
 * as take_step took it: its end values y1 and, for Dormand-Prince, its dense
 * output cont, for the Taylor series x. */
static void replay_step(const Model *M, double y1[NMAX], Dense *cont, double x[TAYLOR_MAX + 1]) {
    const State *S = &M->s;
    double f1[NMAX] = {0};
    if (M->v.nBlocks == 2) {
        stack_replay_step(M, y1, f1, cont);
        return;
    }
    int piece = model_piece(M, S->tOld);
    if (S->denseTaylor) {
        taylor_series(M, S->tOld, S->tay[0], S->tay[1], S->denseSide, piece, S->tayN, x);
        taylor_eval(x, S->tayN, S->hDense, &y1[0], &y1[1]);
        return;
    }
    RhsCtx c = rhs_context(M, S->tOld, S->denseSide);
    double y0[NMAX] = {0}, f0[NMAX] = {0}, err[NMAX];
    for (int i = 0; i < 2; i++) y0[i] = S->cont.r[0][i];
    rhs_cb(&c, S->tOld, y0, f0);
    dopri5_step(rhs_cb, &c, 2, S->tOld, y0, f0, S->hDense, y1, f1, err, cont);
}

#define FAIL(...)                      \
    do {                               \
        snprintf(msg, n, __VA_ARGS__); \
        return 1;                      \
    } while (0)

/* Angles may pass their geometric bounds by this much (rad): events are
 * located to the integrator's accuracy, and a Taylor step samples its series. */
#define ANGLE_SLACK 1e-3
/* Counts no run reaches (and whose increments could overflow). */
#define COUNT_MAX (INT_MAX / 2)
#define STEPS_MAX (1LL << 53)

/* Times the FMU keeps apart may still differ by this much: fmi2DoStep accepts
 * a communication point within 1e-9 (relative) of the FMU's time. */
static double slack(double t) { return 1e-9 * fmax(1.0, fabs(t)); }

static int within(double x, double lo, double hi) { return x >= lo && x <= hi; } /* false for NaN */
static int flag(int b) { return b == 0 || b == 1; }
static int sign(int s) { return s == 1 || s == -1; }

/* The first entry of x[0..count) that is not finite, or -1. */
static int not_finite(const double *x, int count) {
    for (int i = 0; i < count; i++)
        if (!isfinite(x[i])) return i;
    return -1;
}

/* Enumerations, flags and counts (every state). */
static int check_discrete(const Model *M, StateUse use, char *msg, size_t n) {
    const State *S = &M->s;
    const Variables *v = &M->v;
    int two = v->nBlocks == 2, taylor = taylor_on(M), mode = (int)S->mode, pending = (int)S->pending;
    /* (rocking-sliding, one block or a stack, is the engine's: engine_check_state) */
    if (two ? !(mode == MODE_REST || mode == MODE_OVERTURNED || mode == MODE_UPPER || mode == MODE_LOCKED ||
                mode == MODE_BOTH)
            : !(mode == MODE_ROCKING || mode == MODE_REST || mode == MODE_OVERTURNED))
        FAIL("pattern %d is not one of %s", mode,
             two ? "two blocks (1 rest, 2 overturned, 3 upper, 4 locked, 5 both)"
                 : "one block (0 rocking, 1 rest, 2 overturned)");
    int moving = two ? mode == MODE_UPPER || mode == MODE_LOCKED || mode == MODE_BOTH : mode == MODE_ROCKING;
    int lastEvent = two ? EVENT_OPEN : EVENT_OVERTURN;
    if (!(pending >= EVENT_NONE && pending <= lastEvent))
        FAIL("pending event %d is not one of %s", pending,
             two ? "0 to 5 (none, impact, overturn, interface, overturn2, open)" : "0 to 2 (none, impact, overturn)");
    /* rocking-sliding: slip direction and mode of the state and of the last step */
    if (S->sigma || S->denseSigma || S->denseMode || S->slideStarts)
        FAIL("sigma = %d, denseSigma = %d, denseMode = %d, slideStarts = %d belong to contact.model = 1 (0 here)",
             S->sigma, S->denseSigma, (int)S->denseMode, S->slideStarts);
    if (pending != EVENT_NONE && !moving) FAIL("event %d is pending, but nothing moves (pattern %d)", pending, mode);
    if (!flag(S->fValid) || !flag(S->denseValid) || !flag(S->denseTaylor))
        FAIL("flags fValid = %d, denseValid = %d, denseTaylor = %d must be 0 or 1", S->fValid, S->denseValid,
             S->denseTaylor);

    /* pivots: +1 right, -1 left; 0 only where one block has no second pivot, and before the first step */
    if (!sign(S->side)) FAIL("side = %d must be +1 or -1", S->side);
    if (two ? !sign(S->side2) : S->side2 != 0)
        FAIL("side2 = %d must be %s", S->side2, two ? "+1 or -1" : "0 for one block");
    if (!within(S->denseSide, -1, 1) || (S->denseValid && !sign(S->denseSide)))
        FAIL("denseSide = %d must be +1 or -1 (0 before the first step)", S->denseSide);
    if (two ? !within(S->denseSide2, -1, 1) || (S->denseValid && !sign(S->denseSide2)) : S->denseSide2 != 0)
        FAIL("denseSide2 = %d must be %s", S->denseSide2,
             two ? "+1 or -1 (0 before the first step)" : "0 for one block");
    if (mode == MODE_LOCKED && S->side2 != S->side)
        FAIL("a locked pair turns about one corner: side2 = %d must equal side = %d", S->side2, S->side);
    if (mode == MODE_UPPER && S->side != S->side2)
        FAIL("with block 1 flat, side = %d must follow side2 = %d", S->side, S->side2);

    /* the Taylor series of the last step: its order is the one solver.relTol gives */
    int order = taylor_order(v->relTol);
    if (taylor ? !(S->tayN == 0 || S->tayN == order) : S->tayN != 0)
        FAIL("tayN = %d must be %s", S->tayN,
             taylor ? "0 or the order solver.relTol gives" : "0 without the Taylor-series integrator");
    if (S->denseTaylor != (S->tayN != 0)) FAIL("denseTaylor = %d does not fit tayN = %d", S->denseTaylor, S->tayN);
    if (taylor && S->denseValid && !S->denseTaylor)
        FAIL("the dense output of a Taylor-series step must be its series");
    if (taylor && S->fValid) FAIL("the Taylor-series integrator keeps no derivative (fValid = 1)");

    /* peaks located in the last step (one block): Dormand-Prince finds up to MAX_STEP_PEAKS, Taylor 2 */
    int maxPeaks = two ? 0 : taylor ? 2 : MAX_STEP_PEAKS;
    if (!within(S->nStepPeaks, 0, maxPeaks)) FAIL("nStepPeaks = %d is outside [0, %d]", S->nStepPeaks, maxPeaks);
    if (S->nStepPeaks > 0 && mode != MODE_ROCKING)
        FAIL("%d peaks are pending, but the block does not rock", S->nStepPeaks);

    /* counters */
    if (!within(S->impacts, 0, COUNT_MAX) || !within(S->peaks, 0, COUNT_MAX) ||
        !within(S->impactsGround, 0, COUNT_MAX) || !within(S->impactsInterface, 0, COUNT_MAX))
        FAIL("counters impacts = %d, peaks = %d, impactsGround = %d, impactsInterface = %d must be in [0, %d]",
             S->impacts, S->peaks, S->impactsGround, S->impactsInterface, COUNT_MAX);
    if (!(S->steps >= 0 && S->steps <= STEPS_MAX && S->rejected >= 0 && S->rejected <= STEPS_MAX))
        FAIL("step counts %lld, %lld (rejected) must be in [0, 2^53]", S->steps, S->rejected);
    if (S->impacts > S->steps) FAIL("impacts = %d exceed the steps taken (%lld)", S->impacts, S->steps);
    if (S->peaks > MAX_STEP_PEAKS * S->steps) FAIL("peaks = %d exceed what %lld steps find", S->peaks, S->steps);
    if (two) {
        if (S->impacts != S->impactsGround + S->impactsInterface)
            FAIL("impacts = %d must be impactsGround + impactsInterface = %d + %d", S->impacts, S->impactsGround,
                 S->impactsInterface);
        if (S->peaks != 0) FAIL("peaks = %d: two blocks count none", S->peaks);
        if (!flag(S->overturned1) || !flag(S->overturned2) || (S->overturned1 && !S->overturned2))
            FAIL("overturned1 = %d, overturned2 = %d: flags 0 or 1, and block 1 takes block 2 with it", S->overturned1,
                 S->overturned2);
        if ((mode == MODE_OVERTURNED) != S->overturned2)
            FAIL("overturned2 = %d does not fit pattern %d", S->overturned2, mode);
        int maxSwitches = MAX_QUICK_SWITCHES + (use == STATE_INERT); /* a failed step counted one more */
        if (!within(S->quickSwitches, 0, maxSwitches))
            FAIL("quickSwitches = %d is outside [0, %d]", S->quickSwitches, maxSwitches);
    } else if (S->impactsGround || S->impactsInterface || S->overturned1 || S->overturned2 || S->quickSwitches) {
        FAIL("the two-block counters and flags must be 0 for one block");
    }

    /* outputs: booleans are checked by model_validate */
    if (v->impacts < 0 || v->peaks < 0 || v->impactsGround < 0 || v->impactsInterface < 0)
        FAIL("output counters impacts = %d, peaks = %d, impactsGround = %d, impactsInterface = %d must be >= 0",
             v->impacts, v->peaks, v->impactsGround, v->impactsInterface);
    if (!within(v->pattern, MODE_ROCKING, MODE_BOTH))
        FAIL("output pattern = %d is outside [0, %d]", v->pattern, MODE_BOTH);
    if (!within(v->contactMode, 0, 4) || v->slideStarts < 0)
        FAIL("output block1.mode = %d, block1.slides = %d are outside [0, 4] and [0, ...)", v->contactMode,
             v->slideStarts);

    /* initialised, not yet stepped */
    if (use == STATE_INITIAL && (S->steps || S->rejected || S->impacts || S->peaks || S->nStepPeaks || S->denseValid ||
                                 S->tayN || pending != EVENT_NONE || S->quickSwitches))
        FAIL("a state in initialization mode has taken no step (%lld steps, %d impacts)", S->steps, S->impacts);
    return 0;
}

/* All bits 0 (not -0.0): what the solver never wrote. */
static int zero_bits(double x) { return x == 0 && !signbit(x); }

/* Numbers of a state that steps (or is about to): finite, and where a run leaves them. */
static int check_numbers(const Model *M, double t0, double tc, StateUse use, char *msg, size_t n) {
    const State *S = &M->s;
    /* (rocking-sliding is the engine's: engine_check_state) */
    int two = M->v.nBlocks == 2, mode = (int)S->mode, ny = two ? 4 : 2;
    int moving = two ? mode == MODE_UPPER || mode == MODE_LOCKED || mode == MODE_BOTH
                     : mode == MODE_ROCKING || mode == MODE_SLIDE;
    const struct {
        const char *name;
        const double *x;
        int count;
    } numbers[] = {
        {"t", &S->t, 1}, {"y", S->y, NMAX}, {"f", S->f, NMAX}, {"h", &S->h, 1}, {"tOld", &S->tOld, 1},
        {"hDense", &S->hDense, 1}, {"cont", S->cont.r[0], DENSE_ROWS * NMAX},
        {"tay", S->tay, TAYLOR_MAX + 1}, {"stepPeakTime", S->stepPeakTime, MAX_STEP_PEAKS},
        {"stepPeakTheta", S->stepPeakTheta, MAX_STEP_PEAKS}, {"lastImpactTime", &S->lastImpactTime, 1},
        {"lastPeakTime", &S->lastPeakTime, 1}, {"lastPeakTheta", &S->lastPeakTheta, 1},
        {"maxAbsTheta", &S->maxAbsTheta, 1}, {"overturnTime", &S->overturnTime, 1}, {"restTime", &S->restTime, 1},
        {"maxAbsTheta2", &S->maxAbsTheta2, 1}, {"maxPrev", &S->maxPrev, 1}, {"maxPrev2", &S->maxPrev2, 1},
        {"monT", &S->monT, 1}, {"monTr", S->monTr, 2}, {"monN", S->monN, 2}, {"demandMax", S->demandMax, 2},
        {"normalMin", S->normalMin, 2}, {"slideTime", &S->slideTime, 1}, {"liftTime", &S->liftTime, 1},
        {"impulseDemandMax", &S->impulseDemandMax, 1}, {"endTr", &S->endTr, 1}, {"endN", &S->endN, 1},
        {"withinTime", &S->withinTime, 1}, {"maxAbsSlip", &S->maxAbsSlip, 1}, {"slideSince", &S->slideSince, 1},
        {"slideDur", &S->slideDur, 1}, {"impactLoss", &S->impactLoss, 1},
    };
    for (size_t k = 0; k < sizeof(numbers) / sizeof(numbers[0]); k++) {
        int i = not_finite(numbers[k].x, numbers[k].count);
        if (i >= 0) FAIL("%s[%d] = %g is not a finite number", numbers[k].name, i, numbers[k].x[i]);
    }
    if (!(S->cont.method == RK_DOPRI5 && (S->cont.rows == 5 || S->cont.rows == 0)))
        FAIL("the last step's dense output (method %d, %d rows) is not DOPRI5's (5 rows, or none yet)", S->cont.method,
             S->cont.rows);
    /* what a solver never writes keeps the zeros model_initialize gave it */
    if (two) {
        if (!isfinite(S->lastSwitchTime) && S->lastSwitchTime != -INFINITY)
            FAIL("lastSwitchTime = %g must be a time (-inf before the first pattern change)", S->lastSwitchTime);
        for (int i = 0; i < MAX_STEP_PEAKS; i++)
            if (!zero_bits(S->stepPeakTime[i]) || !zero_bits(S->stepPeakTheta[i]))
                FAIL("two blocks locate no peaks: stepPeak %d must be 0", i);
    } else {
        int taylor = taylor_on(M); /* the Taylor-series integrator keeps neither f nor cont */
        for (int i = 0; i < NMAX; i++) {
            int unused = i >= ny || taylor;
            int used = unused && (!zero_bits(S->f[i]) || (i >= ny && !zero_bits(S->y[i])));
            for (int k = 0; k < DENSE_ROWS; k++) used |= unused && !zero_bits(S->cont.r[k][i]);
            if (used)
                FAIL("component %d of y, f or the dense output is unused%s and must be 0", i,
                     taylor ? " (Taylor series)" : "");
        }
        if (!zero_bits(S->maxAbsTheta2) || !zero_bits(S->maxPrev) || !zero_bits(S->maxPrev2) ||
            !zero_bits(S->lastSwitchTime))
            FAIL("the two-block quantities must be 0 for one block");
    }
    if (!zero_bits(S->maxAbsSlip) || !zero_bits(S->slideSince) || !zero_bits(S->slideDur) ||
        !zero_bits(S->impactLoss))
        FAIL("the rocking-sliding quantities must be 0 with contact.model = 0");
    for (int k = 0; k <= TAYLOR_MAX; k++)
        if ((S->tayN == 0 || k > S->tayN) && !zero_bits(S->tay[k]))
            FAIL("tay[%d] = %g lies beyond the series' order %d and must be 0", k, S->tay[k], S->tayN);

    /* times: the integrator may run ahead of tc by the step that covers tc, never fall behind */
    if (!(S->t >= tc - slack(tc))) FAIL("t = %.17g lies before the communication point %.17g", S->t, tc);
    if (use == STATE_INITIAL && S->t != tc)
        FAIL("t = %.17g must be the start time %.17g in initialization mode", S->t, tc);
    if (!(S->h >= 0)) FAIL("the proposed step h = %g must be >= 0", S->h);
    if (S->denseValid) {
        if (!(S->hDense > 0)) FAIL("the last step's length %g must be > 0", S->hDense);
        if (!(fabs(S->tOld + S->hDense - S->t) <= slack(S->t)))
            FAIL("the last step [%.17g, + %.17g] does not end at t = %.17g", S->tOld, S->hDense, S->t);
        if (!(S->tOld <= tc + slack(tc)))
            FAIL("the last step starts at %.17g, after the communication point %.17g", S->tOld, tc);
    }
    if (S->t > tc + slack(tc) && !(moving && S->denseValid))
        FAIL("t = %.17g is ahead of the communication point %.17g without a step that covers it", S->t, tc);
    if (!moving && !(fabs(S->t - tc) <= slack(tc)))
        FAIL("at rest or overturned, t = %.17g must be the communication point %.17g", S->t, tc);
    if (S->pending != EVENT_NONE && !(S->t > tc))
        FAIL("an event is pending at t = %.17g, not after the communication point %.17g", S->t, tc);
    double lo = t0 - slack(t0), hi = S->t + slack(S->t);
    if (S->impactRun < 0 || S->impactRun > S->impacts)
        FAIL("impactRun = %d must lie in [0, impacts = %d]", S->impactRun, S->impacts);
    if (S->impacts == 0 ? S->lastImpactTime != -1 : !within(S->lastImpactTime, lo, hi))
        FAIL("lastImpactTime = %.17g does not fit %d impacts (-1 before the first, else a time in [start, t])",
             S->lastImpactTime, S->impacts);
    if (S->peaks == 0 ? S->lastPeakTime != -1 || S->lastPeakTheta != 0 : !within(S->lastPeakTime, lo, hi))
        FAIL("lastPeakTime = %.17g, lastPeakTheta = %g do not fit %d peaks", S->lastPeakTime, S->lastPeakTheta,
             S->peaks);
    if (mode == MODE_OVERTURNED ? !within(S->overturnTime, lo, hi) : S->overturnTime != -1)
        FAIL("overturnTime = %.17g does not fit pattern %d", S->overturnTime, mode);
    if (S->restTime != -1 && !within(S->restTime, lo, hi))
        FAIL("restTime = %.17g is not a time in [start, t]", S->restTime);
    if (!flag(S->monValid) || !flag(S->endValid))
        FAIL("monValid = %d, endValid = %d must be 0 or 1", S->monValid, S->endValid);
    if (S->endValid) { /* the reactions kept for the state must be the state's: recomputed, to the bit */
        double T[2], N[2];
        RhsTerms k;
        double dy[2];
        if (two || mode != MODE_ROCKING || !S->fValid)
            FAIL("endValid = 1 belongs to a moving block at the end of a step");
        model_rhs_terms(M, S->t, S->y, S->side, model_piece(M, S->t), dy, &k);
        contact_one_block_terms(M, S->y[1], S->f[1], &k, &T[0], &N[0]);
        if (T[0] != S->endTr || N[0] != S->endN)
            FAIL("the stored contact reactions (%g, %g) are not those of the state (%g, %g)", S->endTr, S->endN,
                 T[0], N[0]);
    }
    if (S->monValid && !within(S->monT, lo, hi)) FAIL("monT = %.17g is not a time in [start, t]", S->monT);
    if (S->slideTime != -1 && !within(S->slideTime, lo, hi))
        FAIL("slideTime = %.17g is not a time in [start, t] (or -1)", S->slideTime);
    if (S->liftTime != -1 && !within(S->liftTime, lo, hi))
        FAIL("liftTime = %.17g is not a time in [start, t] (or -1)", S->liftTime);
    if (!within(S->withinTime, lo, hi) || (S->monValid && S->withinTime > S->monT))
        FAIL("withinTime = %.17g is not the start or a sample time in [start, monT]", S->withinTime);
    if (!(S->demandMax[0] >= 0 && S->demandMax[1] >= 0 && S->impulseDemandMax >= 0))
        FAIL("the friction demands must be >= 0");
    if (two && S->lastSwitchTime != -INFINITY && !within(S->lastSwitchTime, lo, hi))
        FAIL("lastSwitchTime = %.17g is not a time in [start, t]", S->lastSwitchTime);
    for (int i = 0; i < S->nStepPeaks; i++)
        if (!within(S->stepPeakTime[i], S->tOld - slack(S->tOld), hi))
            FAIL("pending peak %d at %.17g lies outside the last step [%.17g, %.17g]", i, S->stepPeakTime[i],
                 S->tOld, S->t);

    /* angles: block 1 within a quarter turn of upright, block 2 within a quarter turn of block 1 */
    double quarter = M_PI / 2 + ANGLE_SLACK;
    if (!(fabs(S->y[0]) <= quarter)) FAIL("block 1's angle %g lies beyond pi/2", S->y[0]);
    if (two && !(fabs(S->y[2] - S->y[0]) <= quarter))
        FAIL("block 2's angle %g lies beyond pi/2 from block 1's %g", S->y[2], S->y[0]);
    for (int i = 0; i < S->nStepPeaks; i++)
        if (!(fabs(S->stepPeakTheta[i]) <= quarter))
            FAIL("pending peak %d at angle %g lies beyond pi/2", i, S->stepPeakTheta[i]);
    if (!(fabs(S->lastPeakTheta) <= quarter)) FAIL("lastPeakTheta = %g lies beyond pi/2", S->lastPeakTheta);
    if (!within(S->maxAbsTheta, two ? 0 : fabs(S->lastPeakTheta), quarter))
        FAIL("maxAbsTheta = %g is outside [|lastPeakTheta|, pi/2]", S->maxAbsTheta);
    if (two && !(within(S->maxAbsTheta2, 0, 2 * quarter) && within(S->maxPrev, 0, S->maxAbsTheta) &&
                 within(S->maxPrev2, 0, S->maxAbsTheta2)))
        FAIL("maxAbsTheta2 = %g, maxPrev = %g, maxPrev2 = %g do not fit maxAbsTheta = %g", S->maxAbsTheta2, S->maxPrev,
             S->maxPrev2, S->maxAbsTheta);

    /* rates: a million times the blocks' own frequency sqrt(g / R) is no rocking (and keeps
     * the energy finite) */
    const Derived *d = &M->d;
    double rateMax = 1e6 * sqrt(M->v.g / (two ? fmin(d->R, fmin(d->RI, d->RL)) : d->R));
    for (int i = 1; i < ny; i += 2)
        if (!(fabs(S->y[i]) <= rateMax)) FAIL("rate y[%d] = %g exceeds %g rad/s", i, S->y[i], rateMax);

    /* the derivative kept for the next step is the one at (t, y) (only a moving state steps) */
    if (S->fValid && moving) {
        double f[NMAX] = {0};
        state_rhs(M, f);
        if (memcmp(f, S->f, ny * sizeof(double)) != 0)
            FAIL("the derivative kept at t = %.17g is not the one there", S->t);
    }
    /* Once the integrator has run ahead of tc, outputs come from the last step's dense output
     * (no event applied since): taken again from the step's start, the step must give the same
     * dense output and end values (an angle an event set to its target excepted) */
    if (moving && S->denseValid && S->t > tc) {
        double y1[NMAX] = {0}, x[TAYLOR_MAX + 1] = {0};
        Dense cont = {0};
        if (S->denseSide != S->side || S->denseSide2 != S->side2)
            FAIL("the pivots of the last step (%d, %d) are not the current ones (%d, %d)", S->denseSide, S->denseSide2,
                 S->side, S->side2);
        replay_step(M, y1, &cont, x);
        if (S->denseTaylor ? memcmp(x, S->tay, sizeof(x)) != 0 : memcmp(&cont, &S->cont, sizeof(cont)) != 0)
            FAIL("the last step's dense output is not the one its start (t = %.17g) gives", S->tOld);
        for (int i = 0; i < ny; i++) {
            int angle = i % 2 == 0;
            if (angle && S->pending != EVENT_NONE ? !(fabs(S->y[i] - y1[i]) <= ANGLE_SLACK) : S->y[i] != y1[i])
                FAIL("y[%d] = %.17g is not where the last step ends (%.17g)", i, S->y[i], y1[i]);
        }
    }

    /* what each pattern holds fixed */
    switch (mode) {
    case MODE_REST:
        for (int i = 0; i < ny; i++)
            if (S->y[i] != 0)
                FAIL("at rest every angle and rate is 0, not y[%d] = %g", i, S->y[i]);
        break;
    case MODE_SLIDE: /* one block flat; a stack: some contact slides (ss_check_state) */
        if (!two && (S->y[0] != 0 || S->y[1] != 0)) FAIL("a sliding block lies flat (y = %g, %g)", S->y[0], S->y[1]);
        break;
    case MODE_OVERTURNED: /* (a rocking-sliding stack's run ended by a fall-off or flight keeps its last state) */

        if (two ? S->y[1] != 0 || S->y[3] != 0 : S->y[1] != 0 || S->y[0] != S->side * M_PI / 2)
            FAIL("an overturned block lies still on its side (y = %g, %g)", S->y[0], S->y[1]);
        break;
    case MODE_UPPER:
        if (S->y[0] != 0 || S->y[1] != 0)
            FAIL("block 1 lies flat while block 2 rocks alone (y = %g, %g)", S->y[0], S->y[1]);
        break;
    case MODE_LOCKED: /* an event located at t set block 1's angle to its target, not yet block 2's */
        if (S->y[3] != S->y[1] ||
            (S->pending == EVENT_NONE ? S->y[2] != S->y[0] : !(fabs(S->y[2] - S->y[0]) <= ANGLE_SLACK)))
            FAIL("a locked pair moves as one body (y = %g, %g, %g, %g)", S->y[0], S->y[1], S->y[2], S->y[3]);
        break;
    default:
        break;
    }
    return 0;
}

/* The inputs' derivatives of a restored state (every model's): finite, and only those instance_set_real_derivative
 * takes. */
static int check_inputs(const Model *M, char *msg, size_t n) {
    const State *S = &M->s;
    int moves = 0;
    for (int i = 0; i < MODEL_INPUTS; i++) {
        if (!isfinite(S->inD[i][0]) || !isfinite(S->inD[i][1]) || !isfinite(S->inT0[i]))
            FAIL("input %d's derivatives (%g, %g from t = %g) are not finite numbers", i, S->inD[i][0], S->inD[i][1],
                 S->inT0[i]);
        moves |= S->inD[i][0] != 0.0 || S->inD[i][1] != 0.0;
    }
    if ((S->inD[2][0] != 0.0 || S->inD[2][1] != 0.0) && !coupling_on(M))
        FAIL("derivatives of support.force off a two-way support, which the FMU does not take");
    if (S->inD[1][1] != 0.0 || (S->inD[0][1] != 0.0 && M->v.supportKind != 0))
        FAIL("a second derivative of ground.av, or on a support, which the FMU does not take");
    if (moves && M->v.kind != KIND_NONE && M->v.kind != KIND_RECORD)
        FAIL("input derivatives with a built-in waveform excitation (kind %d), which the FMU does not take", M->v.kind);
    return 0;
}

int state_validate(const Model *M, double t0, double tc, StateUse use, char *msg, size_t n) {
    if (check_inputs(M, msg, n)) return 1;
    if (engine_on(M)) return engine_check_state(M, msg, n);
    if (check_discrete(M, use, msg, n)) return 1;
    if (use == STATE_INERT) return 0;
    if (check_numbers(M, t0, tc, use, msg, n)) return 1;
    /* the outputs are those of the state at tc, but for the ones that follow the inputs at
     * once (set after the outputs were written) */
    Model out = *M;
    solver_outputs(&out, tc);
    out.v.alphaDD = M->v.alphaDD;
    out.v.alphaDD2 = M->v.alphaDD2;
    out.v.ahTotal = M->v.ahTotal;
    out.v.avTotal = M->v.avTotal;
    if (!(M->s.loadValid == 0 || M->s.loadValid == 1) || !isfinite(M->s.loadMean) || !isfinite(M->s.loadSlope) ||
        !isfinite(M->s.massMoment))
        FAIL("the last step's mean load (valid %d) = %g, its slope %g or the mass moment %g is not a number",
             M->s.loadValid, M->s.loadMean, M->s.loadSlope, M->s.massMoment);
#define VAR(T, vr, field, name, caus, var, start, unit, desc)         \
    if (memcmp(&out.v.field, &M->v.field, sizeof(out.v.field)) != 0) \
        FAIL("%s is not what the state gives at t = %.17g", name, tc);
#include "variables.def"
#undef VAR
    return 0;
}
#undef FAIL
