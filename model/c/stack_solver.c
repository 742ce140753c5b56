/* Event-driven time stepping of two stacked blocks (see stack_solver.h and
 * docs/two_blocks.md, "Patterns and their changes"). */
#include "stack_solver.h"

#include <float.h>
#include <math.h>
#include <string.h>

#include "contact.h"
#include "events.h"
#include "ground.h"
#include "integrator.h"
#include "stack.h"

/* Samples per step when looking for a contact that opens. */
#define OPEN_SAMPLES 8

typedef struct {
    const Model *M;
    Mode mode;
    int s1, s2, piece;
} Ctx;

static void rhs_cb(const void *ctx, double t, const double *y, double *dy) {
    const Ctx *c = (const Ctx *)ctx;
    stack_rhs(c->M, c->mode, c->s1, c->s2, t, y, c->piece, dy);
}

static int moving(Mode m) { return m == MODE_UPPER || m == MODE_LOCKED || m == MODE_BOTH; }

static const char *mode_name(Mode m) {
    switch (m) {
    case MODE_REST: return "rest";
    case MODE_UPPER: return "upper";
    case MODE_LOCKED: return "locked";
    case MODE_BOTH: return "both";
    case MODE_OVERTURNED: return "overturned";
    default: return "?";
    }
}

static int sign_of(double x, double y) { return x > 0 ? 1 : x < 0 ? -1 : (y < 0 ? -1 : 1); }

static void set_mode(State *S, Mode mode, int s1, int s2) {
    if (mode == MODE_LOCKED) s2 = s1; /* the irrelevant pivot follows the relevant one */
    if (mode == MODE_UPPER) s1 = s2;
    S->mode = mode;
    S->side = s1;
    S->side2 = s2;
    S->fValid = 0;
}

/* Angular velocity below which an impact settles a contact: the rate that
 * would lift the body above it (the pair on the ground, or block 2 on block
 * 1) to restRatio * alpha in free rocking under g + av. */
static double settle_rate(const Model *M, int interface, double av) {
    const Derived *d = &M->d;
    double ge = M->v.g + av, W, R, a, I;
    if (interface) {
        W = M->v.mass2 * ge, R = d->RI, a = d->alphaI, I = d->II;
    } else {
        W = d->mTot * ge, R = d->RL, a = d->alphaL, I = d->IL;
    }
    double lift = cos(a - M->v.restRatio * a) - cos(a);
    return lift > 0 ? sqrt(2.0 * W * R * lift / I) : 0.0;
}

void stack_initialize(Model *M) {
    State *S = &M->s;
    const Variables *v = &M->v;
    double *y = S->y, ah, av;
    y[0] = v->theta0;
    y[1] = v->omega0;
    y[2] = v->theta02;
    y[3] = v->omega02;
    S->maxAbsTheta = fabs(y[0]);
    S->maxAbsTheta2 = fabs(y[2]);
    S->maxPrev = S->maxAbsTheta;
    S->maxPrev2 = S->maxAbsTheta2;
    S->lastSwitchTime = -INFINITY;
    model_ground(M, S->t, &ah, &av);
    /* a closed contact released with a rate below the one that settles it at an impact is
     * closed: its excursion would be too short for any step, and its return missed */
    if (y[0] == 0.0 && fabs(y[1]) < settle_rate(M, 0, av)) y[1] = 0.0;
    if (y[2] == y[0] && fabs(y[3] - y[1]) < settle_rate(M, 1, av)) y[3] = y[1];
    int s1 = sign_of(y[0], y[1]), s2 = sign_of(y[2] - y[0], y[3] - y[1]);
    Mode mode;
    int contact, end;
    if (y[0] == 0.0 && y[1] == 0.0) {
        mode = (y[2] == 0.0 && y[3] == 0.0) ? MODE_REST : MODE_UPPER;
        s1 = s2;
    } else {
        mode = (y[2] == y[0] && y[3] == y[1]) ? MODE_LOCKED : MODE_BOTH;
        if (mode == MODE_LOCKED) s2 = s1;
    }
    /* a closed contact that cannot hold opens at its weak end (at rest the
     * first step decides, see rest_advance) */
    if ((mode == MODE_UPPER || mode == MODE_LOCKED) &&
        stack_weakest(M, mode, s1, s2, y, ah, av, &contact, &end) < -STACK_TOL_OPEN) {
        if (mode == MODE_UPPER) s1 = end;
        else s2 = end;
        mode = MODE_BOTH;
    }
    set_mode(S, mode, s1, s2);
}

static void start_from_rest(Model *M, double t, int side, const Logger *log) {
    State *S = &M->s;
    memset(S->y, 0, sizeof(S->y));
    Mode chosen = stack_start_pattern(M, t, side);
    S->t = t;
    S->h = 0.0;
    S->denseValid = 0;
    set_mode(S, chosen, side, side);
    say(log, LOG_EVENTS, "uplift t=%.17g side=%d pattern=%s", t, side, mode_name(chosen));
}

/* Impacts: the momentum map onto the new pattern (opening the contact that
 * cannot carry the impulse), the constant-restitution scaling, and the
 * settling of a contact whose rebound is below settle_rate. */
static void apply_impact(Model *M, const Logger *log) {
    State *S = &M->s;
    const Variables *v = &M->v;
    double *y = S->y, ah, av, wm[2] = {y[1], y[3]}, wp[2], wq[2];
    int ground = S->pending == EVENT_IMPACT;
    Mode om = S->mode, nm = om;
    int o1 = S->side, o2 = S->side2, n1 = o1, n2 = o2;
    model_ground(M, S->t, &ah, &av);
    if (ground) {
        y[0] = 0.0;
        if (om == MODE_LOCKED) y[2] = 0.0;
        n1 = -o1;
        if (om == MODE_LOCKED) n2 = n1;
    } else {
        y[2] = y[0];
        n2 = -o2;
        if (om == MODE_UPPER) n1 = n2;
    }
    if (!stack_impact(M, nm, n1, n2, o1, o2, y, wm, wp)) {
        /* the closed contact would have to pull: it opens at one end */
        int found = 0;
        for (int e = 1; e >= -1 && !found; e -= 2) {
            int b1 = nm == MODE_UPPER ? e : n1, b2 = nm == MODE_LOCKED ? e : n2;
            stack_impact(M, MODE_BOTH, b1, b2, o1, o2, y, wm, wq);
            double open = nm == MODE_UPPER ? e * wq[0] : e * (wq[1] - wq[0]);
            if (open > 0) {
                nm = MODE_BOTH, n1 = b1, n2 = b2, wp[0] = wq[0], wp[1] = wq[1];
                found = 1;
            }
        }
    }
    if (v->law == 2) { /* constant restitution: kinetic energy ratio eta^2 */
        double eta = ground ? v->etaGround : v->etaInterface;
        double Tm = stack_kinetic(M, o1, o2, y, wm), Tp = stack_kinetic(M, n1, n2, y, wp);
        double f = Tp > 0 ? eta * sqrt(Tm / Tp) : 0.0;
        wp[0] *= f;
        wp[1] *= f;
    }
    contact_impulse(M, S->t, y, om, o1, o2, wm, nm, n1, n2, wp, log);
    if (ground) S->impactsGround++;
    else S->impactsInterface++;
    S->impacts++;
    S->lastImpactTime = S->t;
    say(log, LOG_EVENTS,
        "impact t=%.17g contact=%s theta1=%.17g theta2=%.17g w1m=%.17g w2m=%.17g w1p=%.17g "
        "w2p=%.17g from=%s:%d:%d to=%s:%d:%d",
        S->t, ground ? "ground" : "interface", y[0], y[2], wm[0], wm[1], wp[0], wp[1],
        mode_name(om), o1, o2, mode_name(nm), n1, n2);

    /* settling: a contact at zero gap whose rate is negligible closes. Both
     * contacts are looked at (a landing block 2 can leave block 1 with a
     * negligible rate too); the most settled admissible pattern wins. */
    int groundOpen = nm == MODE_BOTH || nm == MODE_LOCKED;
    int interfaceOpen = nm == MODE_BOTH || nm == MODE_UPPER;
    int groundSettles = !groundOpen || (y[0] == 0.0 && fabs(wp[0]) < settle_rate(M, 0, av));
    int interfaceSettles =
        !interfaceOpen || (y[2] == y[0] && fabs(wp[1] - wp[0]) < settle_rate(M, 1, av));
    Mode cand[3];
    int nc = 0;
    if (groundSettles && interfaceSettles) cand[nc++] = MODE_REST;
    if (nm == MODE_BOTH) { /* close one contact, the impacting one first */
        if (ground ? groundSettles : interfaceSettles) cand[nc++] = ground ? MODE_UPPER : MODE_LOCKED;
        if (ground ? interfaceSettles : groundSettles) cand[nc++] = ground ? MODE_LOCKED : MODE_UPPER;
    }
    for (int i = 0; i < nc; i++) {
        /* A rigid block cannot be stopped by compressive impulses alone
         * (docs/two_blocks.md), so settling is a rest criterion on a rebound
         * that is already negligible, not an impact law: the remaining rates
         * are projected onto the settled pattern, which must hold. */
        Mode sm = cand[i];
        stack_impact(M, sm, n1, n2, n1, n2, y, wp, wq);
        double ys[4] = {y[0], wq[0], y[2], wq[1]};
        if (stack_admissible(M, sm, n1, n2, ys, ah, av)) {
            nm = sm, wp[0] = wq[0], wp[1] = wq[1];
            if (sm == MODE_REST) S->restTime = S->t;
            say(log, LOG_EVENTS, "settle t=%.17g pattern=%s w1=%.17g w2=%.17g", S->t,
                mode_name(sm), wq[0], wq[1]);
            break;
        }
    }
    if (nm == MODE_REST) memset(y, 0, 4 * sizeof(double));
    else {
        y[1] = wp[0];
        y[3] = wp[1];
        if (nm == MODE_UPPER) y[0] = y[1] = 0.0;
    }
    set_mode(S, nm, n1, n2);
}

static int apply_event(Model *M, const Logger *log) {
    State *S = &M->s;
    if (S->t == S->lastSwitchTime) {
        if (++S->quickSwitches > MAX_QUICK_SWITCHES) {
            say(log, LOG_ERROR,
                "the motion pattern keeps changing at t=%.17g without time advancing "
                "(pattern %s); the contact problem has no consistent solution here",
                S->t, mode_name(S->mode));
            return -1;
        }
    } else {
        S->quickSwitches = 0;
        S->lastSwitchTime = S->t;
    }
    switch (S->pending) {
    case EVENT_IMPACT:
    case EVENT_INTERFACE:
        apply_impact(M, log);
        break;
    case EVENT_OPEN: {
        double ah, av;
        int contact = 0, end = 1;
        model_ground(M, S->t, &ah, &av);
        stack_weakest(M, S->mode, S->side, S->side2, S->y, ah, av, &contact, &end);
        int s1 = contact == 0 ? end : S->side, s2 = contact == 1 ? end : S->side2;
        say(log, LOG_EVENTS, "open t=%.17g contact=%s end=%d pattern=both", S->t,
            contact ? "interface" : "ground", end);
        set_mode(S, MODE_BOTH, s1, s2);
        break;
    }
    case EVENT_OVERTURN:
    case EVENT_OVERTURN2:
        S->overturned2 = 1;
        if (S->pending == EVENT_OVERTURN) S->overturned1 = 1;
        S->overturnTime = S->t;
        S->y[1] = S->y[3] = 0.0;
        set_mode(S, MODE_OVERTURNED, S->side, S->side2);
        say(log, LOG_EVENTS, "overturn t=%.17g blocks=%s", S->t, S->overturned1 ? "1+2" : "2");
        break;
    default:
        break;
    }
    S->pending = EVENT_NONE;
    return 0;
}


/* Weakest margin (shifted by STACK_TOL_OPEN) on the dense output at s. */
static double open_margin(const Model *M, const Ctx *c, double t0, double h,
                          const Dense *cont, double s) {
    double y[NMAX], ah, av;
    int contact, end;
    dense_eval(cont, 4, s, y);
    model_ground_piece(M, t0 + s * h, c->piece, &ah, &av);
    return stack_weakest(M, c->mode, c->s1, c->s2, y, ah, av, &contact, &end) + STACK_TOL_OPEN;
}

/* open_margin along one step (first_negative_sampled's function). */
typedef struct {
    const Model *M;
    const Ctx *c;
    double t0, h;
    const Dense *cont;
} OpenSearch;

static double open_at(void *ctx, double s) {
    const OpenSearch *o = ctx;
    return open_margin(o->M, o->c, o->t0, o->h, o->cont, s);
}

/* First s in (0, 1] at which a closed contact opens, or 2. The margin is
 * sampled and the first sign change bisected to machine precision. */
static double open_crossing(const Model *M, const Ctx *c, double t0, double h,
                            const Dense *cont) {
    OpenSearch o = {M, c, t0, h, cont};
    return first_negative_sampled(open_at, &o, OPEN_SAMPLES);
}

static int take_step(Model *M, const Logger *log) {
    State *S = &M->s;
    const Variables *v = &M->v;
    Ctx c = {M, S->mode, S->side, S->side2, model_piece(M, S->t)};
    int contact, end, hitBp;
    double ah, av;

    if (S->mode == MODE_LOCKED || S->mode == MODE_UPPER) {
        model_ground_piece(M, S->t, c.piece, &ah, &av);
        if (stack_weakest(M, S->mode, S->side, S->side2, S->y, ah, av, &contact, &end) < -STACK_TOL_OPEN) {
            S->pending = EVENT_OPEN; /* e.g. an input changed at the communication point */
            S->denseValid = 0;
            return 0;
        }
    }
    double bp = next_breakpoint(M, S->t, c.piece), hmax = bp - S->t;
    double y1[NMAX] = {0}, f1[NMAX] = {0}, h = S->h, hNext;
    Dense cont = {0}; /* components past 4: 0 in the state */
    if (!S->fValid) {
        rhs_cb(&c, S->t, S->y, S->f);
        S->fValid = 1;
    }
    if (adaptive_step(rhs_cb, &c, 4, S->t, S->y, S->f, &h, hmax, v->relTol, v->absTol, y1, f1,
                      &cont, &hNext, &hitBp, &S->rejected)) {
        say(log, LOG_ERROR, "no acceptable step size (last tried %g) at t=%.17g", h, S->t);
        return -1;
    }
    S->steps++;

    /* events: polynomial crossings of the dense output, and contact opening */
    double a[DENSE_ROWS], b[DENSE_ROWS], P[5];
    int s1 = S->side, s2 = S->side2;
    dense_poly(&cont, 0, a);
    dense_poly(&cont, 2, b);
    EventKind ev = EVENT_NONE;
    double sEv = 2.0;
    struct {
        EventKind kind;
        int use;
        double sign, offset;
        int rel, slope;
    } cand[4] = {
        {EVENT_IMPACT, S->mode != MODE_UPPER, s1, 0.0, 0, -1},
        {EVENT_OVERTURN, S->mode != MODE_UPPER, s1, M_PI / 2, 0, +1},
        {EVENT_INTERFACE, S->mode != MODE_LOCKED, s2, 0.0, 1, -1},
        {EVENT_OVERTURN2, S->mode != MODE_LOCKED, s2, M_PI / 2, 1, +1},
    };
    for (int k = 0; k < 4; k++) {
        if (!cand[k].use) continue;
        for (int i = 0; i < 5; i++) P[i] = cand[k].sign * (cand[k].rel ? b[i] - a[i] : a[i]);
        P[0] -= cand[k].offset;
        double s = first_crossing(P, 4, cand[k].slope);
        if (s < sEv) sEv = s, ev = cand[k].kind;
    }
    if (S->mode == MODE_LOCKED || S->mode == MODE_UPPER) {
        double s = open_crossing(M, &c, S->t, h, &cont);
        if (s < sEv) sEv = s, ev = EVENT_OPEN;
    }
    double hStep = h, tNew = hitBp ? bp : S->t + h;
    if (ev != EVENT_NONE) {
        double w[NMAX] = {0}, target = 0.0;
        if (ev == EVENT_IMPACT || ev == EVENT_OVERTURN) w[0] = 1.0;
        if (ev == EVENT_INTERFACE || ev == EVENT_OVERTURN2) w[0] = -1.0, w[2] = 1.0;
        if (ev == EVENT_OVERTURN) target = s1 * M_PI / 2;
        if (ev == EVENT_OVERTURN2) target = s2 * M_PI / 2;
        hStep = refine_step(RK_DOPRI5, rhs_cb, &c, 4, S->t, S->y, S->f, sEv * h, h, w, target, y1, f1, &cont, NULL);
        if (ev == EVENT_IMPACT || ev == EVENT_OVERTURN) y1[0] = target;
        if (ev == EVENT_INTERFACE || ev == EVENT_OVERTURN2) y1[2] = y1[0] + target;
        tNew = S->t + hStep;
        hitBp = 0;
    }

    stack_track_peaks(S, &cont, y1);
    S->tOld = S->t;
    S->hDense = hStep;
    S->cont = cont;
    S->denseSide = s1;
    S->denseSide2 = s2;
    S->denseValid = 1;
    S->t = tNew;
    memcpy(S->y, y1, 4 * sizeof(double));
    memcpy(S->f, f1, 4 * sizeof(double));
    S->fValid = ev == EVENT_NONE && (!hitBp || ground_continuous_after(M, c.piece)); /* (the next step's start) */
    S->h = hNext;
    S->pending = ev;

    for (int i = 0; i < 4; i++)
        if (!isfinite(S->y[i])) {
            say(log, LOG_ERROR, "non-finite state at t=%.17g", S->t);
            return -1;
        }
    return 0;
}

static int state_at(const Model *M, double tc, double y[4], int *s1, int *s2, double *s);

/* Contact reactions of the stack at time t (contact.h). */
static void reactions(const Model *M, double t, int inStep, double T[2], double N[2]) {
    const State *S = &M->s;
    double y[4], s = 1.0, ah, av, acc[2] = {0.0, 0.0};
    int s1, s2;
    state_at(M, inStep ? t : S->t, y, &s1, &s2, &s);
    model_ground(M, t, &ah, &av);
    if (moving(S->mode) && !inStep && S->fValid) { /* (t, y) is the last step's end: its last evaluation */
        acc[0] = S->f[1];
        acc[1] = S->f[3];
    } else if (moving(S->mode)) {
        stack_accel(M, S->mode, s1, s2, y, ah, av, acc);
    }
    contact_stack(M, S->mode, s1, s2, y, acc, ah, av, &T[0], &N[0], &T[1], &N[1]);
}

static const SolverOps TWO_BLOCKS = {apply_event, take_step, start_from_rest, NULL, reactions, NULL, NULL};

int stack_advance(Model *M, double tc, const Logger *log, EventStop *stop) {
    return advance_to(M, tc, log, &TWO_BLOCKS, stop);
}

/* State at tc (<= S->t) from the dense output, with the pivots of its step. */
static int state_at(const Model *M, double tc, double y[4], int *s1, int *s2, double *s) {
    const State *S = &M->s;
    memcpy(y, S->y, 4 * sizeof(double));
    *s1 = S->side;
    *s2 = S->side2;
    if (!(S->t > tc && S->denseValid)) return 0;
    *s = (tc - S->tOld) / S->hDense;
    if (*s < 0) *s = 0;
    if (*s > 1) *s = 1;
    dense_eval(&S->cont, 4, *s, y);
    *s1 = S->denseSide;
    *s2 = S->denseSide2;
    return 1;
}

void stack_track_peaks(State *S, const Dense *cont, const double *y1) {
    S->maxPrev = S->maxAbsTheta;
    S->maxPrev2 = S->maxAbsTheta2;
    S->maxAbsTheta = fmax(S->maxAbsTheta, fmax(dense_abs_max(cont, 0, 1.0), fabs(y1[0])));
    S->maxAbsTheta2 = fmax(S->maxAbsTheta2, fmax(dense_abs_max(cont, 2, 1.0), fabs(y1[2])));
}

void stack_counter_outputs(const Model *M, Variables *v, double ah, double av) {
    const State *S = &M->s;
    v->impacts = S->impacts;
    v->impactsGround = S->impactsGround;
    v->impactsInterface = S->impactsInterface;
    v->lastImpactTime = S->lastImpactTime;
    v->atRest = S->mode == MODE_REST;
    v->overturned1 = S->overturned1;
    v->overturned2 = S->overturned2;
    v->overturnTime = S->overturnTime;
    v->restTime = S->restTime;
    v->pattern = (int)S->mode;
    v->peaks = 0; /* a stack counts no peaks */
    v->lastPeakTime = -1.0;
    v->lastPeakTheta = 0.0;
    v->ahTotal = ah;
    v->avTotal = av;
}

void stack_outputs(Model *M, double tc) {
    State *S = &M->s;
    Variables *v = &M->v;
    double y[4], s = 1.0, ah, av, acc[2] = {0.0, 0.0};
    int s1, s2;
    int inStep = state_at(M, tc, y, &s1, &s2, &s);
    model_ground(M, tc, &ah, &av);
    if (moving(S->mode)) stack_accel(M, S->mode, s1, s2, y, ah, av, acc);
    v->theta = y[0];
    v->omega = y[1];
    v->theta2 = y[2];
    v->omega2 = y[3];
    v->alphaDD = acc[0];
    v->alphaDD2 = acc[1];
    v->maxAbsTheta = S->maxAbsTheta;
    v->maxAbsTheta2 = S->maxAbsTheta2;
    if (inStep) {
        v->maxAbsTheta = fmax(S->maxPrev, dense_abs_max(&S->cont, 0, s));
        v->maxAbsTheta2 = fmax(S->maxPrev2, dense_abs_max(&S->cont, 2, s));
    }
    v->energy = stack_energy(M, s1, s2, y);
    stack_counter_outputs(M, v, ah, av);
    v->locked = S->mode == MODE_LOCKED;
    v->overturned = S->mode == MODE_OVERTURNED;
    if (S->mode == MODE_REST && contact_tipping_side(M, tc)) { /* the motion that starts, if the ground tips the stack at tc (contact_rest) */
        double T[2], N[2];
        contact_rest(M, tc, 0, T, N);
        v->groundT = T[0], v->groundN = N[0], v->interfaceT = T[1], v->interfaceN = N[1];
    } else {
        contact_stack(M, S->mode, s1, s2, y, acc, ah, av, &v->groundT, &v->groundN, &v->interfaceT, &v->interfaceN);
    }
    double p[2][2];
    contact_momenta(M, S->mode, s1, s2, y, p);
    v->momentum = p[0][0] + p[1][0];
    M->s.massMoment = contact_mass_moment(M, S->mode, s1, s2, y);
    contact_outputs(M, v);
}

void stack_rollback(Model *M, double tc) {
    State *S = &M->s;
    double y[4], s = 1.0;
    int s1, s2;
    if (!moving(S->mode) || S->t <= tc || !S->denseValid) return;
    state_at(M, tc, y, &s1, &s2, &s);
    S->maxAbsTheta = fmax(S->maxPrev, dense_abs_max(&S->cont, 0, s));
    S->maxAbsTheta2 = fmax(S->maxPrev2, dense_abs_max(&S->cont, 2, s));
    memcpy(S->y, y, sizeof(y));
    S->t = tc;
    S->side = s1;
    S->side2 = s2;
    S->pending = EVENT_NONE;
    S->fValid = 0;
    S->denseValid = 0;
}

void stack_state_rhs(const Model *M, double f[NMAX]) {
    const State *S = &M->s;
    Ctx c = {M, S->mode, S->side, S->side2, model_piece(M, S->t)};
    rhs_cb(&c, S->t, S->y, f);
}

void stack_replay_step(const Model *M, double y1[NMAX], double f1[NMAX], Dense *cont) {
    const State *S = &M->s;
    Ctx c = {M, S->mode, S->denseSide, S->denseSide2, model_piece(M, S->tOld)};
    double y0[NMAX], f0[NMAX], err[NMAX];
    for (int i = 0; i < NMAX; i++) y0[i] = S->cont.r[0][i];
    rhs_cb(&c, S->tOld, y0, f0);
    dopri5_step(rhs_cb, &c, 4, S->tOld, y0, f0, S->hDense, y1, f1, err, cont);
}
