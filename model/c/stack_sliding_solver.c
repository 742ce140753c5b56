/* Event-driven time stepping of the rocking-sliding stack (stack_sliding.h,
 * docs/stack_sliding.md, "Transitions"). The same event loop as every model
 * (advance_to), the same integrator and event location (events.c). */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "contact.h"
#include "events.h"
#include "ground.h"
#include "integrator.h"
#include "stack.h"
#include "stack_sliding.h"
#include "stack_solver.h"

#define TOL_OPEN 1e-9      /* a flat contact opens once an end margin falls below -TOL_OPEN */
#define TOL_FRICTION 1e-12 /* a sticking contact slips once (mu N - |T|) / W falls below -TOL_FRICTION */
#define EDGE_EPS 1e-12     /* m: block 2's pivot falls off once this far beyond block 1's edge */
#define SLIP_EPS 1e-15     /* m/s: a slip stops where sigma u' + SLIP_EPS falls through 0 (so that a slip just
                            * started from rest that runs against its direction stops at once) */
#define FORCE_SAMPLES 4    /* samples per step of the force indicators on the dense output */
#define ZENO_DT 1e-9       /* s (relative to the time): impacts closer than this accumulate */
#define ZENO_MAX 32        /* accumulating impacts after which the landing contact closes */
#define FAST_OPEN_SAMPLES 8 /* rigid patterns: samples per step of the end margins, as the rigid stack's */

/* The integrator's context. While nothing slides and block 2 sits at its rest offset on block 1
 * (u2 = 0), the pattern is one of the rigid stack's: its closed-form equations (stack.h) integrate
 * theta1, omega1, theta2, omega2 and the ground's work (FAST_N components, the rigid stack's error
 * control), and the slips stay put. */
#define FAST_N 5
typedef struct {
    const Model *M;
    StackPattern p;
    int piece;
    int fast;
    Mode mode;
    int s1, s2;
} SCtx;

static Mode mode_of(const StackPattern *p);

static SCtx context(const Model *M, const StackPattern *p, double t, const double *y) {
    SCtx c = {M, *p, model_piece(M, t), !p->g.sigma && !p->i.sigma && y[SS_U2] == 0.0, mode_of(p), p->g.s, p->i.s};
    if (c.mode == MODE_LOCKED) c.s2 = c.s1; /* the irrelevant pivot follows the relevant one */
    if (c.mode == MODE_UPPER) c.s1 = c.s2;
    return c;
}

static void rhs_cb(const void *ctx, double t, const double *y, double *dy) {
    const SCtx *c = ctx;
    if (c->fast) stack_rhs_work(c->M, c->mode, c->s1, c->s2, t, y, c->piece, dy);
    else ss_rhs(c->M, &c->p, t, y, c->piece, dy, NULL);
}

/* The components a step integrates. */
static int components(const SCtx *c) { return c->fast ? FAST_N : SS_N; }

static Mode mode_of(const StackPattern *p) {
    if (ss_is_rest(p)) return MODE_REST;
    if (p->g.sigma || p->i.sigma) return MODE_SLIDE;
    return p->g.flat ? MODE_UPPER : p->i.flat ? MODE_LOCKED : MODE_BOTH;
}

static const char *contact_name(int c) { return c == 0 ? "ground" : "interface"; }

/* Bookkeeping of the slide phases when the pattern changes at S->t. */
static void set_pattern(Model *M, const StackPattern *p, const Logger *log) {
    State *S = &M->s;
    const StackPattern *o = &S->pat;
    char buf[40];
    for (int c = 0; c < 2; c++) {
        int was = c == 0 ? o->g.sigma : o->i.sigma, now = c == 0 ? p->g.sigma : p->i.sigma;
        int *starts = c == 0 ? &S->slideStarts : &S->slideStarts2;
        double *since = c == 0 ? &S->slideSince : &S->slideSince2, *dur = c == 0 ? &S->slideDur : &S->slideDur2;
        double *first = c == 0 ? &S->slideStartTime1 : &S->slideStartTime2;
        if (!was && now) {
            (*starts)++;
            *since = S->t;
            if (*first < 0) *first = S->t;
            if (S->slideTime < 0) S->slideTime = S->t;
            say(log, LOG_EVENTS, "slide t=%.17g contact=%s sigma=%d mode=%s pattern=%s", S->t, contact_name(c), now,
                (c == 0 ? p->g.flat : p->i.flat) ? "slide" : "slide-rock", ss_label(p, buf));
        } else if (was && !now) {
            *dur += S->t - *since;
            say(log, LOG_EVENTS, "stick t=%.17g contact=%s pattern=%s", S->t, contact_name(c), ss_label(p, buf));
        } else if (was && now && was != now) {
            *dur += S->t - *since;
            *since = S->t;
            say(log, LOG_EVENTS, "reverse t=%.17g contact=%s sigma=%d pattern=%s", S->t, contact_name(c), now,
                ss_label(p, buf));
        }
    }
    S->pat = *p;
    S->mode = mode_of(p);
    S->side = p->g.s;
    S->side2 = p->i.s;
    S->sigma = p->g.sigma;
    S->fValid = 0;
    if (S->mode == MODE_REST) { /* both contacts closed: nothing moves relative to the ground */
        S->y[0] = S->y[1] = S->y[2] = S->y[3] = S->y[SS_V1] = S->y[SS_V2] = 0.0;
    }
}

/* The run ends here: overturn (block 1, or block 2 alone), block 2 fell off, or flight. */
static void finish(Model *M, EventKind why, const Logger *log) {
    State *S = &M->s;
    if (S->pat.g.sigma) S->slideDur += S->t - S->slideSince;
    if (S->pat.i.sigma) S->slideDur2 += S->t - S->slideSince2;
    S->pat.g.sigma = S->pat.i.sigma = 0;
    S->sigma = 0;
    S->mode = MODE_OVERTURNED; /* the run has ended: the state stays as it was at its end */
    if (why == EVENT_OVERTURN || why == EVENT_OVERTURN2) {
        S->y[1] = S->y[3] = S->y[SS_V1] = S->y[SS_V2] = 0.0; /* lying on its side */
        S->overturned2 = 1;
        if (why == EVENT_OVERTURN) S->overturned1 = 1;
        S->overturnTime = S->t;
        say(log, LOG_EVENTS, "overturn t=%.17g blocks=%s", S->t, S->overturned1 ? "1+2" : "2");
    } else if (why == EVENT_FELL_OFF) {
        S->fellOff = 1;
        S->fellOffTime = S->t;
        say(log, LOG_EVENTS, "fell-off t=%.17g u2=%.17g", S->t, S->y[SS_U2]);
    } else {
        if (S->liftTime < 0) S->liftTime = S->t;
        say(log, LOG_EVENTS, "flight t=%.17g reason=no-consistent-pattern", S->t); /* a contact would pull: the run ends */
    }
}

/* No consistent pattern after an event: block 2 falls off if turning about its corner beyond
 * block 1's edge would be consistent, otherwise a contact would have to pull (flight). */
static void no_pattern(Model *M, const double q[4], const double w[4], const int exclude[2], const Logger *log) {
    StackPattern p;
    if (ss_select(M, M->s.t, q, w, exclude, 1, 1, &p) && !p.i.flat) finish(M, EVENT_FELL_OFF, log);
    else finish(M, EVENT_NONE, log);
}

/* Choose the pattern at S->t from the state (with exclusions); 0 if none (the run ended). */
static int choose(Model *M, const int exclude[2], const Logger *log) {
    double q[4], w[4];
    StackPattern p;
    ss_qw(M->s.y, q, w);
    if (!ss_select(M, M->s.t, q, w, exclude, 1, 0, &p)) {
        no_pattern(M, q, w, exclude, log);
        return 0;
    }
    set_pattern(M, &p, log);
    return 1;
}

void ss_initialize(Model *M) {
    State *S = &M->s;
    const Variables *v = &M->v;
    memset(S->y, 0, sizeof(S->y));
    S->y[0] = v->theta0;
    S->y[1] = v->omega0;
    S->y[2] = v->theta02;
    S->y[3] = v->omega02;
    S->maxAbsTheta = fabs(S->y[0]);
    S->maxAbsTheta2 = fabs(S->y[2]);
    S->maxPrev = S->maxAbsTheta;
    S->maxPrev2 = S->maxAbsTheta2;
    S->lastSwitchTime = -INFINITY;
    S->slideStartTime1 = S->slideStartTime2 = S->fellOffTime = -1.0;
    S->maxAbsSlip = S->maxAbsSlip2 = S->slideDur = S->slideDur2 = S->impactLoss = 0.0;
    S->slideStarts = S->slideStarts2 = S->fellOff = 0;
    S->eventContact = 0;
    S->eventEnd = 1;
    StackPattern rest = {{1, 1, 0}, {1, 1, 0}};
    S->pat = S->densePat = rest;
    double q[4], w[4];
    StackPattern p;
    ss_qw(S->y, q, w);
    if (q[1] == 0 && q[3] == 0 && w[1] == 0 && w[3] == 0) { /* at rest: the rest search starts it */
        S->mode = MODE_REST;
        S->side = S->side2 = 1;
    } else if (ss_select(M, S->t, q, w, NULL, 1, 0, &p)) {
        S->pat = p;
        S->mode = mode_of(&p);
        S->side = p.g.s;
        S->side2 = p.i.s;
        S->sigma = p.g.sigma;
        if (p.g.sigma) S->slideStarts = 1, S->slideSince = S->slideStartTime1 = S->slideTime = S->t;
        if (p.i.sigma) S->slideStarts2 = 1, S->slideSince2 = S->slideStartTime2 = S->slideTime = S->t;
    } else { /* no consistent pattern at the start: flight (outside the model), the run ends there */
        finish(M, EVENT_FLIGHT, NULL);
    }
    S->densePat = S->pat;
}

/* The ground moves the stack at rest at time t: the pattern that starts is chosen as at any event
 * (its corners and slip signs among the candidates, so the side find_uplift reports is not needed).
 * A contact that opens is an uplift; a contact that starts to slide is logged as a slide by
 * set_pattern, so a stack that only slides logs no uplift. */
static void start_moving(Model *M, double t, int side, const Logger *log) {
    State *S = &M->s;
    double q[4] = {0}, w[4] = {0};
    StackPattern p;
    (void)side;
    S->t = t;
    S->h = 0.0;
    S->denseValid = 0;
    if (!ss_select(M, t, q, w, NULL, 0, 0, &p)) {
        no_pattern(M, q, w, NULL, log);
        return;
    }
    char buf[40];
    if (!p.g.flat || !p.i.flat) say(log, LOG_EVENTS, "uplift t=%.17g pattern=%s", t, ss_label(&p, buf));
    set_pattern(M, &p, log);
}

/* ------------------------------------------------------------------ impacts */

static void apply_impact(Model *M, int landing, const Logger *log) {
    State *S = &M->s;
    double q[4], w[4], wp[4], P[6], ah, av;
    StackPattern pat = S->pat, after;
    char buf[40];
    if (landing == 0) {
        S->y[0] = 0.0;
        if (pat.i.flat) S->y[2] = 0.0;
    } else {
        S->y[2] = S->y[0];
    }
    ss_qw(S->y, q, w);
    double keMinus = ss_kinetic(M, q, w, pat.g.s, pat.i.s);
    int r = ss_impact(M, landing, &pat, q, w, &after, wp, P);
    /* impacts that accumulate (each within ZENO_DT of the one before, at the same contact) */
    S->zenoCount = S->t - S->lastImpactTime <= ZENO_DT * fmax(1.0, fabs(S->t)) && S->zenoContact == landing
                       ? S->zenoCount + 1
                       : 0;
    S->zenoContact = landing;
    if (landing == 0) S->impactsGround++;
    else S->impactsInterface++;
    S->impacts++;
    S->lastImpactTime = S->t;
    if (!r) {
        say(log, LOG_EVENTS, "impact t=%.17g contact=%s inconsistent", S->t, contact_name(landing));
        finish(M, EVENT_NONE, log);
        return;
    }
    say(log, LOG_EVENTS,
        "impact t=%.17g contact=%s theta1=%.17g theta2=%.17g w1m=%.17g w2m=%.17g w1p=%.17g w2p=%.17g "
        "slip_rate_minus=%.17g,%.17g slip_rate_plus=%.17g,%.17g to=%s%s",
        S->t, contact_name(landing), q[1], q[3], w[1], w[3], wp[1], wp[3], w[0], w[2], wp[0], wp[2],
        ss_label(&after, buf), r == 2 ? " held" : "");
    /* settling: contacts at zero gap whose rebound is negligible close (both, then the landing one,
     * then the other), if the pattern chosen there keeps them flat */
    model_ground(M, S->t, &ah, &av);
    int qualifies[2] = {0, 0};
    for (int c = 0; c < 2; c++) {
        const ContactKind *m = c == 0 ? &after.g : &after.i;
        double gap = c == 0 ? q[1] : q[3] - q[1], rate = c == 0 ? wp[1] : wp[3] - wp[1];
        qualifies[c] = !m->flat && gap == 0.0 && fabs(rate) < ss_settle_rate(M, c, av);
    }
    int order[3], no = 0;
    if (qualifies[0] && qualifies[1]) order[no++] = 3;
    if (qualifies[landing]) order[no++] = 1 << landing;
    if (qualifies[1 - landing]) order[no++] = 1 << (1 - landing);
    for (int k = 0; k < no; k++) {
        StackPattern closed, chosen;
        double wc[4];
        ss_close(M, &after, q, wp, order[k], &closed, wc);
        /* a sliding contact's friction impulse can push the slip it opposed the other way: a closing
         * that would add kinetic energy is no settling */
        if (ss_kinetic(M, q, wc, closed.g.s, closed.i.s) > ss_kinetic(M, q, wp, after.g.s, after.i.s)) continue;
        if (!ss_select(M, S->t, q, wc, NULL, 1, 0, &chosen)) continue;
        if ((!(order[k] & 1) || chosen.g.flat) && (!(order[k] & 2) || chosen.i.flat)) {
            memcpy(wp, wc, sizeof(wc));
            after = closed;
            say(log, LOG_EVENTS, "settle t=%.17g contact=%s pattern=%s", S->t,
                order[k] == 3 ? "ground+interface" : contact_name(order[k] == 1 ? 0 : 1), ss_label(&chosen, buf));
            break;
        }
    }
    int exclude[2] = {0, 0};
    if (S->zenoCount >= ZENO_MAX && !(landing == 0 ? after.g.flat : after.i.flat)) {
        /* the impacts accumulate without the rebound settling (a sliding contact's landings): the
         * landing contact closes, its friction mode kept, and stays flat */
        StackPattern closed;
        double wc[4];
        ss_close(M, &after, q, wp, 1 << landing, &closed, wc);
        S->zenoCount = 0;
        if (ss_kinetic(M, q, wc, closed.g.s, closed.i.s) > ss_kinetic(M, q, wp, after.g.s, after.i.s)) {
            /* no closing without a gain: no consistent motion follows (outside the model) */
            say(log, LOG_EVENTS, "impacts accumulate t=%.17g contact=%s: no consistent motion", S->t,
                contact_name(landing));
            finish(M, EVENT_FLIGHT, log);
            return;
        }
        memcpy(wp, wc, sizeof(wc));
        after = closed;
        exclude[landing] = SS_NOT_ROCK; /* the pattern chosen keeps it flat, or none: flight */
        say(log, LOG_EVENTS, "settle t=%.17g contact=%s reason=impacts-accumulate", S->t, contact_name(landing));
    }
    S->impactLoss += keMinus - ss_kinetic(M, q, wp, after.g.s, after.i.s);
    S->y[1] = wp[1], S->y[3] = wp[3], S->y[SS_V1] = wp[0], S->y[SS_V2] = wp[2];
    S->pat.g.s = after.g.s, S->pat.i.s = after.i.s; /* the rates refer to these pivots */
    if (choose(M, exclude, log) && M->s.mode == MODE_REST) M->s.restTime = M->s.t;
}

/* ------------------------------------------------------------------ events */

/* Which force indicators: flat contacts' end margins, sticking contacts' friction margins. */
#define IND_MARGINS 1
#define IND_FRICTION 2
#define IND_ALL 3

/* The indicators that the contact forces give: normal force over the weight carried (flight where a
 * rocking contact's turns tensile: the run ends, as in the reference; a held contact's friction would
 * push its slip) and, where a contact sticks, its friction margin. */
static void pressure_indicators(const Model *M, const StackPattern *p, double T0, double N0, double T1, double N1,
                                double ind[SS_IND]) {
    const Variables *v = &M->v;
    ind[0] = p->g.flat ? INFINITY : N0 / M->d.weight[0];
    ind[1] = p->i.flat ? INFINITY : N1 / M->d.weight[1];
    ind[6] = p->g.sigma ? INFINITY : (v->muGround * N0 - fabs(T0)) / M->d.weight[0];
    ind[7] = p->i.sigma ? INFINITY : (v->muInterface * N1 - fabs(T1)) / M->d.weight[1];
}

/* The force indicators `what` of a rigid pattern (SCtx.fast) from the rigid stack's closed forms:
 * its end margins (stack_margins) and the friction margins of its reactions (contact_stack) with
 * the accelerations acc (NULL: computed). */
static void fast_indicators(const SCtx *c, const double *y, double ah, double av, int what, const double *acc,
                            double ind[SS_IND]) {
    const Model *M = c->M;
    double g[2], in[2], a[2], T0, N0, T1, N1;
    for (int i = 0; i < SS_IND; i++) ind[i] = INFINITY;
    if (what & IND_MARGINS) {
        stack_margins(M, c->mode, c->s1, c->s2, y, ah, av, g, in);
        ind[2] = g[0], ind[3] = g[1], ind[4] = in[0], ind[5] = in[1];
    }
    if (what & IND_FRICTION) {
        if (acc) a[0] = acc[0], a[1] = acc[1];
        else stack_accel(M, c->mode, c->s1, c->s2, y, ah, av, a);
        contact_stack(M, c->mode, c->s1, c->s2, y, a, ah, av, &T0, &N0, &T1, &N1);
        pressure_indicators(c->M, &c->p, T0, N0, T1, N1, ind);
    }
}

/* The contact whose force indicator (of those `what`) is the least at (t, y): writes which (0
 * ground, 1 interface) and the kind of event (EVENT_OPEN with end +1/-1, or EVENT_SLIP_START).
 * acc: the rigid pattern's accelerations at (t, y) if known (else NULL). */
static double weakest(const SCtx *c, double t, const double *y, int what, const double *acc, int *contact,
                      EventKind *kind, int *end) {
    const Model *M = c->M;
    const StackPattern *p = &c->p;
    double q[4], w[4], ah, av, ind[SS_IND], m = INFINITY;
    SsSolution sol;
    model_ground_piece(M, t, c->piece, &ah, &av);
    if (c->fast) {
        fast_indicators(c, y, ah, av, what, acc, ind);
    } else {
        ss_qw(y, q, w);
        if (!ss_solve(M, p, q, w, ah, av, &sol)) return INFINITY;
        ss_indicators(M, p, q, &sol, ind);
        const double *F = sol.F;
        pressure_indicators(M, p, F[0], F[1], F[3], F[4], ind);
    }
    for (int i = 0; i < SS_IND; i++) {
        int margin = i >= 2 && i <= 5;
        if (!(what & (margin ? IND_MARGINS : IND_FRICTION))) continue;
        double val = ind[i] + (margin ? TOL_OPEN : TOL_FRICTION);
        if (val < m) {
            m = val;
            *contact = (i == 0 || i == 2 || i == 3 || i == 6) ? 0 : 1;
            *kind = i <= 1 ? EVENT_FLIGHT : i >= 6 ? EVENT_SLIP_START : EVENT_OPEN;
            *end = (i == 2 || i == 4) ? 1 : -1;
        }
    }
    return m;
}

/* A step of n components leaves the others where they were: in its result and, as constants,
 * in its dense output. */
static void keep_rest(int n, const double *y, double *y1, double *f1, double cont[5][NMAX]) {
    for (int i = n; i < SS_N; i++) {
        y1[i] = y[i];
        f1[i] = 0.0;
        cont[0][i] = y[i];
        for (int k = 1; k < 5; k++) cont[k][i] = 0.0;
    }
}

typedef struct {
    const SCtx *c;
    double t, h;
    const double *y;
    const double (*cont)[NMAX];
    int what;
} DenseForce;

static double dense_force(void *ctx, double s) {
    const DenseForce *d = ctx;
    double y[NMAX];
    int contact, end;
    EventKind kind;
    memcpy(y, d->y, sizeof(y)); /* the components a step leaves where they were */
    dense_eval(d->cont, components(d->c), s, y);
    return weakest(d->c, d->t + s * d->h, y, d->what, NULL, &contact, &kind, &end);
}

typedef struct {
    const SCtx *c;
    double t;
    const double *y, *f0;
    double *y1, *f1;
    double (*cont)[NMAX];
} RealForce;

static double real_force(void *ctx, double x) {
    RealForce *r = ctx;
    double err[NMAX];
    int contact, end;
    EventKind kind;
    dopri5_step(rhs_cb, r->c, components(r->c), r->t, r->y, r->f0, x, r->y1, r->f1, err, r->cont);
    keep_rest(components(r->c), r->y, r->y1, r->f1, r->cont);
    return weakest(r->c, r->t + x, r->y1, IND_ALL, NULL, &contact, &kind, &end);
}


static int take_step(Model *M, const Logger *log) {
    State *S = &M->s;
    const Variables *v = &M->v;
    const Derived *d = &M->d;
    SCtx c = context(M, &S->pat, S->t, S->y);
    const StackPattern *p = &c.p;
    int hitBp, n = components(&c);
    double bp = next_breakpoint(M, S->t, c.piece), hmax = bp - S->t;
    double y1[NMAX] = {0}, f1[NMAX] = {0}, cont[5][NMAX] = {{0}}, h = S->h, hNext;
    /* error control: angles and their rates as the rigid stack; slips in units of the pair's
     * half diagonal R, slip rates in R sqrt(g / R), work integrals in (m1 + m2) g R */
    double len = d->RL, rate = len * sqrt(v->g / len), work = d->mTot * v->g * len;
    double scale[SS_N] = {1, 1, 1, 1, work, len, rate, len, rate, work, work};
    if (!S->fValid) {
        rhs_cb(&c, S->t, S->y, S->f);
        S->fValid = 1;
    }
    if (adaptive_step_controlled(rhs_cb, &c, n, c.fast ? 4 : SS_N, c.fast ? NULL : scale, S->t, S->y, S->f, &h, hmax,
                                 v->relTol, v->absTol, y1, f1, cont, &hNext, &hitBp, &S->rejected)) {
        if (p->g.sigma || p->i.sigma) { /* the forces of a slide grew without bound (Painleve's paradox) */
            say(log, LOG_EVENTS, "painleve t=%.17g (a sliding contact's forces grow without bound: no unique motion)",
                S->t);
            finish(M, EVENT_FLIGHT, log);
            return 0;
        }
        say(log, LOG_ERROR, "no acceptable step size (last tried %g) at t=%.17g", h, S->t);
        return -1;
    }
    keep_rest(n, S->y, y1, f1, cont);
    S->steps++;
    /* polynomial events: gaps, overturns, slip-rate zeros, block 2's pivot past block 1's edge */
    double a[5], b[5], P[5];
    dense_poly(cont, 0, a);
    dense_poly(cont, 2, b);
    EventKind ev = EVENT_NONE;
    int evContact = 0;
    double sEv = 2.0, wEv[NMAX] = {0}, target = 0.0;
    struct {
        EventKind kind;
        int use, contact, comp, rel, slope;
        double sign, offset;
    } cand[8] = {
        {EVENT_IMPACT, !p->g.flat, 0, 0, 0, -1, p->g.s, 0.0},
        {EVENT_OVERTURN, !p->g.flat, 0, 0, 0, +1, p->g.s, M_PI / 2},
        {EVENT_INTERFACE, !p->i.flat, 1, 2, 1, -1, p->i.s, 0.0},
        {EVENT_OVERTURN2, !p->i.flat, 1, 2, 1, +1, p->i.s, M_PI / 2},
        {EVENT_SLIP_STOP, p->g.sigma != 0, 0, SS_V1, 0, -1, p->g.sigma, -SLIP_EPS},
        {EVENT_SLIP_STOP, p->i.sigma != 0, 1, SS_V2, 0, -1, p->i.sigma, -SLIP_EPS},
        {EVENT_FELL_OFF, !p->i.flat && !c.fast, 1, SS_U2, 0, +1, 1.0, v->halfWidth - p->i.s * v->halfWidth2 + EDGE_EPS},
        {EVENT_FELL_OFF, !p->i.flat && !c.fast, 1, SS_U2, 0, +1, -1.0, v->halfWidth + p->i.s * v->halfWidth2 + EDGE_EPS},
    };
    for (int k = 0; k < 8; k++) {
        if (!cand[k].use) continue;
        double cc[5];
        if (!cand[k].rel) dense_poly(cont, cand[k].comp, cc);
        for (int i = 0; i < 5; i++) P[i] = cand[k].sign * (cand[k].rel ? b[i] - a[i] : cc[i]);
        P[0] -= cand[k].offset;
        double sc = first_crossing(P, cand[k].slope);
        if (sc < sEv) {
            sEv = sc, ev = cand[k].kind, evContact = cand[k].contact;
            memset(wEv, 0, sizeof(wEv));
            if (cand[k].rel) wEv[0] = -cand[k].sign, wEv[2] = cand[k].sign;
            else wEv[cand[k].comp] = cand[k].sign;
            target = cand[k].offset;
        }
    }
    /* force indicators (flat contacts' end margins, sticking contacts' friction margins) on the
     * dense output: sampled as the rigid stack samples its openings where a contact is flat, at
     * the step's end otherwise */
    int fContact = 0, fEnd = 1;
    EventKind fKind = EVENT_NONE;
    int flat = p->g.flat || p->i.flat;
    double endAcc[2], endT[2] = {0, 0}, endN[2] = {0, 0};
    DenseForce df = {&c, S->t, h, S->y, (const double(*)[NMAX])cont, IND_ALL};
    double sF;
    if (c.fast) { /* the rigid stack's cost: its openings sampled, friction at the step's end (its
                   * accelerations are the step's last evaluation) */
        df.what = IND_MARGINS;
        sF = flat ? first_negative_sampled(dense_force, &df, FAST_OPEN_SAMPLES) : 2.0;
        /* the reactions at the step's end from its last evaluation (kept for the monitors, whose
         * next sample is there) */
        double ahE, avE;
        model_ground_piece(M, hitBp ? bp : S->t + h, c.piece, &ahE, &avE);
        endAcc[0] = f1[1], endAcc[1] = f1[3];
        contact_stack(M, c.mode, c.s1, c.s2, y1, endAcc, ahE, avE, &endT[0], &endN[0], &endT[1], &endN[1]);
        double ind[SS_IND] = {INFINITY, INFINITY, INFINITY, INFINITY, INFINITY, INFINITY, INFINITY, INFINITY}, fr = INFINITY;
        pressure_indicators(M, p, endT[0], endN[0], endT[1], endN[1], ind);
        for (int i = 0; i < SS_IND; i++) fr = fmin(fr, ind[i]);
        if (fr + TOL_FRICTION < 0) {
            df.what = IND_FRICTION;
            sF = fmin(sF, first_negative_sampled(dense_force, &df, FORCE_SAMPLES));
        }
        df.what = IND_ALL;
    } else {
        sF = first_negative_sampled(dense_force, &df, flat ? FORCE_SAMPLES : 1);
    }
    double hStep = h, tNew = hitBp ? bp : S->t + h;
    if (sF < sEv && sF <= 1.0) {
        double yS[NMAX], fS[NMAX], cS[5][NMAX];
        if (c.fast) { /* as the rigid stack: a real step to the time located on the dense output */
            const double none[NMAX] = {0};
            hStep = refine_step(rhs_cb, &c, n, S->t, S->y, S->f, sF * h, h, none, 0.0, yS, fS, cS);
            keep_rest(n, S->y, yS, fS, cS);
        } else { /* regula falsi on the length of real steps from the step's start */
            RealForce rf = {&c, S->t, S->y, S->f, yS, fS, cS};
            double lo = fmax(0.0, sF - 1.0 / FORCE_SAMPLES) * h, hi = sF * h;
            double flo = lo > 0 ? real_force(&rf, lo) : dense_force(&df, 0.0);
            double fhi = real_force(&rf, hi);
            if (fhi >= 0) hi = h, fhi = real_force(&rf, hi);
            if (flo < 0) lo = 0.0, flo = fmax(dense_force(&df, 0.0), 0.0);
            hStep = fhi < 0 ? first_negative(real_force, &rf, lo, flo, hi, fhi, 4.0, fabs(S->t), 0.0, 100) : hi;
            real_force(&rf, hStep);
        }
        memcpy(y1, yS, sizeof(yS));
        memcpy(f1, fS, sizeof(fS));
        memcpy(cont, cS, sizeof(cS));
        weakest(&c, S->t + hStep, y1, IND_ALL, NULL, &fContact, &fKind, &fEnd);
        ev = fKind, evContact = fContact;
        tNew = S->t + hStep;
        hitBp = 0;
        sEv = 2.0; /* located */
    }
    if (sEv <= 1.0) {
        hStep = refine_step(rhs_cb, &c, n, S->t, S->y, S->f, sEv * h, h, wEv, target, y1, f1, cont);
        keep_rest(n, S->y, y1, f1, cont);
        /* the event's functional exactly at its target */
        if (ev == EVENT_IMPACT || ev == EVENT_OVERTURN) y1[0] = p->g.s * target;
        if (ev == EVENT_INTERFACE || ev == EVENT_OVERTURN2) y1[2] = y1[0] + p->i.s * target;
        if (ev == EVENT_SLIP_STOP) y1[evContact == 0 ? SS_V1 : SS_V2] = 0.0;
        tNew = S->t + hStep;
        hitBp = 0;
    }

    stack_track_peaks(S, (const double(*)[NMAX])cont, y1);
    if (!c.fast) {
        S->maxAbsSlip = fmax(S->maxAbsSlip, fmax(dense_abs_max(cont, SS_U1, 1.0), fabs(y1[SS_U1])));
        S->maxAbsSlip2 = fmax(S->maxAbsSlip2, fmax(dense_abs_max(cont, SS_U2, 1.0), fabs(y1[SS_U2])));
    }
    S->tOld = S->t;
    S->hDense = hStep;
    memcpy(S->cont, cont, sizeof(cont));
    S->denseSide = p->g.s;
    S->denseSide2 = p->i.s;
    S->densePat = *p;
    S->denseValid = 1;
    S->t = tNew;
    memcpy(S->y, y1, sizeof(y1));
    memcpy(S->f, f1, sizeof(f1));
    S->fValid = (ev == EVENT_NONE && !hitBp);
    S->ssEndValid = S->fValid && c.fast;
    memcpy(S->ssEndT, endT, sizeof(endT));
    memcpy(S->ssEndN, endN, sizeof(endN));
    if (!S->ssEndValid) S->ssEndT[0] = S->ssEndT[1] = S->ssEndN[0] = S->ssEndN[1] = 0.0;
    S->h = hNext;
    S->pending = ev;
    S->eventContact = evContact;
    S->eventEnd = fEnd;
    for (int i = 0; i < SS_N; i++)
        if (!isfinite(S->y[i])) {
            say(log, LOG_ERROR, "non-finite state at t=%.17g", S->t);
            return -1;
        }
    if (hitBp && ev == EVENT_NONE) { /* the excitation's expression changes: does the pattern still hold? */
        double q[4], w[4], ah, av;
        SsSolution sol;
        ss_qw(S->y, q, w);
        model_ground(M, S->t, &ah, &av);
        if (!(ss_solve(M, &S->pat, q, w, ah, av, &sol) && ss_consistent(M, &S->pat, q, w, &sol, 0)))
            S->pending = EVENT_RECHOOSE;
    }
    return 0;
}

static int apply_event(Model *M, const Logger *log) {
    State *S = &M->s;
    EventKind ev = S->pending;
    int contact = S->eventContact, exclude[2] = {0, 0};
    S->pending = EVENT_NONE;
    if (S->t == S->lastSwitchTime) {
        if (++S->quickSwitches > MAX_QUICK_SWITCHES) {
            say(log, LOG_ERROR,
                "the contact pattern keeps changing at t=%.17g without time advancing; the contact problem has no "
                "consistent solution here",
                S->t);
            return -1;
        }
    } else {
        S->quickSwitches = 0;
        S->lastSwitchTime = S->t;
    }
    switch (ev) {
    case EVENT_IMPACT:
    case EVENT_INTERFACE:
        apply_impact(M, ev == EVENT_IMPACT ? 0 : 1, log);
        break;
    case EVENT_OVERTURN:
    case EVENT_OVERTURN2:
    case EVENT_FELL_OFF:
    case EVENT_FLIGHT:
        finish(M, ev, log);
        break;
    case EVENT_OPEN: {
        double u2 = S->y[SS_U2], b1 = M->v.halfWidth, b2 = M->v.halfWidth2;
        int end = S->eventEnd;
        if (contact == 1 && ((end == 1 && u2 + b2 > b1) || (end == -1 && u2 - b2 < -b1))) {
            finish(M, EVENT_FELL_OFF, log); /* it would turn about block 1's edge */
            break;
        }
        say(log, LOG_EVENTS, "open t=%.17g contact=%s end=%d", S->t, contact_name(contact), end);
        exclude[contact] = SS_NOT_FLAT;
        choose(M, exclude, log);
        break;
    }
    case EVENT_SLIP_START:
        exclude[contact] = SS_NOT_STICK;
        choose(M, exclude, log);
        break;
    case EVENT_SLIP_STOP:
        S->y[contact == 0 ? SS_V1 : SS_V2] = 0.0;
        if (choose(M, exclude, log) && S->mode == MODE_REST) S->restTime = S->t;
        break;
    case EVENT_RECHOOSE:
        if (choose(M, exclude, log) && S->mode == MODE_REST) S->restTime = S->t;
        break;
    default:
        break;
    }
    return 0;
}

/* ------------------------------------------------------------------ dense output, outputs */

/* State at tc (<= S->t) from the dense output, with the pattern of its step. */
static int state_at(const Model *M, double tc, double y[NMAX], StackPattern *p, double *s) {
    const State *S = &M->s;
    memcpy(y, S->y, NMAX * sizeof(double));
    *p = S->pat;
    if (!(S->t > tc && S->denseValid)) return 0;
    *s = (tc - S->tOld) / S->hDense;
    if (*s < 0) *s = 0;
    if (*s > 1) *s = 1;
    dense_eval(S->cont, SS_N, *s, y);
    *p = S->densePat;
    return 1;
}

static void reactions(const Model *M, double t, int inStep, double T[2], double N[2]) {
    const State *S = &M->s;
    double y[NMAX], s = 1.0, q[4], w[4], ah, av;
    StackPattern p;
    SsSolution sol;
    int dense = state_at(M, inStep ? t : M->s.t, y, &p, &s);
    /* inside a step, and at its end before its event is applied, the excitation of that step (at a
     * break, the break's left limit: the pattern after it is chosen by the event) */
    if (dense || (S->pending != EVENT_NONE && S->denseValid)) model_ground_piece(M, t, model_piece(M, S->tOld), &ah, &av);
    else model_ground(M, t, &ah, &av);
    SCtx c = context(M, &p, t, y);
    if (!inStep && S->fValid && S->ssEndValid) { /* the step's end: kept by take_step */
        memcpy(T, S->ssEndT, sizeof(S->ssEndT));
        memcpy(N, S->ssEndN, sizeof(S->ssEndN));
        return;
    }
    if (c.fast) { /* the rigid stack's closed forms (at a step's end, its last evaluation) */
        double acc[2];
        if (!inStep && S->fValid) acc[0] = S->f[1], acc[1] = S->f[3];
        else stack_accel(M, c.mode, c.s1, c.s2, y, ah, av, acc);
        contact_stack(M, c.mode, c.s1, c.s2, y, acc, ah, av, &T[0], &N[0], &T[1], &N[1]);
        return;
    }
    ss_qw(y, q, w);
    if (!ss_solve(M, &p, q, w, ah, av, &sol)) memset(&sol, 0, sizeof(sol));
    T[0] = sol.F[0], N[0] = sol.F[1], T[1] = sol.F[3], N[1] = sol.F[4];
}

static const SolverOps SLIDING_STACK = {apply_event, take_step, start_moving, NULL, reactions, NULL};

int ss_advance(Model *M, double tc, const Logger *log, EventStop *stop) {
    return advance_to(M, tc, log, &SLIDING_STACK, stop);
}

static int contact_mode(const ContactKind *k) { return k->flat ? (k->sigma ? 1 : 0) : (k->sigma ? 3 : 2); }

void ss_outputs(Model *M, double tc) {
    State *S = &M->s;
    Variables *v = &M->v;
    double y[NMAX], s = 1.0, q[4], w[4], ah, av;
    StackPattern p;
    SsSolution sol;
    int inStep = state_at(M, tc, y, &p, &s);
    ss_qw(y, q, w);
    model_ground(M, tc, &ah, &av);
    int moving = S->mode != MODE_REST && S->mode != MODE_OVERTURNED;
    memset(&sol, 0, sizeof(sol));
    if (moving || S->mode == MODE_REST) {
        if (!ss_solve(M, &p, q, w, ah, av, &sol)) memset(&sol, 0, sizeof(sol));
    }
    v->theta = y[0], v->omega = y[1], v->theta2 = y[2], v->omega2 = y[3];
    v->alphaDD = moving ? sol.qdd[1] : 0.0;
    v->alphaDD2 = moving ? sol.qdd[3] : 0.0;
    v->maxAbsTheta = S->maxAbsTheta, v->maxAbsTheta2 = S->maxAbsTheta2;
    v->maxAbsSlip = fmax(S->maxAbsSlip, fabs(y[SS_U1]));
    v->maxAbsSlip2 = fmax(S->maxAbsSlip2, fabs(y[SS_U2]));
    if (inStep) {
        v->maxAbsTheta = fmax(S->maxPrev, dense_abs_max(S->cont, 0, s));
        v->maxAbsTheta2 = fmax(S->maxPrev2, dense_abs_max(S->cont, 2, s));
    }
    v->energy = ss_energy(M, y, &p);
    v->momentum = S->mode == MODE_OVERTURNED ? 0.0 : ss_momentum(M, y, &p);
    stack_counter_outputs(M, v, ah, av);
    v->locked = moving && !p.g.flat && p.i.flat;
    v->overturned = S->overturned2;
    if (S->mode == MODE_REST && contact_tipping_side(M, tc)) {
        double T[2], N[2];
        contact_rest(M, tc, 0, T, N);
        v->groundT = T[0], v->groundN = N[0], v->interfaceT = T[1], v->interfaceN = N[1];
    } else if (S->mode == MODE_OVERTURNED) {
        v->groundT = v->groundN = v->interfaceT = v->interfaceN = 0.0;
    } else {
        v->groundT = sol.F[0], v->groundN = sol.F[1], v->interfaceT = sol.F[3], v->interfaceN = sol.F[4];
    }
    v->slip = y[SS_U1], v->slipRate = y[SS_V1];
    v->slip2 = y[SS_U2], v->slipRate2 = y[SS_V2];
    v->frictionLoss = y[SS_LOSS1], v->frictionLoss2 = y[SS_LOSS2];
    v->groundWork = y[SS_WORK];
    v->impactLoss = S->impactLoss;
    int sl1 = inStep ? p.g.sigma : S->pat.g.sigma, sl2 = inStep ? p.i.sigma : S->pat.i.sigma;
    v->slideDuration = S->slideDur + (sl1 && tc > S->slideSince ? tc - S->slideSince : 0.0);
    v->slideDuration2 = S->slideDur2 + (sl2 && tc > S->slideSince2 ? tc - S->slideSince2 : 0.0);
    v->slideStartTime = S->slideStartTime1;
    v->slideStartTime2 = S->slideStartTime2;
    v->slideStarts = S->slideStarts;
    v->slideStarts2 = S->slideStarts2;
    v->fellOff = S->fellOff;
    v->fellOffTime = S->fellOffTime;
    if (S->mode == MODE_OVERTURNED) { /* the run has ended: each contact as it was at the end */
        v->contactMode = S->overturned1 ? 4 : contact_mode(&S->pat.g);
        v->contactMode2 = S->fellOff ? 5 : S->overturned2 ? 4 : contact_mode(&S->pat.i);
    } else {
        v->contactMode = contact_mode(&p.g);
        v->contactMode2 = contact_mode(&p.i);
    }
    contact_outputs(M, v);
}

void ss_rollback(Model *M, double tc) {
    State *S = &M->s;
    double y[NMAX], s = 1.0;
    StackPattern p;
    if (S->mode == MODE_REST || S->mode == MODE_OVERTURNED || S->t <= tc || !S->denseValid) return;
    state_at(M, tc, y, &p, &s);
    S->maxAbsTheta = fmax(S->maxPrev, dense_abs_max(S->cont, 0, s));
    S->maxAbsTheta2 = fmax(S->maxPrev2, dense_abs_max(S->cont, 2, s));
    memcpy(S->y, y, sizeof(y));
    S->t = tc;
    S->pat = p;
    S->mode = mode_of(&p);
    S->side = p.g.s;
    S->side2 = p.i.s;
    S->sigma = p.g.sigma;
    S->pending = EVENT_NONE;
    S->fValid = 0;
    S->denseValid = 0;
}

void ss_state_rhs(const Model *M, double f[NMAX]) {
    const State *S = &M->s;
    SCtx c = context(M, &S->pat, S->t, S->y);
    memset(f, 0, NMAX * sizeof(double));
    rhs_cb(&c, S->t, S->y, f);
}

void ss_replay_step(const Model *M, double y1[NMAX], double f1[NMAX], double cont[5][NMAX]) {
    const State *S = &M->s;
    double y0[NMAX], f0[NMAX] = {0}, err[NMAX];
    for (int i = 0; i < NMAX; i++) y0[i] = S->cont[0][i];
    SCtx c = context(M, &S->densePat, S->tOld, y0);
    rhs_cb(&c, S->tOld, y0, f0);
    dopri5_step(rhs_cb, &c, components(&c), S->tOld, y0, f0, S->hDense, y1, f1, err, cont);
    keep_rest(components(&c), y0, y1, f1, cont);
}

/* ------------------------------------------------------------------ restored states */

static int kind_ok(const ContactKind *k) {
    return (k->flat == 0 || k->flat == 1) && (k->s == 1 || k->s == -1) && k->sigma >= -1 && k->sigma <= 1;
}

int ss_check_state(const Model *M, char *msg, size_t n) {
    const State *S = &M->s;
    const double x[] = {S->maxAbsSlip2, S->slideSince2, S->slideDur2, S->slideStartTime1, S->slideStartTime2,
                        S->fellOffTime};
    for (size_t i = 0; i < sizeof(x) / sizeof(x[0]); i++)
        if (!isfinite(x[i])) {
            snprintf(msg, n, "the rocking-sliding stack's quantity %d = %g is not a finite number", (int)i, x[i]);
            return 1;
        }
    if (!kind_ok(&S->pat.g) || !kind_ok(&S->pat.i) || !kind_ok(&S->densePat.g) || !kind_ok(&S->densePat.i)) {
        snprintf(msg, n, "a contact of the pattern is not one of flat 0/1, corner +-1, slip -1/0/+1");
        return 1;
    }
    if (S->mode != MODE_OVERTURNED && S->mode != mode_of(&S->pat)) {
        snprintf(msg, n, "pattern %d does not fit the contacts' modes", (int)S->mode);
        return 1;
    }
    if (!(S->fellOff == 0 || S->fellOff == 1) || (S->fellOff != (S->fellOffTime >= 0)) ||
        (S->fellOff && S->mode != MODE_OVERTURNED)) {
        snprintf(msg, n, "fellOff = %d does not fit fellOffTime = %g", S->fellOff, S->fellOffTime);
        return 1;
    }
    if (S->ssEndValid) { /* the kept reactions must be the state's, to the bit */
        SCtx c = context(M, &S->pat, S->t, S->y);
        double ah, av, acc[2] = {S->f[1], S->f[3]}, T[2], N[2];
        model_ground(M, S->t, &ah, &av);
        if (S->ssEndValid != 1 || !S->fValid || !c.fast) {
            snprintf(msg, n, "ssEndValid = %d belongs to a rigid pattern at the end of a step", S->ssEndValid);
            return 1;
        }
        contact_stack(M, c.mode, c.s1, c.s2, S->y, acc, ah, av, &T[0], &N[0], &T[1], &N[1]);
        if (memcmp(T, S->ssEndT, sizeof(T)) != 0 || memcmp(N, S->ssEndN, sizeof(N)) != 0) {
            snprintf(msg, n, "the kept contact reactions are not those of the state");
            return 1;
        }
    }
    if (S->zenoCount < 0 || S->zenoCount > ZENO_MAX || !(S->zenoContact == 0 || S->zenoContact == 1)) {
        snprintf(msg, n, "zenoCount = %d, zenoContact = %d are out of range", S->zenoCount, S->zenoContact);
        return 1;
    }
    if (S->slideStarts2 < 0 || S->maxAbsSlip2 < 0 || S->slideDur2 < 0 || S->eventContact < 0 || S->eventContact > 1 ||
        !(S->eventEnd == 1 || S->eventEnd == -1)) {
        snprintf(msg, n, "the rocking-sliding stack's counters are out of range");
        return 1;
    }
    return 0;
}
