/* Model Exchange interface of the rocking block (me.h). The continuous
 * state is the State's (t, y); the discrete state its side, mode and
 * counters, so that outputs come from solver_outputs as in Co-Simulation. */
#include "me.h"

#include <math.h>
#include <stdio.h>

#include "contact.h"
#include "events.h"
#include "ground.h"
#include "solver.h"

/* s: how far ahead an uplift is looked for without a stop time (an endless harmonic
 * motion below the threshold would otherwise be searched for ever) */
#define UPLIFT_HORIZON 1000.0

/* Hysteresis of the impact and peak indicators, relative to the states' nominal values
 * (alpha and alpha p): an indicator crosses zero that far past its event, so that none is
 * exactly 0 where the importer's solver (re)starts, on the boundary (a block released from
 * rest at theta = omega = 0, the restart after a located impact or peak). LSODAR stops with
 * flag -3 on a root at its initial point; root finders that count a 0 at the start as a sign
 * change locate an event at once and never advance. Impacts are then located 1e-10 alpha past
 * theta = 0 (a delay of 1e-10 alpha / |omega|), peaks where omega has turned by 1e-10 alpha p
 * (theta off by the square of that). */
#define ME_HYSTERESIS 1e-10

static int sign_of(double x) { return x > 0 ? 1 : x < 0 ? -1 : 0; }

static void hold_extremes(Instance *I);

int me_check(Instance *I) {
    const Variables *v = &I->s.model.v;
    if (v->nBlocks != 1) {
        INSTANCE_ERROR(I, "invalid parameter: nBlocks = %d: Model Exchange runs one block (nBlocks = 1); run the "
                     "two-block stack with Co-Simulation", v->nBlocks);
        return 1;
    }
    if (v->contactModel != 0) {
        INSTANCE_ERROR(I, "invalid parameter: contact.model = %d: Model Exchange runs rigid rocking (0) only; "
                     "rocking-sliding changes its equations at events the importer cannot see (its mode logic "
                     "lives in the FMU's own event loop): run it with Co-Simulation", v->contactModel);
        return 1;
    }
    if (model_engine(v)) {
        INSTANCE_ERROR(I, "invalid parameter: support.coupling = 1: Model Exchange runs rigid rocking on the ground or "
                     "on a one-way support (support.coupling = 0); a two-way support is integrated with the blocks in "
                     "the FMU's own event loop: run it with Co-Simulation");
        return 1;
    }
    if (v->earlyOverturn) {
        INSTANCE_ERROR(I, "invalid parameter: solver.earlyOverturn belongs to the built-in solver of Co-Simulation; "
                     "in Model Exchange the importer's solver integrates until |theta| = pi/2");
        return 1;
    }
    return 0;
}

/* The sign omega will have: its own, or for a block released with omega = 0, that of
 * its acceleration (0 if balanced). */
static int moving_sign(const Model *M) {
    const State *S = &M->s;
    if (sign_of(S->y[1])) return sign_of(S->y[1]);
    double dy[2];
    model_rhs(M, S->t, S->y, S->side, dy);
    return sign_of(dy[1]);
}

/* The ground tips a block standing on its base at time t: the side it tips towards, else 0. */
static int tipping_side(const Model *M, double t) {
    double ah, av;
    model_ground(M, t, &ah, &av);
    if (!(fabs(ah) > (M->v.g + av) * M->d.upliftSlope)) return 0;
    return ah > 0 ? -1 : 1; /* a_h > 0 tips it towards theta < 0 */
}

/* A rocking block flat on its base (theta = omega = 0) whose acceleration does not take it
 * onto its pivot side: it stands on its base, and rests unless the ground tips it (to the
 * other side: the ground tipping it to its pivot side, within rounding of the threshold,
 * leaves it as it is). */
static int flat_and_falling_back(const Model *M) {
    const State *S = &M->s;
    if (S->mode != MODE_ROCKING || S->y[0] != 0.0 || S->y[1] != 0.0) return 0;
    double dy[2];
    model_rhs(M, S->t, S->y, S->side, dy);
    return !(S->side * dy[1] > 0) && tipping_side(M, S->t) != S->side;
}

/* Changes of the discrete state that leave the continuous states (0, 0) as they are:
 * a block on its base that the ground tips over a corner, or one rocking flat on its base
 * whose acceleration does not lift it on its pivot side (it stands, or tips the other way).
 * At the start, and on entering continuous-time mode (inputs or the time set in event mode
 * after the event iteration): the importer's solver would never see the uplift indicator
 * change sign, negative from the start. Returns 1 if the mode or side changed. */
static int settle(Instance *I, const Logger *log) {
    Model *M = &I->s.model;
    State *S = &M->s;
    double t = S->t;
    int flat = flat_and_falling_back(M);
    if (!(S->mode == MODE_REST && S->y[0] == 0.0 && S->y[1] == 0.0) && !flat) return 0;
    int side = tipping_side(M, t);
    if (side) {
        if (S->mode == MODE_ROCKING && S->side == side) return 0;
        S->mode = MODE_ROCKING;
        S->side = side;
        S->omegaSign = side;
        say(log, LOG_EVENTS, "uplift t=%.17g side=%d", t, side);
        return 1;
    }
    if (flat) {
        S->mode = MODE_REST;
        say(log, LOG_EVENTS, "rest t=%.17g", t);
        return 1;
    }
    return 0;
}

void me_start(Instance *I) {
    Model *M = &I->s.model;
    State *S = &M->s;
    S->t = I->s.tc;
    I->meTimeFloor = S->t;
    S->denseValid = 0;
    S->nStepPeaks = 0;
    S->omegaSign = S->mode == MODE_ROCKING ? moving_sign(M) : 0; /* released at rest: it moves as it accelerates */
    Logger log = instance_solver_logger(I);
    settle(I, &log);
    hold_extremes(I);
}

void me_enter_continuous(Instance *I) {
    Logger log = instance_solver_logger(I);
    settle(I, &log);
    hold_extremes(I);
}

/* The running extremes are discrete variables: between events the outputs keep the values
 * the last event gave them (FMI 2.0 lets a discrete variable change in event mode only). */
static double *extreme(Variables *v, int i) {
    double *p[6] = {&v->maxAbsTheta, &v->maxAbsTheta2, &v->demandMaxGround, &v->demandMaxInterface,
                    &v->normalMinGround, &v->normalMinInterface};
    return p[i];
}

void me_update_outputs(Instance *I) {
    if (I->s.dirty) return;
    solver_outputs(&I->s.model, I->s.model.s.t);
    if (I->s.meHeld)
        for (int i = 0; i < 6; i++) *extreme(&I->s.model.v, i) = I->s.meExtremes[i];
}

/* At an event (initialization, the event update, entering continuous-time mode): the
 * extremes reached up to now become the outputs until the next event. */
static void hold_extremes(Instance *I) {
    I->s.meHeld = 0;
    me_update_outputs(I);
    if (I->s.dirty) return;
    for (int i = 0; i < 6; i++) I->s.meExtremes[i] = *extreme(&I->s.model.v, i);
    I->s.meHeld = 1;
}

Status me_set_time(Instance *I, double t, const char *fn) {
    if (!isfinite(t)) {
        INSTANCE_ERROR(I, "%s: time %g is not finite", fn, t);
        return STATUS_ERROR;
    }
    /* an importer's solver may go back within the step it is taking (a rejected trial), not
     * before the last completed step or event: that would take an FMU state, which Model
     * Exchange does not offer (canGetAndSetFMUstate is Co-Simulation's) */
    if (t < I->meTimeFloor) {
        INSTANCE_ERROR(I, "%s: time %.17g goes back before %.17g, the last completed integrator step or event "
                       "(Model Exchange keeps no earlier state)", fn, t, I->meTimeFloor);
        return STATUS_ERROR;
    }
    I->s.model.s.t = t;
    I->s.tc = t;
    me_update_outputs(I);
    return STATUS_OK;
}

static Status check_size(Instance *I, const void *p, size_t n, size_t want, const char *fn) {
    if (!p && n > 0) {
        INSTANCE_ERROR(I, "%s: NULL array", fn);
        return STATUS_ERROR;
    }
    if (n != want) {
        INSTANCE_ERROR(I, "%s: %zu values given, the model has %zu", fn, n, want);
        return STATUS_ERROR;
    }
    return STATUS_OK;
}

Status me_set_states(Instance *I, const double *x, size_t nx, const char *fn) {
    if (check_size(I, x, nx, ME_STATES, fn)) return STATUS_ERROR;
    if (!isfinite(x[0]) || !isfinite(x[1])) {
        INSTANCE_ERROR(I, "%s: state (%g, %g) is not finite", fn, x[0], x[1]);
        return STATUS_ERROR;
    }
    /* past pi/2 the block has overturned (the event iteration lays it on its side); past a
     * half turn it would be upside down, which no step from a state of the block reaches */
    if (!(fabs(x[0]) <= M_PI)) {
        INSTANCE_ERROR(I, "%s: block1.theta = %g rad lies beyond a half turn (|theta| <= pi; past pi/2 the block "
                       "has overturned)", fn, x[0]);
        return STATUS_ERROR;
    }
    const Derived *d = &I->s.model.d;
    double rateMax = 1e6 * sqrt(I->s.model.v.g / d->R); /* as a state of the built-in solver */
    if (!(fabs(x[1]) <= rateMax)) {
        INSTANCE_ERROR(I, "%s: block1.omega = %g rad/s exceeds 1e6 sqrt(g / R) = %g rad/s (no rocking turns that fast)",
                       fn, x[1], rateMax);
        return STATUS_ERROR;
    }
    State *S = &I->s.model.s;
    S->y[0] = x[0];
    S->y[1] = x[1];
    me_update_outputs(I);
    return STATUS_OK;
}

/* The model functions need valid parameters, for Model Exchange (parameters set in
 * initialization mode are checked when they are used). */
static Status ready(Instance *I) {
    if (instance_initialize(I) || me_check(I)) return STATUS_ERROR;
    return STATUS_OK;
}

Status me_get_states(Instance *I, double *x, size_t nx, const char *fn) {
    if (check_size(I, x, nx, ME_STATES, fn) || ready(I)) return STATUS_ERROR;
    x[0] = I->s.model.s.y[0];
    x[1] = I->s.model.s.y[1];
    return STATUS_OK;
}

Status me_get_nominals(Instance *I, double *x, size_t nx, const char *fn) {
    if (check_size(I, x, nx, ME_STATES, fn)) return STATUS_ERROR;
    const Derived *d = &I->s.model.d;
    /* the size of the motion: an excursion of the order of alpha (once the
     * parameters are known), at the rate a free fall from it reaches */
    int known = !I->s.dirty;
    x[0] = known ? d->alpha : 1.0;
    x[1] = known ? d->alpha * sqrt(d->p2) : 1.0;
    return STATUS_OK;
}

/* A block on the ground needs g + av > 0 (as the built-in solver's steps do): with the
 * ground falling faster than g it would lift off, which the model does not cover. */
static int ground_lets_go(Instance *I, const char *fn) {
    const Model *M = &I->s.model;
    const State *S = &M->s;
    if (S->mode != MODE_ROCKING && S->mode != MODE_REST) return 0;
    double ah, av;
    model_ground(M, S->t, &ah, &av);
    if (M->v.g + av > 0) return 0;
    INSTANCE_ERROR(I, "%s: vertical ground acceleration %g <= -g at t=%.17g: the block would leave the ground (not "
                   "modelled)", fn, av, S->t);
    return 1;
}

Status me_get_derivatives(Instance *I, double *dx, size_t nx, const char *fn) {
    if (check_size(I, dx, nx, ME_STATES, fn) || ready(I)) return STATUS_ERROR;
    const Model *M = &I->s.model;
    const State *S = &M->s;
    if (ground_lets_go(I, fn)) return STATUS_ERROR;
    double d[2] = {0.0, 0.0};
    if (S->mode == MODE_ROCKING) model_rhs(M, S->t, S->y, S->side, d);
    if (!isfinite(d[0]) || !isfinite(d[1])) {
        INSTANCE_ERROR(I, "%s: the derivatives (%g, %g) at t=%.17g are not finite (ground.ah %g, ground.av %g)", fn,
                       d[0], d[1], S->t, M->v.ahIn, M->v.avIn);
        return STATUS_ERROR;
    }
    dx[0] = d[0];
    dx[1] = d[1];
    return STATUS_OK;
}

Status me_get_event_indicators(Instance *I, double *z, size_t nz, const char *fn) {
    if (check_size(I, z, nz, ME_INDICATORS, fn) || ready(I)) return STATUS_ERROR;
    const Model *M = &I->s.model;
    const State *S = &M->s;
    double w[ME_INDICATORS] = {1.0, 1.0, 1.0, 1.0, 1.0, 1.0};
    if (S->mode == MODE_ROCKING) {
        /* theta on the pivot side, omega in the direction it turns, each with its hysteresis
         * (ME_HYSTERESIS): positive from a release or an event until the impact or the peak */
        w[0] = S->side * S->y[0] + ME_HYSTERESIS * M->d.alpha;
        w[1] = M_PI / 2 - fabs(S->y[0]);
        w[3] = S->omegaSign * S->y[1] + ME_HYSTERESIS * M->d.alpha * sqrt(M->d.p2);
    } else if (S->mode == MODE_REST) {
        double ah, av;
        model_ground(M, S->t, &ah, &av);
        w[2] = (M->v.g + av) * M->d.upliftSlope - fabs(ah);
    }
    if (S->mode != MODE_OVERTURNED && (S->slideTime < 0 || S->liftTime < 0)) {
        /* the contact monitors until their first violation: mu N - |T| (sliding) and N
         * (lift-off), over the weight; the event samples them (solver_sample_contacts) */
        double T, N, W = M->d.weight[0];
        solver_contact_now(M, &T, &N);
        if (S->slideTime < 0) w[4] = (M->v.muGround * N - fabs(T)) / W;
        if (S->liftTime < 0) w[5] = N / W;
    }
    for (int i = 0; i < ME_INDICATORS; i++)
        if (!isfinite(w[i])) {
            INSTANCE_ERROR(I, "%s: event indicator %d = %g at t=%.17g is not finite (ground.ah %g, ground.av %g)", fn,
                           i, w[i], S->t, M->v.ahIn, M->v.avIn);
            return STATUS_ERROR;
        }
    for (int i = 0; i < ME_INDICATORS; i++) z[i] = w[i];
    return STATUS_OK;
}

/* rad/s: half the peak indicator's hysteresis. An omega smaller than that against the way
 * the block turns is rounding (a dense output right after a release gives omega = 1e-25 of
 * either sign), not a turn: neither a peak nor a rotation into the ground. */
static double omega_noise(const Model *M) { return 0.5 * ME_HYSTERESIS * M->d.alpha * sqrt(M->d.p2); }

/* An impact due: theta at 0 or on the far side of it from the pivot corner, with omega
 * turning the block into the ground (towards the other side). */
static int past_impact(const Model *M) {
    const State *S = &M->s;
    return S->side * S->y[0] <= 0 && S->side * S->y[1] < -omega_noise(M);
}

/* theta on the far side of 0 with omega not turning the block into the ground: an importer's
 * solver that stopped right after a release, where the dense output's rounding gives
 * theta = -1.5e-36 while omega points away from the ground. No impact: the block leaves the
 * ground on its pivot side. */
static int leaving_ground(const Model *M) {
    const State *S = &M->s;
    return S->side * S->y[0] < 0 && !past_impact(M);
}

/* omega turned against the way the block was turning: a peak. */
static int turned(const Model *M) { return M->s.omegaSign * M->s.y[1] < -omega_noise(M); }

int me_event_pending(Instance *I) {
    const Model *M = &I->s.model;
    const State *S = &M->s;
    if (I->s.dirty) return 0;
    switch (S->mode) {
    case MODE_REST:
        return S->y[0] != 0.0 || S->y[1] != 0.0 || tipping_side(M, S->t) != 0;
    case MODE_OVERTURNED:
        return S->y[0] != S->side * M_PI / 2 || S->y[1] != 0.0;
    case MODE_ROCKING:
        return fabs(S->y[0]) >= M_PI / 2 || past_impact(M) || flat_and_falling_back(M) || turned(M);
    default:
        return 0;
    }
}

int me_event_update(Instance *I, MeEventInfo *info) {
    Model *M = &I->s.model;
    State *S = &M->s;
    Logger log = instance_solver_logger(I);
    double t = S->t, ah, av;
    info->newDiscreteStatesNeeded = info->terminate = info->statesChanged = 0;
    if (ready(I)) return -1;
    model_ground(M, t, &ah, &av);
    if (!(M->v.g + av > 0)) {
        say(&log, LOG_ERROR,
            "vertical ground acceleration %g <= -g at t=%.17g: the block would leave the ground (not modelled)", av, t);
        return -1;
    }
    /* as the importer's solver left it: a located violation (not a state past the overturn,
     * where a long step of the importer's solver carried the block beyond the model) */
    if (!(S->mode == MODE_ROCKING && fabs(S->y[0]) >= M_PI / 2)) solver_sample_contacts(M, &log);
    if (S->mode == MODE_REST && (S->y[0] != 0.0 || S->y[1] != 0.0)) {
        /* the importer set the states of a block at rest: it moves from there (as one
         * released with block1.theta0 and block1.omega0 would), on the corner it leans on */
        S->mode = MODE_ROCKING;
        S->side = S->y[0] > 0 ? 1 : S->y[0] < 0 ? -1 : S->y[1] > 0 ? 1 : -1;
        S->omegaSign = moving_sign(M);
        say(&log, LOG_EVENTS, "release t=%.17g theta=%.17g omega=%.17g", t, S->y[0], S->y[1]);
    }
    if (S->mode == MODE_OVERTURNED && (S->y[0] != S->side * M_PI / 2 || S->y[1] != 0.0)) {
        /* an overturned block lies on its side: its states stay there */
        S->y[0] = S->side * M_PI / 2;
        S->y[1] = 0.0;
        info->statesChanged = 1;
    }
    if (S->mode == MODE_ROCKING) {
        double theta = S->y[0], omega = S->y[1];
        if (fabs(theta) >= M_PI / 2) {
            /* on the side it fell to (an importer's long step may have carried it across
             * theta = 0 and beyond the other corner) */
            S->side = theta > 0 ? 1 : -1;
            S->mode = MODE_OVERTURNED;
            S->overturnTime = t;
            S->y[0] = S->side * M_PI / 2;
            S->y[1] = 0.0;
            S->maxAbsTheta = M_PI / 2;
            info->statesChanged = 1;
            say(&log, LOG_EVENTS, "overturn t=%.17g side=%d", t, S->side);
        } else if (past_impact(M)) {
            /* block 1 lands on the corner of the other side: the impact map */
            double wp;
            int rest = model_impact(M, t, omega, &wp);
            {
                double y0[2] = {0.0, 0.0}, w0[2] = {omega, 0.0}, w1[2] = {wp, 0.0};
                contact_impulse(M, t, y0, MODE_ROCKING, S->side, 0, w0, MODE_ROCKING, -S->side, 0, w1, &log);
            }
            S->impacts++;
            S->lastImpactTime = t;
            S->y[0] = 0.0; /* on the ground line (the indicator's hysteresis located it a hair past) */
            S->y[1] = wp;
            S->side = -S->side;
            info->statesChanged = 1;
            say(&log, LOG_EVENTS, "impact t=%.17g omega_minus=%.17g omega_plus=%.17g", t, omega, wp);
            if (rest) {
                S->mode = MODE_REST;
                S->y[0] = S->y[1] = 0.0;
                S->restTime = t;
                say(&log, LOG_EVENTS, "rest t=%.17g", t);
            }
        } else if (leaving_ground(M)) {
            /* not an impact: it (re)starts rocking on the side omega points to, from theta = 0
             * (omega = 0: settle below decides from its acceleration) */
            S->y[0] = 0.0;
            info->statesChanged = 1;
            say(&log, LOG_EVENTS, "lift-off t=%.17g side=%d omega=%.17g", t, S->side, omega);
        } else if (turned(M)) { /* omega changed sign: a peak */
            S->peaks++;
            S->lastPeakTime = t;
            S->lastPeakTheta = theta;
            if (fabs(theta) > S->maxAbsTheta) S->maxAbsTheta = fabs(theta);
            say(&log, LOG_EVENTS, "peak t=%.17g theta=%.17g", t, theta);
        }
        /* the way it turns now (an omega at rounding level right after a release says nothing) */
        if (S->mode == MODE_ROCKING && fabs(S->y[1]) > omega_noise(M)) S->omegaSign = sign_of(S->y[1]);
        if (fabs(S->y[0]) > S->maxAbsTheta) S->maxAbsTheta = fabs(S->y[0]);
    }
    /* a block on its base: the ground tips it (uplift), or one rocking flat on its base
     * stands on it */
    if (settle(I, &log)) info->statesChanged = 1; /* the importer's solver restarts */
    if (S->mode == MODE_OVERTURNED && M->v.stopAtOverturn) {
        I->s.terminated = 1;
        info->terminate = 1;
    }
    int piece = model_piece(M, t);
    double next = next_breakpoint(M, t, piece);
    /* at rest, the next uplift under the built-in excitation (and the inputs as they are
     * now) is a time event, found as the built-in solver finds it (find_uplift): an
     * excursion of |ah| above the threshold shorter than one step of the importer's solver
     * would give the uplift indicator no sign change at the step's ends */
    if (S->mode == MODE_REST) {
        double horizon = fmin(I->s.stopDefined ? I->s.stopTime : INFINITY, t + UPLIFT_HORIZON), tu;
        int side = find_uplift(M, t, horizon, &tu);
        if ((side == 1 || side == -1) && tu > t) next = fmin(next, tu);
    }
    info->nextTimeDefined = isfinite(next) && next > t;
    info->nextTime = info->nextTimeDefined ? next : 0.0;
    solver_sample_contacts(M, &log); /* after the event */
    hold_extremes(I);
    I->meTimeFloor = t;
    return 0;
}

/* A first violation that sampling the contact now records (contact_sample): a tensile
 * normal reaction, or a pressed contact needing more friction than mu gives. */
static int monitor_violated(const Model *M) {
    const State *S = &M->s;
    if (S->mode == MODE_OVERTURNED || (S->slideTime >= 0 && S->liftTime >= 0)) return 0;
    double T, N;
    solver_contact_now(M, &T, &N);
    return (S->slideTime < 0 && N > 0 && fabs(T) > M->v.muGround * N) || (S->liftTime < 0 && N < 0);
}

int me_completed_step(Instance *I, int *enterEventMode) {
    /* a step event when the states no longer fit the discrete state in a way no event
     * indicator shows: states the importer set on a block at rest or overturned, or
     * rocking flat on its base (theta = 0 moving to the wrong side does not change the sign
     * of theta's indicator from its domain z <= 0) */
    *enterEventMode = me_event_pending(I);
    I->meTimeFloor = I->s.model.s.t; /* the step is accepted: the importer goes on from here */
    if (!I->s.dirty && !*enterEventMode) {
        /* a monitor's first violation that the importer's solver stepped over without locating
         * it (a fixed-step Euler): an event, so that `slides` and `lifts` (discrete) change in
         * event mode; else the monitors' extremes at the importer's steps */
        if (monitor_violated(&I->s.model)) {
            *enterEventMode = 1;
        } else {
            Logger log = instance_solver_logger(I);
            solver_sample_contacts(&I->s.model, &log);
        }
    }
    return 0;
}
