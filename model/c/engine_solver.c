/* Event-driven time stepping of the contact engine (engine_solver.h). Rules: docs/flight.md. */
#include "engine_solver.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "contact.h"
#include "coupling.h"
#include "engine.h"
#include "events.h"
#include "ground.h"
#include "integrator.h"

/* The longest step while a contact slides or a body flies, in units of the time scale 1 / p
 * (a quadratic motion would otherwise be followed with ever longer steps, whose dense output
 * loses its digits a tiny fraction into the step). */
#define FREE_STEP_MAX 1.0
/* Samples of the dense output per step at which the kinematic indicators are checked. */
#define DENSE_SAMPLES 4
/* The look-ahead at an event whose complementarity problem is degenerate at the event itself,
 * in units of 1 / p: far above rounding (1e-16) and far below any time scale of the motion. */
#define LOOK_AHEAD 1e-6
/* Impacts that accumulate: CHATTER_RUN in a row, each within CHATTER_INTERVAL / p of the one before (a
 * rebound that never settles because the plastic impact that would close it flat, friction included,
 * would add energy); the next negligible rebound is then closed by the frictionless projection. */
#define CHATTER_INTERVAL 1e-6
#define CHATTER_RUN 16
/* A force indicator (normal force or friction margin over the weight carried) below -RECHOOSE_SLACK at
 * a step's start says the contact set no longer holds there: far below a located event's rounding. */
#define RECHOOSE_SLACK 1e-9
/* A flying corner's landing indicator (its gap over its body's size, engine_indicators) negative where a step starts: a
 * penetration left by rounding (a corner an impact opened at zero gap, a projection of the bodies below it, a pair
 * switched at its corner). It would never cross zero again, and the corner would pass through its face unseen: its
 * landing is watched as the crossing of its start value less LAND_ROUNDING instead. Below -LAND_PENETRATION (far above
 * rounding, far below any motion) no step starts from it: the corner touches, an impact there at once (before_step).
 * So is a rocking body's open corner whose indicator (its rotation relative to its support) starts on the wrong side
 * of zero: its landing is its dense root (the relative rotation back at zero, after it rose), which the step no longer
 * drops for the start's sign. One that approaches its face there is an impact at the event that left it so
 * (resolve_approach), not at a step's start. */
#define LAND_ROUNDING (64.0 * DBL_EPSILON)
#define LAND_PENETRATION 1e-12

int engine_on(const Model *M) { return model_engine(&M->v); }

typedef struct {
    const Model *M;
    const EnSystem *sys;
    EnMode mode;
    int piece;
    EnForces f; /* of the last evaluation */
    int singular;
    int chain;                 /* a chain (every body touches): its reduced coordinates integrated alone */
    int slides;                /* one of its contacts slides (its slips integrated too) */
    double xi0[EN_MAX_BODIES]; /* the anchors of its sticking contacts */
    double placed[NMAX];       /* a chain's state as the last evaluation placed it (engine_rhs) */
    int two;                   /* the support coupled two ways: its components follow the engine's (coupling.h) */
    int resting;               /* two-way, every body flat on its support and sticking (a sticking chain) */
    int method;                /* the integrator: DOP853 with a two-way support, else DOPRI5 (step_method) */
} Ctx;

static int nblock(const Ctx *c);

/* f + s g, each force and acceleration */
static void forces_axpy(EnForces *f, const EnForces *g, double s) {
    for (int q = 0; q < EN_NQ; q++) f->qdd[q] += s * g->qdd[q];
    for (int k = 0; k < EN_MAX_BODIES; k++) {
        for (int i = 0; i < 2; i++) f->N[k][i] += s * g->N[k][i];
        f->T[k] += s * g->T[k];
        f->xidd[k] += s * g->xidd[k];
    }
}

/* f + s (g - f), each force and acceleration */
static void forces_along(EnForces *f, const EnForces *g, double s) {
    for (int q = 0; q < EN_NQ; q++) f->qdd[q] += s * (g->qdd[q] - f->qdd[q]);
    for (int k = 0; k < EN_MAX_BODIES; k++) {
        for (int i = 0; i < 2; i++) f->N[k][i] += s * (g->N[k][i] - f->N[k][i]);
        f->T[k] += s * (g->T[k] - f->T[k]);
        f->xidd[k] += s * (g->xidd[k] - f->xidd[k]);
    }
}

/* Two-way coupling: the engine's derivatives (affine in the floor's acceleration) at the base's acceleration ag
 * and at ag + 1, floor j's acceleration solved from them (coupling.h), and the derivatives there; then the
 * support's. */
static void coupled_rhs(Ctx *c, double t, const double *y, double ag, double av, double *dy) {
    const Model *M = c->M;
    int nb = c->sys->nb, n0 = nblock(c);
    const double *xi0 = c->chain ? c->xi0 : NULL;
    double r[SUPPORT_MAX_STOREYS], dyB[NMAX], placedB[NMAX];
    EnForces fB;
    coupling_free(M, t, y, ag, r);
    if (c->resting) { /* every body flat and sticking: they move with the floor, T = (their mass) a_f exactly */
        double mtot, uj;
        coupling_momentum(c->sys, y, &mtot);
        uj = coupling_floor(M, r, mtot * ag, mtot);
        if (!engine_rhs(c->sys, &c->mode, xi0, y, ag + uj, av, dy, &c->f, c->placed)) {
            c->singular = 1;
            return;
        }
        for (int i = n0; i < EN_N(nb); i++) dy[i] = 0.0;
        double py = 0.0;
        for (int k = 0; k < nb; k++) py += c->sys->body[k].m * c->placed[EN_VEL(nb, k, 1)];
        coupling_rhs(M, y, r, uj, ag, av, 0.0, py, dy);
        return;
    }
    /* the derivatives' and forces' slopes in the floor's acceleration (dyB, fB): one body on a chain gives them from
     * one evaluation; else the difference of two a unit of acceleration apart */
    int one = c->chain ? engine_rhs_slope(c->sys, &c->mode, xi0, y, ag, av, dy, &c->f, c->placed, dyB, &fB) : -1;
    if (one == -1) {
        if (!engine_rhs(c->sys, &c->mode, xi0, y, ag, av, dy, &c->f, c->chain ? c->placed : NULL) ||
            !engine_rhs(c->sys, &c->mode, xi0, y, ag + 1.0, av, dyB, &fB, c->chain ? placedB : NULL)) {
            c->singular = 1;
            return;
        }
        for (int i = 0; i < n0; i++) dyB[i] -= dy[i];
        forces_axpy(&fB, &c->f, -1.0);
    } else if (one == 0) {
        c->singular = 1;
        return;
    }
    double uj = coupling_floor(M, r, c->f.T[0], fB.T[0]);
    /* (the components with a slope alone, one at a time: the vectorised loop read dy two at a time just after the
     * engine stored it one at a time, and stalled on the stores' forwarding) */
    for (int i = 0; i < n0; i++)
        if (dyB[i] != 0.0) dy[i] += uj * dyB[i];
    for (int i = n0; i < EN_N(nb); i++) dy[i] = 0.0; /* (a chain's placed components ride along) */
    forces_axpy(&c->f, &fB, uj);
    const double *yc = c->chain ? c->placed : y;
    double px = 0.0, py = 0.0;
    for (int k = 0; k < nb; k++) {
        px += c->sys->body[k].m * yc[EN_VEL(nb, k, 0)];
        py += c->sys->body[k].m * yc[EN_VEL(nb, k, 1)];
    }
    coupling_rhs(M, y, r, uj, ag, av, px, py, dy);
}

static void rhs_cb(const void *ctx, double t, const double *y, double *dy) {
    Ctx *c = (Ctx *)ctx; /* the integrator hands our own (non-const) context back */
    double ah, av;
    model_ground_piece(c->M, t, c->piece, &ah, &av);
    if (c->two) {
        coupled_rhs(c, t, y, ah, av, dy);
        return;
    }
    if (!engine_rhs(c->sys, &c->mode, c->chain ? c->xi0 : NULL, y, ah, av, dy, &c->f, c->chain ? c->placed : NULL))
        c->singular = 1;
}

/* The forces of contact set m at the state y under the base's accelerations (ag, av): on a two-way support
 * with floor j's acceleration solved with them. Returns the floor's absolute acceleration (ag elsewhere), or
 * NAN if the set's system is singular. */
static double solve_at(const Model *M, double t, const EnMode *m, const double *y, double ag, double av, EnForces *f) {
    const EnSystem *sys = &M->d.en;
    if (!engine_solve(sys, m, y, ag, av, f)) return NAN;
    if (!coupling_on(M) || M->s.rest.on) return ag; /* (at rest in closed form ag is the floor's: support_rest) */
    double r[SUPPORT_MAX_STOREYS];
    EnForces g;
    coupling_free(M, t, y, ag, r);
    if (!engine_solve(sys, m, y, ag + 1.0, av, &g)) return NAN;
    double uj = coupling_floor(M, r, f->T[0], g.T[0] - f->T[0]);
    forces_along(f, &g, uj);
    return ag + uj;
}

/* The integrator of the engine's steps. On a two-way support the floors' modes (of periods down to a few hundredths of
 * a second) are integrated with the bodies: Dormand and Prince's 8(5,3) (DOP853) takes about a fifth of DOPRI5's steps
 * and half its evaluations there (docs/supports.md). Elsewhere DOPRI5, whose steps the record's samples bound. */
static int step_method(const Model *M) { return coupling_on(M) ? RK_DOP853 : RK_DOPRI5; }

/* The context of the contact set m from t (its forces and placed state are written by each evaluation). */
static void context(Ctx *c, const Model *M, const EnMode *m, double t) {
    c->M = M;
    c->sys = &M->d.en;
    c->mode = *m;
    c->piece = model_piece(M, t);
    memset(&c->f, 0, sizeof(c->f));
    c->singular = 0;
    c->chain = engine_touches(c->sys, m);
    c->slides = c->chain && !engine_is_chain(c->sys, m);
    c->two = coupling_on(M);
    c->resting = c->two && c->chain && !c->slides;
    for (int k = 0; k < c->sys->nb && c->resting; k++) c->resting = m->closed[k][0] && m->closed[k][1];
    memcpy(c->xi0, M->s.enAnchor, sizeof(c->xi0));
    c->method = step_method(M);
}

/* The dense output of a DOP853 step completed (three more evaluations), the context's last evaluation (its forces
 * and a chain's placement, which the step's end left and its callers read) kept. */
static void dense_finish(Ctx *c, Dop853Stages *st, Dense *d) {
    if (d->method != RK_DOP853 || d->rows == DENSE_ROWS) return;
    EnForces f = c->f;
    double placed[NMAX];
    int singular = c->singular;
    memcpy(placed, c->placed, sizeof(placed));
    dop853_dense(rhs_cb, c, st, d);
    c->f = f;
    c->singular = singular;
    memcpy(c->placed, placed, sizeof(placed));
}

/* The engine's components a step integrates: a chain's first EN_CHAIN_N (EN_SLIDE_N where a contact slides), or
 * all. */
static int nblock(const Ctx *c) {
    return c->chain ? (c->slides ? EN_SLIDE_N(c->sys->nb) : EN_CHAIN_N(c->sys->nb)) : EN_N(c->sys->nb);
}

/* The components a step integrates: the engine's; on a two-way support all of the engine's (those a chain places
 * ride along with derivative 0) and the support's after them. */
static int nstep(const Ctx *c) { return c->two ? EN_N(c->sys->nb) + coupling_size(c->M) : nblock(c); }

/* The components a two-way step varies, for DOP853's linear algebra: a chain's reduced ones and the support's (those
 * the chain places ride along with derivative 0: coupled_rhs); all otherwise. */
static void varying(const Ctx *c, Dop853Stages *st) {
    st->nRanges = 0;
    if (!c->two || !c->chain) return;
    st->nRanges = 2;
    st->lo[0] = 0;
    st->hi[0] = nblock(c);
    st->lo[1] = EN_N(c->sys->nb);
    st->hi[1] = nstep(c);
}

/* A step's result y (its first nstep components) completed: a chain's other components from rest (a sticking
 * chain's friction losses, unchanged) and its centres placed exactly from its reduced coordinates and anchors.
 * With f, a chain's forces under the ground's (ah, av) in the same evaluation; returns 1 if it gave them. */
static void keep_rest(const Ctx *c, const double *rest, double *y) {
    int n0 = nblock(c), n = EN_N(c->sys->nb);
    memcpy(y + n0, rest + n0, sizeof(double) * (size_t)(n - n0));
}

static int complete_forces(Ctx *c, const double *rest, double *y, double ah, double av, EnForces *f) {
    if (!c->chain) return 0;
    keep_rest(c, rest, y);
    engine_chain(c->sys, &c->mode, c->xi0, y, ah, av, f);
    return f != NULL;
}

static void complete(Ctx *c, const double *rest, double *y) { complete_forces(c, rest, y, 0.0, 0.0, NULL); }

/* complete for a y the last evaluation was at (a step's result): a chain's placement taken from it. */
static void complete_last(Ctx *c, const double *rest, double *y) {
    if (!c->chain) return;
    int nb = c->sys->nb;
    keep_rest(c, rest, y);
    for (int k = 0; k < nb; k++) {
        y[EN_TH(k)] = c->placed[EN_TH(k)];
        y[EN_W(k)] = c->placed[EN_W(k)];
        for (int i = 0; i < 2; i++) {
            y[EN_POS(nb, k, i)] = c->placed[EN_POS(nb, k, i)];
            y[EN_VEL(nb, k, i)] = c->placed[EN_VEL(nb, k, i)];
        }
    }
}

static int nstate(const Model *M) { return EN_N(M->d.en.nb) + coupling_size(M); }

/* Body k's records: block 1's in the one-block fields, block 2's in their stack counterparts, blocks 3 to 8 in the
 * column's (State) */
typedef struct {
    int *starts;       /* slides started */
    double *since;     /* start of the slide under way, s */
    double *dur;       /* time slid in finished slides, s */
    double *first;     /* first slide's start, s (-1: none) */
    double *maxSlip;   /* largest |slip|, m */
    double *maxTheta;  /* largest |theta|, rad */
} Track;
static Track track(State *S, int k) {
    if (k == 0) return (Track){&S->slideStarts, &S->slideSince, &S->slideDur, &S->slideStartTime1, &S->maxAbsSlip,
                               &S->maxAbsTheta};
    if (k == 1) return (Track){&S->slideStarts2, &S->slideSince2, &S->slideDur2, &S->slideStartTime2, &S->maxAbsSlip2,
                               &S->maxAbsTheta2};
    return (Track){&S->colSlideStarts[k - 2], &S->colSlideSince[k - 2], &S->colSlideDur[k - 2],
                   &S->colSlideFirst[k - 2], &S->colMaxSlip[k - 2], &S->colMaxTheta[k - 2]};
}

/* The contact of body k for the event log: "" for one block, else " contact=ground", " contact=interface" (a stack's)
 * or " contact=interfaceK" (a column's, between blocks K and K + 1) */
static const char *contact_name(int nb, int k, char *buf, size_t n) {
    if (nb == 1) return "";
    if (k == 0) return " contact=ground";
    if (nb == 2) return " contact=interface";
    snprintf(buf, n, " contact=interface%d", k);
    return buf;
}
static double time_scale(const Model *M) { return 1.0 / sqrt(M->d.p2); }

static int flying(const EnMode *m, int k) { return !m->closed[k][0] && !m->closed[k][1]; }

/* ----------------------------------------------------------------- bookkeeping */

/* The slip of body k's contact: the x (along the support) of its lowest corner less that
 * corner's offset c b: the base centre's whenever the base is flat; with an overhang at that end (m's over) the same
 * from the support's corner's place on k's base (engine_point_m). Its rate in *rate. */
static double slip_of(const EnSystem *s, const EnMode *m, int k, const double *y, double *rate, double *gap) {
    EnPoint L, R;
    engine_corner_m(s, m, k, -1, y, &L);
    engine_corner_m(s, m, k, 1, y, &R);
    const EnPoint *p = R.g < L.g ? &R : &L;
    int c = p == &R ? 1 : -1;
    if (rate) *rate = p->xid;
    if (gap) *gap = fmax(0.0, fmin(L.g, R.g));
    return p->xi - s->body[k].xa[c > 0];
}

/* ------------------------------------------------------- impulses on a two-way support */

/* The kinetic energy (J): the bodies' relative to their support; on a two-way support the bodies' and the
 * support's in the base's frame. */
static double kinetic(const Model *M, const double *y) {
    return coupling_on(M) ? coupling_kinetic(M, y) : engine_kinetic(&M->d.en, y);
}

/* The energy (J) the run's balance follows: kinetic plus potential, the bodies' relative to their support; on a
 * two-way support the bodies' in the base's frame and the support's. */
static double energy(const Model *M, const double *y) {
    return coupling_on(M) ? coupling_total_energy(M, y) : engine_energy(&M->d.en, y);
}

/* An impulsive change of the bodies' rates relative to their support in y (an impact, a projection onto
 * constraints); returns nonzero if it succeeded. */
typedef int (*RateChange)(const Model *M, double *y, void *ctx);

/* The bodies' horizontal rates relative to the floor (and the ground contact's held slip rate) less d. */
static void shift_rates(const EnSystem *s, double *y, double d) {
    for (int k = 0; k < s->nb; k++) y[EN_VEL(s->nb, k, 0)] -= d;
    y[EN_XID(s->nb, 0)] -= d;
}

/* op applied with the floor's velocity jump D (m/s, U+ = U- + D): to the bodies' rates relative to the floor after
 * the jump (trial), writing their horizontal impulse P (kg m/s); returns m_j D + P, zero where the floor takes minus
 * the bodies' impulse. */
static double floor_balance(const Model *M, const double *y, double D, RateChange op, void *ctx, double *trial,
                            int *ok, double *P) {
    const EnSystem *sys = &M->d.en;
    memcpy(trial, y, sizeof(double) * NMAX);
    shift_rates(sys, trial, D);
    double p0 = coupling_momentum(sys, trial, NULL);
    *ok = op(M, trial, ctx);
    *P = coupling_momentum(sys, trial, NULL) - p0;
    return coupling_floor_mass(M) * D + *P;
}

/* op on the state y; on a two-way support with the floor: springs and dampers carry no impulse, so floor j's
 * velocity jumps by D = -P / m_j, P the bodies' horizontal impulse, and op acts on the rates relative to the floor
 * after the jump. Its P is piecewise affine and nondecreasing in D (op a plastic impact or a projection), so
 * m_j D + P(D) = 0 has one root, found by the secant method kept in its bracket: exact on the piece of the
 * solution, which keeps the horizontal momentum of bodies plus support. Returns op's success. */
static int with_floor(const Model *M, double *y, RateChange op, void *ctx) {
    if (!coupling_on(M)) return op(M, y, ctx);
    const EnSystem *sys = &M->d.en;
    double trial[NMAX], mj = coupling_floor_mass(M), mtot, P, lo = -INFINITY, hi = INFINITY;
    coupling_momentum(sys, y, &mtot);
    int ok;
    double d0 = 0.0, g0 = floor_balance(M, y, d0, op, ctx, trial, &ok, &P), d1 = d0, g1 = g0;
    for (int it = 0; it < 100; it++) {
        double tol = 64.0 * DBL_EPSILON * (mj * fabs(d1) + fabs(P) + mtot * fabs(d1));
        if (fabs(g1) <= tol) break;
        if (g1 < 0) lo = fmax(lo, d1);
        else hi = fmin(hi, d1);
        double dn = it == 0 || g1 == g0 ? d1 - g1 / mj : d1 - g1 * (d1 - d0) / (g1 - g0);
        if (!(dn > lo && dn < hi)) dn = isfinite(lo) && isfinite(hi) ? 0.5 * (lo + hi) : d1 - g1 / (mj + mtot);
        if (dn == d1) break;
        d0 = d1, g0 = g1, d1 = dn;
        g1 = floor_balance(M, y, d1, op, ctx, trial, &ok, &P);
    }
    memcpy(y, trial, sizeof(double) * NMAX);
    y[COUPLING_V(sys->nb, M->d.sup.j)] += d1;
    return ok;
}

/* The plastic impact of the corners touching (impact_op: and the restitution law of the landing contact k; -1:
 * none). */
typedef struct {
    int in[EN_MAX_BODIES][2], touching[EN_MAX_BODIES][2], stuck[EN_MAX_BODIES], k;
    double PN[EN_MAX_BODIES][2], PT[EN_MAX_BODIES];
} ImpactOp;
static void restitution(const Model *M, double *y, double kineticBefore, int contact);
static int impact_op(const Model *M, double *y, void *ctx) {
    ImpactOp *o = ctx;
    memcpy(o->touching, o->in, sizeof(o->in));
    double E0 = engine_kinetic(&M->d.en, y);
    int fail = engine_impact_m(&M->d.en, &M->s.en, y, o->touching, o->stuck, o->PN, o->PT);
    if (o->k >= 0) restitution(M, y, E0, o->k);
    return !fail;
}

/* The rates projected onto the constraints of m (engine_project; anchors xi0 or NULL). */
typedef struct {
    const EnMode *m;
    const double *xi0;
} ProjectOp;
static int project_op(const Model *M, double *y, void *ctx) {
    ProjectOp *o = ctx;
    engine_project(&M->d.en, o->m, y, o->xi0, 1);
    return 1;
}
static void project_rates(const Model *M, const EnMode *m, double *y, const double *xi0) {
    ProjectOp o = {m, xi0};
    with_floor(M, y, project_op, &o);
}

/* The plastic impact onto the constraints of m (engine_plastic) in the system sys, accepted if it keeps the
 * kinetic energy relative to the support within `slack` of the one before. */
typedef struct {
    const EnSystem *sys;
    const EnMode *m;
    double slack;
} PlasticOp;
static int plastic_op(const Model *M, double *y, void *ctx) {
    PlasticOp *o = ctx;
    double E0 = engine_kinetic(&M->d.en, y);
    return engine_plastic(o->sys, o->m, y) && engine_kinetic(&M->d.en, y) <= E0 * o->slack;
}

/* Bookkeeping of a change of contact set at S->t: slides and flights that start or end. */
static void changed(Model *M, const EnMode *was, const EnMode *now, const Logger *log) {
    State *S = &M->s;
    int nb = M->d.en.nb;
    for (int k = 0; k < nb; k++) {
        int fw = flying(was, k), fn = flying(now, k);
        if (!fw && fn) {
            S->flights[k]++;
            S->flightSince[k] = S->t;
            say(log, LOG_EVENTS, "flight t=%.17g body=%d", S->t, k + 1);
        } else if (fw && !fn) {
            S->flightDur[k] += S->t - S->flightSince[k];
            say(log, LOG_EVENTS, "land t=%.17g body=%d", S->t, k + 1);
        }
        /* a stack's flat contact that opens onto one corner (the rigid stack's "open") */
        char buf[32];
        const char *who = contact_name(nb, k, buf, sizeof(buf));
        if (nb >= 2 && S->pending == EVENT_OPEN && was->closed[k][0] && was->closed[k][1] && now->closed[k][0] != now->closed[k][1])
            say(log, LOG_EVENTS, "open t=%.17g%s", S->t, who);
        Track r = track(S, k);
        int *starts = r.starts;
        double *since = r.since, *dur = r.dur, *first = r.first;
        int sw = was->sigma[k] != 0, sn = now->sigma[k] != 0;
        if (!sw && sn) {
            (*starts)++;
            *since = S->t;
            if (*first < 0) *first = S->t;
            if (S->slideTime < 0) S->slideTime = S->t;
            say(log, LOG_EVENTS, "slide t=%.17g sigma=%d mode=%s%s", S->t, now->sigma[k],
                now->closed[k][0] && now->closed[k][1] ? "slide" : "slide-rock", who);
        } else if (sw && !sn) {
            *dur += S->t - *since;
            if (!fn) say(log, LOG_EVENTS, "stick t=%.17g%s", S->t, who);
        } else if (sw && sn && was->sigma[k] != now->sigma[k]) {
            say(log, LOG_EVENTS, "reverse t=%.17g sigma=%d%s", S->t, now->sigma[k], who);
        }
    }
}

/* The side (+1 right, -1 left) body 0 rocks on, for the rigid model's fields. */
static int side_of(const EnMode *m, const double *y) {
    if (m->closed[0][1] && !m->closed[0][0]) return 1;
    if (m->closed[0][0] && !m->closed[0][1]) return -1;
    return y[EN_TH(0)] > 0 ? 1 : y[EN_TH(0)] < 0 ? -1 : 1;
}

/* Set the contact set m (at S->t, S->y) as the state's. */
static void set_mode(Model *M, const EnMode *m, const Logger *log) {
    State *S = &M->s;
    const EnSystem *sys = &M->d.en;
    for (int k = 0; k < sys->nb; k++) { /* a contact that sticks on through the event has not slipped */
        int stuckBefore = !flying(&S->en, k) && S->en.sigma[k] == 0 && S->mode != MODE_OVERTURNED;
        if (!flying(m, k) && !(stuckBefore && m->sigma[k] == 0)) S->enAnchor[k] = slip_of(sys, m, k, S->y, NULL, NULL);
    }
    changed(M, &S->en, m, log);
    S->en = *m;
    project_rates(M, m, S->y, NULL);
    S->side = side_of(m, S->y);
    S->sigma = m->sigma[0];
    S->mode = MODE_ROCKING;
    S->fValid = 0;
}

/* Two-way: every body at rest on floor j from S->t, the support with them in closed form (support.h's SupportRest)
 * while the base's inputs are zero; the floors' components of S->y are then those of S->t until rest_closed_end.
 * Returns 1 if it started. */
static int rest_closed(Model *M) {
    State *S = &M->s;
    int nb = M->d.en.nb, ns = M->d.sup.ns;
    if (model_inputs_on(M) || support_rest_start(M, S->t, S->y + EN_N(nb))) return 0;
    S->restE0 = coupling_total_energy(M, S->y);
    S->restW0 = S->y[COUPLING_WORK(nb, ns)];
    S->restD0 = S->y[COUPLING_DAMP(nb, ns)];
    return 1;
}

/* The support's components of y at t (at or after the rest's start) from the closed form: the floors, the base's
 * work, and the dampers' loss by the energy balance (the base's work less what blocks and support gained). */
static void rest_closed_at(Model *M, double t, double *y) {
    int nb = M->d.en.nb, ns = M->d.sup.ns;
    support_rest_floors(M, t, y + EN_N(nb));
    double W = M->s.restW0 + support_rest_work(M, t);
    y[COUPLING_WORK(nb, ns)] = W;
    y[COUPLING_DAMP(nb, ns)] = M->s.restD0 + (W - M->s.restW0) - (coupling_total_energy(M, y) - M->s.restE0);
}

/* The closed form ends at t: the support's components of S->y from it. */
static void rest_closed_end(Model *M, double t) {
    if (!M->s.rest.on) return;
    rest_closed_at(M, t, M->s.y);
    M->s.rest.on = 0;
    M->sup = NULL;
}

/* The bodies' centres' x at rest (y's EN_POS(., k, 0)): each body's axis at its contact's slip (slip[k]; NULL: 0)
 * from its support's axis (the ground's: x = 0), its centre xG from its axis. */
static void rest_centres(const EnSystem *s, double *y, const double *slip) {
    double axis = 0.0;
    for (int k = 0; k < s->nb; k++) {
        double X = axis + (slip ? slip[k] : 0.0);
        y[EN_POS(s->nb, k, 0)] = X + s->body[k].xG;
        axis = X;
    }
}

/* Every body flat and sticking on its support, at rest relative to it (announce: log "rest"; a slide that
 * stops has logged its "stick"). */
static void come_to_rest(Model *M, const Logger *log, int announce) {
    State *S = &M->s;
    const EnSystem *sys = &M->d.en;
    EnMode m;
    memset(&m, 0, sizeof(m));
    memcpy(m.over, S->en.over, sizeof(m.over)); /* (an overhang stays) */
    for (int k = 0; k < sys->nb; k++) m.closed[k][0] = m.closed[k][1] = 1;
    for (int k = 0; k < sys->nb; k++) S->enAnchor[k] = slip_of(sys, &S->en, k, S->y, NULL, NULL);
    int two = coupling_on(M);
    double E0 = energy(M, S->y), mtot, px = coupling_momentum(sys, S->y, &mtot);
    engine_rest_state(sys, S->y);
    rest_centres(sys, S->y, S->enAnchor);
    if (two) { /* the bodies stop on their floor, which keeps the horizontal momentum of both */
        for (int k = 0; k < sys->nb; k++) S->y[EN_XI(sys->nb, k)] = S->y[EN_XID(sys->nb, k)] = 0.0;
        coupling_carry(M, S->y, px, mtot);
    }
    S->impactLoss += E0 - energy(M, S->y); /* what the rest criterion stops */
    changed(M, &S->en, &m, log);
    S->en = m;
    /* two-way: at rest with its floor in closed form where it can be, else as a contact set the engine integrates
     * with its floor (its forces' indicators end it) */
    S->mode = two && !rest_closed(M) ? MODE_ROCKING : MODE_REST;
    S->side = 1;
    S->sigma = 0;
    S->restTime = S->t;
    S->h = 0.0;
    S->fValid = 0;
    if (announce) say(log, LOG_EVENTS, "rest t=%.17g", S->t);
}

/* ----------------------------------------------------------------- choosing modes */

/* The complementarity problem's choice on a two-way support at the state y under the base's (ag, av): floor j's
 * acceleration d (relative to the base) with it, m_j (d - r_j) + T(ag + d) = 0, T the floor's force on body 0 in
 * the set chosen under the floor's acceleration ag + d. T is piecewise affine and nondecreasing in it, so the
 * root is one: Newton's method on the chosen set's line (exact once the set repeats), kept in its bracket. */
static int choose_on_floor(const Model *M, double t, const double *y, double ag, double av, int touching[][2], const int *stuck,
                           EnMode *out) {
    const EnSystem *sys = &M->d.en;
    double r[SUPPORT_MAX_STOREYS], mj = coupling_floor_mass(M), lo = -INFINITY, hi = INFINITY;
    coupling_free(M, t, y, ag, r);
    double d = r[M->d.sup.j];
    EnMode m;
    for (int it = 0; it < 60; it++) {
        EnForces f, g;
        int rc = engine_choose_m(sys, &M->s.en, y, ag + d, av, (const int(*)[2])touching, stuck, &m, &f);
        if (rc) return rc;
        if (!engine_solve(sys, &m, y, ag + d, av, &f) || !engine_solve(sys, &m, y, ag + d + 1.0, av, &g)) break;
        double h = mj * (d - r[M->d.sup.j]) + f.T[0], Ta = g.T[0] - f.T[0];
        if (fabs(h) <= 64.0 * DBL_EPSILON * (mj * (fabs(d) + fabs(r[M->d.sup.j])) + fabs(f.T[0]))) break;
        if (h < 0) lo = fmax(lo, d);
        else hi = fmin(hi, d);
        double dn = d - h / (mj + Ta);
        if (!(dn > lo && dn < hi)) dn = isfinite(lo) && isfinite(hi) ? 0.5 * (lo + hi) : dn;
        if (dn == d) break;
        d = dn;
    }
    *out = m;
    return 0;
}

/* A rate (m/s) below rounding's reach and far below any motion: an open corner at its face approaching it faster comes
 * down onto it (an impact); a slip rate against a contact's sliding direction by more is not rounding. */
static double approach_rate(const Model *M) { return 1e-9 * sqrt(M->d.en.g * M->d.R); }
/* A normal rate (m/s) within rounding of zero (64 eps of sqrt(g R)): an open corner at its face that moves no faster
 * stays at it (a rebound of 1e-9 m/s leaves it: a motion, which the landing indicator follows). */
static double rest_rate(const Model *M) { return 64.0 * DBL_EPSILON * sqrt(M->d.en.g * M->d.R); }

/* The complementarity problem's choice at (t, y) over the corners `touching` and the sticking
 * candidates `stuck`, its data taken LOOK_AHEAD / p after the event along the motion dy (the
 * problem is degenerate at an event located where a force or margin vanishes). Returns 0, or 1 if
 * it has no solution. */
static int choose(const Model *M, double t, const double *y, const double *dy, int touching[][2], const int *stuck,
                  EnMode *out) {
    const EnSystem *sys = &M->d.en;
    double d = LOOK_AHEAD * time_scale(M), ya[NMAX], ah, av;
    int n = nstate(M);
    memcpy(ya, y, sizeof(ya));
    if (dy)
        for (int i = 0; i < n; i++) ya[i] += d * dy[i];
    model_ground_piece(M, t + (dy ? d : 0.0), model_piece(M, t), &ah, &av);
    EnForces f;
    int rc = coupling_on(M) ? choose_on_floor(M, t + (dy ? d : 0.0), ya, ah, av, touching, stuck, out)
                            : engine_choose_m(sys, &M->s.en, ya, ah, av, (const int(*)[2])touching, stuck, out, &f);
    if (rc || !dy) return rc;
    /* the look-ahead passed a slip's stop (a contact left sliding by an impact at a rate that friction stops within
     * it): the set would slide it against its slip rate at the event, its friction feeding the slip. The choice at
     * the event itself instead. */
    for (int k = 0; k < sys->nb; k++) {
        double vs;
        if (!out->sigma[k] || flying(out, k)) continue;
        slip_of(sys, out, k, y, &vs, NULL);
        if (out->sigma[k] * vs < -approach_rate(M)) return choose(M, t, y, NULL, touching, stuck, out);
    }
    return 0;
}

/* The derivative of the state at S->t in the contact set m. */
static void derivative(const Model *M, const EnMode *m, double *dy) {
    Ctx c;
    context(&c, M, m, M->s.t);
    c.chain = c.slides = c.resting = 0; /* m may not be the state's contact set: its anchors are not known */
    memset(dy, 0, sizeof(double) * NMAX);
    rhs_cb(&c, M->s.t, M->s.y, dy);
}

/* An open corner (index i) of body j in the contact set m at y that lies at its face or below it: its gap within
 * rounding (64 eps R) or negative, or, the body rocking on its other corner, its rotation relative to its support on
 * the wrong side of zero (its landing indicator, engine_indicators, not positive). Its normal rate to *gd. An event's
 * projection of the rates onto a new contact set (a settling body, a contact that sticks) can leave such a corner
 * approaching its face, a landing its indicator, already at or below zero, would never see. */
static int open_at_face(const Model *M, const EnMode *m, const double *y, int j, int i, double *gd) {
    const EnSystem *sys = &M->d.en;
    if (m->closed[j][i]) return 0;
    EnPoint p;
    engine_corner_m(sys, m, j, 2 * i - 1, y, &p);
    *gd = p.gd;
    if (p.g <= 64.0 * DBL_EPSILON * M->d.R) return 1;
    if (!m->closed[j][!i]) return 0;
    double rel = y[EN_TH(j)] - (j > 0 ? y[EN_TH(j - 1)] : 0.0);
    return (1 - 2 * i) * rel <= 0.0; /* (the closed corner's side times rel: engine_indicators' landing) */
}

/* The corners an event's choice covers: those touching, and every open corner at its face (open_at_face, its body's
 * other corner as touching has it) that does not leave it (its normal rate not above rest_rate): the choice
 * closes it, or opens it with a normal acceleration that lifts it (left out, it would sink through its face unseen:
 * its landing indicator starts at or below zero). */
static int touching_at_face(const Model *M, int touching[][2]) {
    const EnSystem *sys = &M->d.en;
    EnMode m = M->s.en;
    int added = 0;
    for (int j = 0; j < sys->nb; j++) {
        m.closed[j][0] = touching[j][0];
        m.closed[j][1] = touching[j][1];
    }
    for (int j = 0; j < sys->nb; j++)
        for (int i = 0; i < 2; i++) {
            double gd;
            if (open_at_face(M, &m, M->s.y, j, i, &gd) && gd <= rest_rate(M)) touching[j][i] = added = 1;
        }
    return added;
}

/* Whether the contact set m at S->y leaves a corner open at its face (open_at_face), not leaving it, whose normal
 * acceleration in m drives it into the face (beyond rounding): it would sink unseen. */
static int sinks(const Model *M, const EnMode *m) {
    const State *S = &M->s;
    const EnSystem *sys = &M->d.en;
    EnForces f;
    double ah, av;
    int solved = 0;
    for (int j = 0; j < sys->nb; j++)
        for (int i = 0; i < 2; i++) {
            double gd;
            if (!open_at_face(M, m, S->y, j, i, &gd) || gd > rest_rate(M)) continue;
            if (!solved) {
                model_ground(M, S->t, &ah, &av);
                if (isnan(solve_at(M, S->t, m, S->y, ah, av, &f))) return 0;
                solved = 1;
            }
            EnPoint p;
            engine_point_m(sys, m, j, 2 * i - 1, S->y, &p);
            double gdd = p.bN;
            for (int q = 0; q < 3 * sys->nb; q++) gdd += p.wN[q] * f.qdd[q];
            if (gdd < -EN_ROUNDING * sys->g) return 1;
        }
    return 0;
}

/* The contact set that follows at S->t from the touching corners and sticking candidates, with a
 * Painleve point (no consistent set) resolved by the impact without collision of Genot & Brogliato
 * (1999): the sliding contact takes the plastic impact of the impact law; if that leaves no
 * consistent set either, it sticks. */
static void settle_mode(Model *M, int touching[][2], int *stuck, const double *dy, const Logger *log) {
    State *S = &M->s;
    EnMode m;
    if (choose(M, S->t, S->y, dy, touching, stuck, &m) == 0) {
        /* a corner the choice leaves open at its face, not leaving it, that the set's accelerations drive into it:
         * the choice again with it (and every such corner) among the touching */
        int face[EN_MAX_BODIES][2];
        memcpy(face, touching, sizeof(face));
        EnMode again;
        if (sinks(M, &m) && touching_at_face(M, face) &&
            choose(M, S->t, S->y, dy, face, stuck, &again) == 0) {
            memcpy(touching, face, sizeof(face));
            m = again;
        }
        set_mode(M, &m, log);
        return;
    }
    const EnSystem *sys = &M->d.en;
    double E0 = kinetic(M, S->y);
    S->painleve++;
    ImpactOp op;
    memcpy(op.in, touching, sizeof(op.in));
    op.k = -1;
    with_floor(M, S->y, impact_op, &op);
    memcpy(touching, op.touching, sizeof(op.touching));
    memcpy(stuck, op.stuck, sizeof(op.stuck));
    S->impactLoss += E0 - kinetic(M, S->y);
    say(log, LOG_EVENTS, "painleve t=%.17g", S->t);
    if (choose(M, S->t, S->y, NULL, touching, stuck, &m) != 0) {
        for (int k = 0; k < sys->nb; k++) stuck[k] = 1;
        memset(&m, 0, sizeof(m));
        EnMode st = S->en;
        for (int k = 0; k < sys->nb; k++) st.sigma[k] = 0;
        project_rates(M, &st, S->y, NULL);
        if (choose(M, S->t, S->y, NULL, touching, stuck, &m) != 0) m = st;
    }
    set_mode(M, &m, log);
}

/* The motion left is negligible (the rest criterion of an impact, in energy): the ground below the
 * threshold that starts the bodies at rest, and a kinetic energy that would lift the centre of mass
 * less than a rebound to restRatio * alpha does. */
static double rest_exit(const Model *M, double t, int piece);
static void fell_off(Model *M, int k, const Logger *log);

/* A rebound of kinetic energy `energy` (J) lifts a body of mass m (kg), turning about a corner at R (m)
 * from its centre, under the gravity geff (m/s2), less than to restRatio of its slenderness angle alpha. */
static int below_rest(const Model *M, double energy, double m, double R, double alpha, double geff) {
    return energy < m * geff * R * (cos(alpha - M->v.restRatio * alpha) - cos(alpha));
}

/* What a rebound at body k's contact lifts, as one rigid body about the corner it pivots on: the sub-column of body k
 * and those above it, at rest (axes aligned), of mass m (kg), inertia I0 about the corner (kg m^2), centre R (m) from
 * it at the angle alpha (rad) from the vertical; of its two corners the one of the smaller alpha (the easier to lift).
 * A stack of two rectangles takes the rigid stack's values (the pair about block 1's corner, block 2 about its own). */
static void sub_column(const Model *M, int k, double *m, double *R, double *alpha, double *I0) {
    const EnSystem *sys = &M->d.en;
    const Derived *d = &M->d;
    if (sys->nb == 2 && !model_polygons(&M->v)) {
        *m = k ? M->v.mass2 : d->mTot;
        *R = k ? d->RI : d->RL;
        *alpha = k ? d->alphaI : d->alphaL;
        *I0 = k ? d->II : d->IL;
        return;
    }
    /* the centres from body k's axis (x) and base (y) */
    double mass = 0.0, mx = 0.0, my = 0.0, base = 0.0, xc[EN_MAX_BODIES], yc[EN_MAX_BODIES];
    for (int j = k; j < sys->nb; j++) {
        const EnBody *B = &sys->body[j];
        xc[j] = B->xG;
        yc[j] = base - B->cy;
        mass += B->m;
        mx += B->m * xc[j];
        my += B->m * yc[j];
        base = yc[j] + B->ht;
    }
    double xG = mx / mass, yG = my / mass, bL = xG - sys->body[k].xa[0], bR = sys->body[k].xa[1] - xG;
    double corner = bR <= bL ? sys->body[k].xa[1] : sys->body[k].xa[0], b = fmin(bL, bR), I = 0.0;
    for (int j = k; j < sys->nb; j++) {
        double dx = xc[j] - corner;
        I += sys->body[j].Ic + sys->body[j].m * (dx * dx + yc[j] * yc[j]);
    }
    *m = mass;
    *R = sqrt(b * b + yG * yG);
    *alpha = atan(b / yG);
    *I0 = I;
}

static int negligible(const Model *M, double t, const double *y) {
    double ah, av;
    model_ground(M, t, &ah, &av);
    if (coupling_on(M)) { /* the floor's acceleration with the bodies at rest on it */
        EnMode r;
        EnForces f;
        memset(&r, 0, sizeof(r));
        memcpy(r.over, M->s.en.over, sizeof(r.over));
        for (int k = 0; k < M->d.en.nb; k++) r.closed[k][0] = r.closed[k][1] = 1;
        ah = solve_at(M, t, &r, y, ah, av, &f);
    }
    double geff = M->v.g + av;
    const EnSystem *sys = &M->d.en;
    int stack = sys->nb >= 2;
    if (stack ? !(rest_exit(M, t, model_piece(M, t)) <= 0.0) : !(geff > 0 && fabs(ah) <= geff * M->d.upliftSlope))
        return 0;
    /* one block; a stack or column: all of it as one body about block 1's corner */
    double alpha = M->d.alpha, R = M->d.R, m = M->v.mass, I0;
    if (stack) sub_column(M, 0, &m, &R, &alpha, &I0);
    if (!below_rest(M, engine_kinetic(sys, y), m, R, alpha, geff)) return 0;
    /* and each upper block's rocking on the one below as the rigid stack settles block 2's: the sub-column it
     * carries about its corner, to restRatio of that one's alpha */
    for (int k = 1; k < sys->nb; k++) {
        double w = y[EN_W(k)] - y[EN_W(k - 1)];
        sub_column(M, k, &m, &R, &alpha, &I0);
        if (!below_rest(M, 0.5 * I0 * w * w, m, R, alpha, geff)) return 0;
    }
    return 1;
}

/* The restitution law on the plastic impact's rates (kineticBefore: the kinetic energy before the impact,
 * J; contact: the landing contact, 0 the ground, 1 between the blocks). One block: law 0 (Housner) with
 * correction 1 is the plastic impact itself; otherwise the rates after (relative to the ground) are scaled
 * by eta / eta_Housner, which gives a block landing on a sticking corner from rocking the rigid model's
 * w+ = eta w-, and never past the kinetic energy before. A stack: the momentum law (0) is the plastic
 * impact; the constant law (2) scales the plastic impact's rates so that it keeps etaGround^2 (or
 * etaInterface^2) of the kinetic energy, the rigid stack's definition (docs/two_blocks.md). */
static void restitution(const Model *M, double *y, double kineticBefore, int contact) {
    const EnSystem *sys = &M->d.en;
    double after = engine_kinetic(sys, y), factor;
    if (sys->nb >= 2) {
        if (M->v.law != 2 || !(after > 0)) return;
        double eta = contact ? M->v.etaInterface : M->v.etaGround;
        factor = eta * sqrt(kineticBefore / after);
    } else {
        double sa = sin(M->d.alpha), etaH = 1.0 - 1.5 * sa * sa;
        factor = M->d.eta / etaH;
        if (factor == 1.0) return;
        if (factor * factor * after > kineticBefore) factor = sqrt(kineticBefore / after);
    }
    for (int k = 0; k < sys->nb; k++)
        for (int i = 0; i < 3; i++) y[EN_VEL(sys->nb, k, i)] *= factor;
}

/* -------------------------------------------------------------------- events */

/* The run ends at S->t (an overturn, or block 2 falling off block 1): the bodies stay where they are,
 * still; the slides and flights under way end. */
static void finish(Model *M) {
    State *S = &M->s;
    int nb = M->d.en.nb;
    S->mode = MODE_OVERTURNED;
    /* two-way: the bodies stop on their floor (a plastic hit that keeps the horizontal momentum of bodies plus
     * floor), which carries them from then on (support_after_end) */
    int two = coupling_on(M);
    double E0 = energy(M, S->y), mtot, px = coupling_momentum(&M->d.en, S->y, &mtot);
    for (int j = 0; j < nb; j++)
        for (int i = 0; i < 3; i++) S->y[EN_VEL(nb, j, i)] = 0.0;
    if (two) {
        coupling_carry(M, S->y, px, mtot);
        S->impactLoss += E0 - energy(M, S->y);
        S->h = 0.0;
        S->denseValid = 0;
        rest_closed(M); /* the floor carries them: in closed form where it can */
    }
    for (int j = 0; j < nb; j++)
        if (S->en.sigma[j]) {
            Track r = track(S, j);
            *r.dur += S->t - *r.since;
        }
    for (int j = 0; j < nb; j++)
        if (flying(&S->en, j)) S->flightDur[j] += S->t - S->flightSince[j];
    S->enFinal = S->en; /* each contact as it was at the end */
    memset(&S->en, 0, sizeof(S->en));
    S->sigma = 0;
}

/* Body k's rotation relative to its support reached pi/2: it falls, and takes the blocks above it with it (block 1
 * the whole stack or column); the run ends. */
static void overturn(Model *M, int k, const Logger *log) {
    State *S = &M->s;
    int nb = M->d.en.nb;
    double rel = S->y[EN_TH(k)] - (k > 0 ? S->y[EN_TH(k - 1)] : 0.0);
    int side = rel > 0 ? 1 : -1;
    S->overturnTime = S->t;
    S->overturned2 = nb == 2 || (nb > 2 && k <= 1);
    S->fallenBody = k + 1;
    if (k == 0) {
        S->overturned1 = 1;
        S->maxAbsTheta = M->d.en.body[0].over[side > 0];
        S->side = side;
    }
    finish(M);
    if (nb == 2) say(log, LOG_EVENTS, "overturn t=%.17g blocks=%s", S->t, k == 0 ? "1+2" : "2");
    else if (nb > 2) say(log, LOG_EVENTS, "overturn t=%.17g blocks=%d-%d side=%d", S->t, k + 1, nb, side);
    else say(log, LOG_EVENTS, "overturn t=%.17g side=%d", S->t, side);
}

/* Body k (k > 0) has left the top of the one below it (a corner it stood on passed the edge, or a corner came down
 * beyond it): it falls off, with the blocks above it; the run ends. */
static void fell_off(Model *M, int k, const Logger *log) {
    State *S = &M->s;
    S->fellOff = 1;
    S->fellOffTime = S->t;
    S->fallenBody = k + 1;
    const EnSystem *sys = &M->d.en;
    double u = slip_of(sys, &S->en, k, S->y, NULL, NULL);
    finish(M);
    if (sys->nb == 2) say(log, LOG_EVENTS, "fell-off t=%.17g u2=%.17g", S->t, u);
    else say(log, LOG_EVENTS, "fell-off t=%.17g block=%d u=%.17g", S->t, k + 1, u);
}

/* After an impact, a body left rocking on one corner with a rotation rate (relative to its support)
 * whose rebound would stay below restRatio of its slenderness angle (the rest criterion on the
 * rotation alone) lands flat: its rates are projected onto both corners' constraints (its slip goes
 * on). Without this rule a sliding block's ever smaller rocking impacts would never end. */
static void close_negligible(Model *M, int touching[][2], int *stuck, const Logger *log) {
    State *S = &M->s;
    const EnSystem *sys = &M->d.en;
    double ah, av;
    model_ground(M, S->t, &ah, &av);
    double geff = sys->g + av;
    if (!(geff > 0)) return;
    for (int k = 0; k < sys->nb; k++) {
        if (touching[k][0] == touching[k][1]) continue;
        const EnBody *B = &sys->body[k];
        /* what the rebound lifts: the body about its corner; in a stack the rigid stack's (docs/two_blocks.md),
         * the pair about block 1's corner for the ground, block 2 about its corner for the interface */
        double R = hypot(B->b, B->h), alpha = atan2(B->b, B->h), I0 = B->Ic + B->m * R * R, m = B->m;
        if (sys->nb >= 2) sub_column(M, k, &m, &R, &alpha, &I0);
        else if (model_block_polygon(&M->v, 0)) R = M->d.R, alpha = M->d.alpha, I0 = M->d.I0;
        double w = S->y[EN_W(k)] - (k > 0 ? S->y[EN_W(k - 1)] : 0.0);
        double rel = S->y[EN_TH(k)] - (k > 0 ? S->y[EN_TH(k - 1)] : 0.0);
        if (fabs(rel) > 1e-9 * alpha) continue;
        if (!below_rest(M, 0.5 * I0 * w * w, m, R, alpha, geff)) continue;
        /* the contacts as the impact left them (touching, sticking where it stuck), body k's closed flat */
        EnMode flat = S->en;
        for (int j = 0; j < sys->nb; j++) {
            double vs;
            slip_of(sys, &S->en, j, S->y, &vs, NULL);
            flat.closed[j][0] = touching[j][0] || j == k;
            flat.closed[j][1] = touching[j][1] || j == k;
            flat.sigma[j] = stuck[j] ? 0 : vs > 0 ? 1 : vs < 0 ? -1 : 0;
        }
        double E0 = kinetic(M, S->y), keep[NMAX];
        memcpy(keep, S->y, sizeof(keep));
        engine_project(sys, &flat, S->y, NULL, 0); /* the positions exactly flat */
        /* the plastic impact onto the set (each contact keeping its friction: the rigid stack's rule); where
         * its friction would add kinetic energy (a normal impulse that pulls while block 2 slides) there is no
         * settling, unless impacts accumulate (CHATTER_RUN): then the rates are projected mass-orthogonally
         * onto the set's equalities, the sliding contacts' friction left out, which never adds any (without
         * it a plinth chattered at 1e-8 s per impact under its sliding statue) */
        double projected[NMAX];
        memcpy(projected, S->y, sizeof(projected));
        PlasticOp op = {sys, &flat, 1.0};
        int ok = with_floor(M, S->y, plastic_op, &op);
        if (!ok && S->impactRun >= CHATTER_RUN) {
            EnSystem smooth = *sys;
            for (int j = 0; j < sys->nb; j++)
                if (flat.sigma[j]) smooth.mu[j] = 0.0;
            memcpy(S->y, projected, sizeof(projected));
            PlasticOp op2 = {&smooth, &flat, 1.0 + 64.0 * DBL_EPSILON};
            ok = with_floor(M, S->y, plastic_op, &op2);
        }
        if (!ok) { /* (the rigid stack's test: no settling) */
            memcpy(S->y, keep, sizeof(keep));
            continue;
        }
        S->impactLoss += E0 - kinetic(M, S->y);
        touching[k][0] = touching[k][1] = 1;
        stuck[k] = flat.sigma[k] == 0;
        say(log, LOG_EVENTS, "flat t=%.17g body=%d", S->t, k + 1);
    }
}

static void impact(Model *M, const Logger *log) {
    State *S = &M->s;
    const EnSystem *sys = &M->d.en;
    int k = S->eventContact, i = S->eventEnd > 0 ? 1 : 0;
    int touching[EN_MAX_BODIES][2], stuck[EN_MAX_BODIES];
    EnMode land = S->en;
    land.closed[k][i] = 1;
    /* the other corners within the integrator's resolution of their support land with it (a body that
     * flies flat lands flat): approaching corners with gaps below 100 max(relTol, absTol) R; and every
     * corner at zero gap to rounding, approaching or not (one that opened at this instant, in a cascade of
     * impacts: the impact's complementarity problem keeps it open if it separates, and does not leave it
     * to land again at once) */
    double tol = 100.0 * fmax(M->v.relTol, M->v.absTol) * M->d.R, zero = 64.0 * DBL_EPSILON * M->d.R;
    /* the projection puts the landing corners exactly at zero gap, and moves their bodies (a penetration found
     * late, or the integrator's error): it moves the support of a body above with them, whose corner may then
     * penetrate or come within the resolution. Those land too, and the projection is taken again, until no
     * corner is left penetrating (each pass closes at least one corner, so at most all of them) */
    for (int pass = 0; pass <= 2 * sys->nb; pass++) {
        int more = 0;
        for (int j = 0; j < sys->nb; j++)
            for (int c = 0; c < 2; c++) {
                EnPoint p;
                if (land.closed[j][c]) continue;
                engine_corner_m(sys, &land, j, 2 * c - 1, S->y, &p);
                if ((p.g <= tol && p.gd <= 0) || p.g <= zero) land.closed[j][c] = more = 1;
            }
        if (pass > 0 && !more) break;
        engine_project(sys, &land, S->y, NULL, 0); /* the landing corner exactly at zero gap */
    }
    for (int j = 0; j < sys->nb; j++) {
        touching[j][0] = land.closed[j][0];
        touching[j][1] = land.closed[j][1];
    }
    double before[NMAX], E0 = kinetic(M, S->y), wm = S->y[EN_W(0)], vm = 0.0;
    int logs = says(log, LOG_EVENTS);
    if (logs) { /* (the rates before, for the message alone) */
        memcpy(before, S->y, sizeof(before));
        slip_of(sys, &S->en, 0, S->y, &vm, NULL);
    }
    ImpactOp op;
    memcpy(op.in, touching, sizeof(op.in));
    op.k = k;
    if (!with_floor(M, S->y, impact_op, &op)) say(log, LOG_ERROR, "no plastic impact found at t=%.17g", S->t);
    memcpy(touching, op.touching, sizeof(op.touching));
    memcpy(stuck, op.stuck, sizeof(op.stuck));
    double Pn = op.PN[0][0] + op.PN[0][1];
    if (Pn > 0 && fabs(op.PT[0]) / Pn > S->impulseDemandMax) S->impulseDemandMax = fabs(op.PT[0]) / Pn;
    S->impacts++;
    if (k == 0) S->impactsGround++;
    else S->impactsInterface++;
    S->impactRun = S->lastImpactTime >= 0 && S->t - S->lastImpactTime < CHATTER_INTERVAL * time_scale(M)
                       ? S->impactRun + 1 : 0;
    S->impactsNow = S->lastImpactTime == S->t ? S->impactsNow + 1 : 1;
    S->lastImpactTime = S->t;
    S->impactLoss += E0 - kinetic(M, S->y);
    if (logs) { /* (slip rates for the message alone) */
        double vp;
        slip_of(sys, &S->en, 0, S->y, &vp, NULL);
        if (sys->nb == 2) {
            double v2m = 0.0, v2p;
            slip_of(sys, &S->en, 1, before, &v2m, NULL);
            slip_of(sys, &S->en, 1, S->y, &v2p, NULL);
            say(log, LOG_EVENTS,
                "impact t=%.17g contact=%s theta1=%.17g theta2=%.17g w1m=%.17g w2m=%.17g w1p=%.17g w2p=%.17g "
                "slip_rate_minus=%.17g,%.17g slip_rate_plus=%.17g,%.17g",
                S->t, k ? "interface" : "ground", S->y[EN_TH(0)], S->y[EN_TH(1)], wm, before[EN_W(1)],
                S->y[EN_W(0)], S->y[EN_W(1)], vm, v2m, vp, v2p);
        } else if (sys->nb > 2) {
            char buf[32];
            say(log, LOG_EVENTS, "impact t=%.17g%s block=%d theta=%.17g omega_minus=%.17g omega_plus=%.17g", S->t,
                contact_name(sys->nb, k, buf, sizeof(buf)), k + 1, S->y[EN_TH(k)], before[EN_W(k)], S->y[EN_W(k)]);
        } else {
            say(log, LOG_EVENTS,
                "impact t=%.17g omega_minus=%.17g omega_plus=%.17g slip_rate_minus=%.17g slip_rate_plus=%.17g",
                S->t, wm, S->y[EN_W(0)], vm, vp);
        }
    }
    if (negligible(M, S->t, S->y)) {
        come_to_rest(M, log, 1);
        return;
    }
    close_negligible(M, touching, stuck, log);
    settle_mode(M, touching, stuck, NULL, log);
}

/* Body k's corner at end c passed its support's top corner c (docs/columns.md, "Overhangs"): the contact at that end
 * changes its pair (EnMode's over). Where the end is closed the two pairs' points coincide there (to EN_EDGE_MARGIN of
 * the support's half width): a flat body's gap, forces and rates go on, and so does its slip (either pair's slip is
 * its axis from the support's). A body on that end alone, tilted, meets the new pair with a normal rate (its slip
 * rate times the sine of its rotation relative to the support): its base turns away from the support's corner (a
 * corner that slides past the edge of the top with the body tipped over it: it drops there, the end opens) or comes
 * down onto the top (an impact of its corner). An open end changes its gap's pair alone. */
static void overhang(Model *M, const Logger *log) {
    State *S = &M->s;
    const EnSystem *sys = &M->d.en;
    int k = S->eventContact, c = S->eventEnd, i = c > 0;
    S->en.over[k][i] = !S->en.over[k][i];
    say(log, LOG_EVENTS, "overhang t=%.17g body=%d end=%d over=%d", S->t, k + 1, c, S->en.over[k][i]);
    S->fValid = 0;
    S->enIndValid = 0;
    if (!S->en.closed[k][i] || S->en.closed[k][!i]) return;
    EnPoint p;
    engine_corner_m(sys, &S->en, k, c, S->y, &p);
    double slow = 1e-9 * sqrt(sys->g * M->d.R);
    if (p.gd < -slow) { /* k's corner comes down onto the top */
        impact(M, log);
        return;
    }
    if (!(p.gd > slow)) return;
    int touching[EN_MAX_BODIES][2], stuck[EN_MAX_BODIES];
    for (int j = 0; j < sys->nb; j++) {
        touching[j][0] = S->en.closed[j][0];
        touching[j][1] = S->en.closed[j][1];
        stuck[j] = S->en.sigma[j] == 0;
    }
    touching[k][i] = 0; /* it separates */
    settle_mode(M, touching, stuck, NULL, log);
}

/* A contact sliding on one corner reached Painleve's singularity (its jam margin, engine_jam_margin, fell to
 * EN_JAM_MARGIN): the normal force its sliding needs grows without bound, and the impulse it delivers stops
 * the slip (Genot & Brogliato 1999). Taken as a plastic sticking impact of that corner (the rates projected
 * onto its zero normal and slip rates, which never adds kinetic energy); then the set is chosen again, and
 * where that would slide on into the singularity, the contact sticks. Counted as a Painleve point. */
static void jam(Model *M, const Logger *log) {
    State *S = &M->s;
    const EnSystem *sys = &M->d.en;
    int k = S->eventContact, touching[EN_MAX_BODIES][2], stuck[EN_MAX_BODIES];
    EnMode st = S->en;
    st.sigma[k] = 0;
    double E0 = kinetic(M, S->y);
    project_rates(M, &st, S->y, NULL);
    S->impactLoss += E0 - kinetic(M, S->y);
    S->painleve++;
    say(log, LOG_EVENTS, "painleve t=%.17g body=%d jam=1", S->t, k + 1);
    for (int j = 0; j < sys->nb; j++) {
        touching[j][0] = S->en.closed[j][0];
        touching[j][1] = S->en.closed[j][1];
        stuck[j] = st.sigma[j] == 0;
    }
    EnMode m;
    if (choose(M, S->t, S->y, NULL, touching, stuck, &m) != 0 ||
        (m.sigma[k] && m.closed[k][0] != m.closed[k][1] && engine_jam_margin(sys, &m, k, S->y) <= EN_JAM_MARGIN))
        m = st;
    set_mode(M, &m, log);
}

/* After an event: an open corner at its face (open_at_face) that approaches it lands, an impact over it (with every
 * corner at zero gap); repeated while the contact set the impact settles into leaves another (at most a few times:
 * each impact leaves the corners it covers at non-negative normal rates). */
static void resolve_approach(Model *M, const Logger *log) {
    State *S = &M->s;
    const EnSystem *sys = &M->d.en;
    for (int pass = 0; pass < 4 * sys->nb && S->mode == MODE_ROCKING; pass++) {
        int hit = -1, end = 0;
        double worst = -approach_rate(M);
        for (int j = 0; j < sys->nb; j++)
            for (int i = 0; i < 2; i++) {
                double gd;
                if (open_at_face(M, &S->en, S->y, j, i, &gd) && gd < worst) {
                    worst = gd;
                    hit = j;
                    end = 2 * i - 1;
                }
            }
        if (hit < 0) return;
        S->pending = EVENT_IMPACT;
        S->eventContact = hit;
        S->eventEnd = end;
        impact(M, log);
        S->pending = EVENT_NONE;
        S->fValid = 0;
    }
}

/* An event located at S->t where a force, friction margin or slip rate vanished. */
static void reselect(Model *M, const Logger *log) {
    State *S = &M->s;
    const EnSystem *sys = &M->d.en;
    int touching[EN_MAX_BODIES][2], stuck[EN_MAX_BODIES];
    EnMode m = S->en;
    if (S->pending == EVENT_SLIP_STOP) { /* the slip rate exactly zero */
        m.sigma[S->eventContact] = 0;
        project_rates(M, &m, S->y, NULL);
    }
    for (int k = 0; k < sys->nb; k++) {
        touching[k][0] = S->en.closed[k][0];
        touching[k][1] = S->en.closed[k][1];
        stuck[k] = m.sigma[k] == 0;
    }
    double dy[NMAX];
    derivative(M, &m, dy);
    /* a flat contact whose slip stops with nothing else moving: at rest? */
    settle_mode(M, touching, stuck, dy, log);
    int still = 1;
    for (int k = 0; k < sys->nb; k++) {
        still &= S->en.closed[k][0] && S->en.closed[k][1] && S->en.sigma[k] == 0;
        for (int q = 0; q < 3; q++) still &= fabs(S->y[EN_VEL(sys->nb, k, q)]) <= 1e-14 * sqrt(sys->g * M->d.R);
    }
    if (still) come_to_rest(M, log, 0);
}

static int apply_event(Model *M, const Logger *log) {
    State *S = &M->s;
    const EnSystem *sys = &M->d.en;
    commit_peaks(M, log);
    for (int k = 0; k < sys->nb; k++) {
        double sl = fabs(!flying(&S->en, k) && S->en.sigma[k] == 0 ? S->enAnchor[k] : slip_of(sys, &S->en, k, S->y, NULL, NULL));
        Track r = track(S, k);
        if (sl > *r.maxSlip) *r.maxSlip = sl;
    }
    for (int k = sys->nb - 1; k >= 0; k--) {
        double *mx = track(S, k).maxTheta;
        if (fabs(S->y[EN_TH(k)]) > *mx) *mx = fabs(S->y[EN_TH(k)]);
    }
    switch (S->pending) {
    case EVENT_IMPACT:
        impact(M, log);
        break;
    case EVENT_OVERTURN:
        overturn(M, S->eventContact, log);
        break;
    case EVENT_JAM:
        jam(M, log);
        break;
    case EVENT_FELL_OFF:
        fell_off(M, S->eventContact, log);
        break;
    case EVENT_OVERHANG:
        overhang(M, log);
        break;
    default:
        reselect(M, log);
        break;
    }
    S->pending = EVENT_NONE;
    S->fValid = 0;
    resolve_approach(M, log);
    return 0;
}

/* Where the rest's indicator turned positive but the complementarity problem, within its rounding, keeps the rest
 * (a force margin within about RIGID_MU eps of zero: rigid rocking's friction), the rest's own least margin decides,
 * so that the two agree and time advances: the corner whose normal force turns negative opens, or the contact
 * whose friction runs out slides against its force. */
static void leave_rest(const Model *M, EnMode *m) {
    const EnSystem *sys = &M->d.en;
    const State *S = &M->s;
    double ah, av, ind[EN_IND];
    int kind[EN_IND], body[EN_IND], corner[EN_IND];
    EnForces f;
    model_ground(M, S->t, &ah, &av);
    if (isnan(solve_at(M, S->t, m, S->y, ah, av, &f))) return;
    int n = engine_indicators(sys, m, S->y, &f, ind, kind, body, corner), least = -1;
    for (int i = 0; i < n; i++)
        if ((kind[i] == EN_IND_OPEN || kind[i] == EN_IND_SLIP) && (least < 0 || ind[i] < ind[least])) least = i;
    if (least < 0 || !(ind[least] <= 0)) return;
    int k = body[least];
    if (kind[least] == EN_IND_OPEN) m->closed[k][corner[least] > 0] = 0;
    else m->sigma[k] = f.T[k] > 0 ? -1 : 1;
}

/* The ground moves the bodies resting at time t (the rest's complementarity problem has another solution
 * there): "uplift" when body 1 starts to rock, then the slide or flight that starts. */
static void start_moving(Model *M, double t, int side, const Logger *log) {
    State *S = &M->s;
    (void)side;
    rest_closed_end(M, t);
    S->t = t;
    S->h = 0.0;
    int nb = M->d.en.nb;
    int touching[EN_MAX_BODIES][2], stuck[EN_MAX_BODIES];
    for (int k = 0; k < nb; k++) {
        touching[k][0] = touching[k][1] = 1;
        stuck[k] = 1;
    }
    double dy[NMAX];
    derivative(M, &S->en, dy);
    EnMode m;
    if (choose(M, S->t, S->y, dy, touching, stuck, &m) != 0) {
        settle_mode(M, touching, stuck, dy, log);
        return;
    }
    if (!memcmp(&m, &S->en, sizeof(m))) leave_rest(M, &m);
    if (m.closed[0][0] != m.closed[0][1]) say(log, LOG_EVENTS, "uplift t=%.17g side=%d", t, m.closed[0][1] ? 1 : -1);
    set_mode(M, &m, log);
}

/* ------------------------------------------------------------------- stepping */

/* The indicators of the contact set at (t, y) (forces: f, or solved here when NULL). */
static int indicators(const Ctx *c, double t, const double *y, const EnForces *f, double *ind, int *kind, int *body,
                      int *corner) {
    EnForces g;
    if (!f) {
        double ah, av;
        model_ground_piece(c->M, t, c->piece, &ah, &av);
        solve_at(c->M, t, &c->mode, y, ah, av, &g);
        f = &g;
    }
    return engine_indicators(c->sys, &c->mode, y, f, ind, kind, body, corner);
}

/* Indicator `which` after a real step of length x from the step's start (first_negative's function). */
typedef struct {
    Ctx *c;
    int n, which;
    double t;
    const double *y, *f0;
    double *y1, *f1;
    Dense *cont;
    Dop853Stages *st; /* (the DOP853 step's stages, to complete its dense output) */
    double x;         /* the length of the step whose result y1, f1, cont hold (-1: none) */
    double shift;     /* added to indicator `which` (a landing watched below its start, LAND_ROUNDING) */
} Search;

static void step_indicators(Search *s, double x, double *ind);

/* v watched from a start shifted by s (take_step's sh; v itself where s is 0) */
static inline double shifted(double v, double s) { return s != 0.0 ? v + s : v; }

static double indicator_after(void *ctx, double x) {
    Search *s = ctx;
    double ind[EN_IND];
    step_indicators(s, x, ind);
    return shifted(ind[s->which], s->shift);
}

/* Every indicator after a real step of length x from the step's start (one step for all). */
static void step_indicators(Search *s, double x, double *ind) {
    int kind[EN_IND], body[EN_IND], corner[EN_IND];
    rk_step(s->c->method, rhs_cb, s->c, s->n, s->t, s->y, s->f0, x, s->y1, s->f1, s->cont, s->st);
    s->x = x;
    complete_last(s->c, s->y, s->y1); /* (the step's last evaluation was at its end) */
    indicators(s->c, s->t + x, s->y1, &s->c->f, ind, kind, body, corner);
}

/* Whether an indicator of kind `kind` of body k is watched at a step's dense samples: the kinematic ones (each
 * a function of the state alone), except those the dense output gives exactly: a rotation's of a body that
 * touches (its landing or overturn on one corner a root below, flat it turns with its support) and a chain's
 * slip rate (a component). The forces' indicators are watched at the step's end. */
static int sampled(const Ctx *c, int kind, int k) {
    switch (kind) {
    case EN_IND_LAND:
    case EN_IND_OVERTURN:
        return flying(&c->mode, k);
    case EN_IND_STOP:
        return !c->chain;
    case EN_IND_JAM:
    case EN_IND_FELL_OFF:
    case EN_IND_OVERHANG:
        return 1;
    default:
        return 0;
    }
}

static int take_step(Model *M, const Logger *log) {
    State *S = &M->s;
    const Variables *v = &M->v;
    Ctx c;
    context(&c, M, &S->en, S->t);
    int nb = c.sys->nb, n = nstep(&c);
    double bp = next_breakpoint(M, S->t, c.piece), hmax = bp - S->t;
    int free_motion = 0;
    for (int k = 0; k < nb; k++) free_motion |= S->en.sigma[k] != 0 || flying(&S->en, k);
    /* free motion, and any motion on a two-way support (a sticking chain on a free platform moves as a polynomial, whose
     * error estimate, 0, would let the step grow without end where no record sample bounds it) */
    if (free_motion || c.two) hmax = fmin(hmax, FREE_STEP_MAX * time_scale(M));
    /* (the step writes the first n components; those after are completed, or never read) */
    double y1[NMAX], f1[NMAX], h = S->h, hNext;
    Dense cont;
    Dop853Stages st;
    varying(&c, &st);
    int hitBp, reuse = S->fValid && S->enIndValid; /* the last step's end, in the same contact set */
    if (!S->fValid) {
        rhs_cb(&c, S->t, S->y, S->f);
        S->fValid = 1;
    }
    double ind0[EN_IND];
    int kind[EN_IND], body[EN_IND], corner[EN_IND];
    int ni;
    if (reuse) {
        ni = S->enIndN;
        memcpy(ind0, S->enInd, sizeof(ind0)); /* (whole: a fixed size copies inline, where a call cost more) */
        memcpy(kind, S->enIndKind, sizeof(kind));
        memcpy(body, S->enIndBody, sizeof(body));
        memcpy(corner, S->enIndCorner, sizeof(corner));
    } else {
        ni = indicators(&c, S->t, S->y, NULL, ind0, kind, body, corner);
    }
    /* an open corner whose landing indicator starts negative by rounding (flying: its gap; rocking: its rotation
     * relative to its support): its landing is the crossing of its start value less LAND_ROUNDING (LAND_ROUNDING; a
     * rocking body's, its dense root, below; 0 for every other indicator, which crosses zero) */
    double sh[EN_IND];
    for (int i = 0; i < ni; i++)
        sh[i] = kind[i] == EN_IND_LAND && ind0[i] < 0 ? LAND_ROUNDING - ind0[i] : 0.0;
    /* after more impacts at this very time than a cascade over every contact takes, a landing that starts at or below
     * zero is those impacts' rounding: not watched in this step, or the same impact would repeat at the same time
     * without end (a block on a light two-way floor driven far beyond its model: a stall) */
    if (S->lastImpactTime == S->t && S->impactsNow >= 4 * nb + 8)
        for (int i = 0; i < ni; i++)
            if (kind[i] == EN_IND_LAND && ind0[i] <= 0) sh[i] = INFINITY;

    /* positions in units of R, rates of R p (angles and angular rates as they are); the integrals ride along */
    double scale[NMAX], R = M->d.R, p = sqrt(M->d.p2);
    for (int k = 0; k < nb; k++) {
        scale[EN_POS(nb, k, 0)] = scale[EN_POS(nb, k, 1)] = R;
        scale[EN_VEL(nb, k, 0)] = scale[EN_VEL(nb, k, 1)] = R * p;
        scale[EN_XI(nb, k)] = R;
        scale[EN_XID(nb, k)] = R * p;
        scale[EN_TH(k)] = scale[EN_W(k)] = 1.0;
        scale[EN_LOSS(nb, k)] = 0.0;
    }
    scale[EN_WORK(nb)] = 0.0;
    /* the rotations alone while every contact of a chain sticks (the centres follow), else all but the
     * integrals (a sliding chain's rotations and slips) */
    int nErr = c.chain && !c.slides ? 2 * nb : n;
    if (c.two) { /* and the support's floors (displacements in units of R, velocities of R p), not its integrals */
        int ns = M->d.sup.ns;
        for (int i = nErr; i < EN_N(nb); i++) scale[i] = 0.0;
        for (int i = 0; i < ns; i++) {
            scale[COUPLING_U(nb, i)] = R;
            scale[COUPLING_V(nb, i)] = R * p;
        }
        scale[COUPLING_WORK(nb, ns)] = scale[COUPLING_DAMP(nb, ns)] = 0.0;
        nErr = n;
    }
    if (adaptive_step_controlled(c.method, rhs_cb, &c, n, nErr, scale, S->t, S->y, S->f, &h, hmax, v->relTol,
                                 v->absTol, y1, f1, &cont, &st, &hNext, &hitBp, &S->rejected)) {
        say(log, LOG_ERROR, "no acceptable step size (last tried %g) at t=%.17g", h, S->t);
        return -1;
    }
    complete_last(&c, S->y, y1); /* (the accepted step's last evaluation was at its end) */
    if (c.singular) {
        say(log, LOG_ERROR, "the contact forces have no unique solution at t=%.17g", S->t);
        return -1;
    }
    dense_finish(&c, &st, &cont);
    S->steps++;
    if (hitBp && hmax < bp - S->t) hitBp = 0;
    /* the first indicator that falls below zero: at dense samples (the kinematic ones the dense output does not
     * give exactly, sampled) and the end */
    double ind[EN_IND], sLo = 0.0, sHi = 2.0;
    int first = -1, haveEnd = 0, anySampled = 0;
    for (int i = 0; i < ni; i++) anySampled |= sampled(&c, kind[i], body[i]);
    for (int j = free_motion && anySampled ? 1 : DENSE_SAMPLES; j <= DENSE_SAMPLES && first < 0; j++) {
        double s = (double)j / DENSE_SAMPLES, yd[NMAX];
        if (j == DENSE_SAMPLES) {
            indicators(&c, S->t + h, y1, &c.f, ind, kind, body, corner);
            haveEnd = 1;
        } else {
            memcpy(yd, S->y, sizeof(yd));
            dense_eval(&cont, n, s, yd);
            complete(&c, S->y, yd);
            EnForces none;
            memset(&none, 0, sizeof(none));
            indicators(&c, S->t + s * h, yd, &none, ind, kind, body, corner);
        }
        for (int i = 0; i < ni; i++) {
            if (j < DENSE_SAMPLES && !sampled(&c, kind[i], body[i])) continue;
            if (shifted(ind0[i], sh[i]) >= 0 && shifted(ind[i], sh[i]) < 0) {
                first = 0;
                sHi = s;
                sLo = (double)(j - 1) / DENSE_SAMPLES;
                break;
            }
        }
    }
    /* a body rocking on one corner lands its other corner exactly when its rotation relative to its
     * support returns to zero: the first such root of the dense output, found exactly (the
     * samples above could step over a short excursion) */
    double rootAt[EN_MAX_BODIES], overAt[EN_MAX_BODIES], stopAt[EN_MAX_BODIES]; /* (2: no root in the step) */
    for (int k = 0; k < EN_MAX_BODIES; k++) rootAt[k] = overAt[k] = stopAt[k] = 2.0;
    for (int k = 0; k < nb; k++) {
        /* a chain's sliding contact stops exactly when its slip rate (a component) reaches zero */
        if (c.slides && S->en.sigma[k]) {
            double P[DENSE_ROWS];
            int deg = dense_poly(&cont, EN_XID(nb, k), P);
            for (int i = 0; i <= deg; i++) P[i] *= S->en.sigma[k];
            stopAt[k] = first_crossing(P, deg, -1);
            if (stopAt[k] <= 1.0 && stopAt[k] < sHi) {
                sHi = stopAt[k];
                sLo = 0.0;
                first = 0;
            }
        }
        if (S->en.closed[k][0] == S->en.closed[k][1]) continue;
        double ck[DENSE_ROWS], cj[DENSE_ROWS] = {0}, P[DENSE_ROWS], Q[DENSE_ROWS];
        int deg = dense_poly(&cont, EN_TH(k), ck);
        if (k > 0) dense_poly(&cont, EN_TH(k - 1), cj);
        int sgn = S->en.closed[k][1] ? 1 : -1; /* rocking on the right corner: relative rotation > 0 */
        for (int i = 0; i <= deg; i++) P[i] = Q[i] = sgn * (ck[i] - cj[i]);
        Q[0] -= c.sys->body[k].over[sgn > 0]; /* where it lands on the hull's next edge (pi/2 for a rectangle) */
        rootAt[k] = first_crossing(P, deg, -1);
        overAt[k] = first_crossing(Q, deg, +1);
        double r = fmin(rootAt[k], overAt[k]);
        if (r <= 1.0 && r < sHi) {
            sHi = r;
            sLo = 0.0;
            first = 0;
        }
    }
    EventKind ev = EVENT_NONE;
    double hStep = h, tNew = hitBp ? bp : S->t + h;
    if (first >= 0) {
        /* locate each crossing in [sLo, sHi] with real steps; the earliest wins. The indicators at the
         * bracket's ends come from one real step each; a rocking body's landing or overturn (a rotation
         * reaching its target) by Newton on the step length from the dense output's root. */
        double best = INFINITY, yb[NMAX] = {0}, fb[NMAX] = {0};
        double ya[NMAX] = {0}, fa[NMAX] = {0};
        Dense ca, cb;
        Dop853Stages sa;
        varying(&c, &sa);
        double indA[EN_IND], indB[EN_IND], a = sLo * h, b = sHi * h;
        int which = -1, any = 0;
        Search se = {&c, n, 0, S->t, S->y, S->f, ya, fa, &ca, &sa, -1.0, 0.0};
        step_indicators(&se, b, indB);
        /* a rocking body's landing or overturn whose dense root lies in the bracket crosses there, whatever the
         * sign its indicator takes by rounding after the real step (its root is found exactly below) */
        double atRoot[EN_IND];
        for (int i = 0; i < ni; i++) {
            double r = kind[i] == EN_IND_LAND ? rootAt[body[i]] : kind[i] == EN_IND_OVERTURN ? overAt[body[i]]
                     : kind[i] == EN_IND_STOP ? stopAt[body[i]] : 2.0;
            atRoot[i] = r <= sHi ? -1.0 : indB[i];
            any |= shifted(ind0[i], sh[i]) >= 0 && shifted(atRoot[i], sh[i]) < 0;
        }
        if (!any && b < h) step_indicators(&se, b = h, indB);
        if (a > 0) step_indicators(&se, a, indA);
        else memcpy(indA, ind0, sizeof(indA));
        for (int i = 0; i < ni; i++) {
            if (!(shifted(ind0[i], sh[i]) >= 0 && (shifted(indB[i], sh[i]) < 0 || shifted(atRoot[i], sh[i]) < 0)))
                continue;
            int k = body[i], rocking = S->en.closed[k][0] != S->en.closed[k][1], x0 = 0;
            double x;
            int stop = c.slides && kind[i] == EN_IND_STOP;
            if ((rocking && (kind[i] == EN_IND_LAND || kind[i] == EN_IND_OVERTURN)) || stop) {
                /* a linear function of the components reaching its target: the relative rotation, or the slip rate */
                double w[NMAX] = {0}, r = stop ? stopAt[k] : kind[i] == EN_IND_LAND ? rootAt[k] : overAt[k];
                int sgn = S->en.closed[k][1] ? 1 : -1;
                double target = stop || kind[i] == EN_IND_LAND ? 0.0 : sgn * c.sys->body[k].over[sgn > 0];
                if (stop) {
                    w[EN_XID(nb, k)] = 1.0;
                } else {
                    w[EN_TH(k)] = 1.0;
                    if (k > 0) w[EN_TH(k - 1)] = -1.0;
                }
                double x1 = (r <= 1.0 ? r : 1.0) * h; /* (the step to it may have been taken above) */
                x = se.x == x1 ? refine_step_from(c.method, rhs_cb, &c, n, S->t, S->y, S->f, x1, h, w, target, ya, fa,
                                                  &ca, &sa)
                               : refine_step(c.method, rhs_cb, &c, n, S->t, S->y, S->f, x1, h, w, target, ya, fa, &ca,
                                             &sa);
                se.x = x;
                x0 = 1;
            } else {
                se.which = i;
                se.shift = sh[i];
                double va = shifted(indA[i], sh[i]), lo = a;
                if (va < 0) {
                    lo = 0.0;
                    va = shifted(ind0[i], sh[i]);
                }
                /* a start at the face (a corner that left it at this instant, its indicator within rounding of
                 * zero): regula falsi's estimates stay at that end (within its bracket's rounding of it) while the
                 * corner rises and comes down again later; halving first, until the start value is no longer
                 * negligible beside the end's */
                double hi = b, vb = shifted(indB[i], sh[i]);
                int atFace = kind[i] == EN_IND_LAND && flying(&S->en, k) && va <= LAND_ROUNDING;
                for (int it = 0; it < 60 && atFace && va < 1e-6 * -vb && hi - lo > 4.0 * DBL_EPSILON * fabs(S->t + hi);
                     it++) {
                    double xm = 0.5 * (lo + hi), vm = indicator_after(&se, xm);
                    if (vm < 0) hi = xm, vb = vm;
                    else lo = xm, va = vm;
                }
                x = first_negative_costly(indicator_after, &se, lo, va, hi, vb, 4.0, fabs(S->t), 0.0, 100);
            }
            if (x < best) {
                best = x;
                which = i;
                if (!x0) indicator_after(&se, x);
                dense_finish(&c, &sa, &ca);
                memcpy(yb, ya, sizeof(yb));
                memcpy(fb, fa, sizeof(fb));
                cb = ca;
            }
        }
        if (which >= 0) {
            hStep = best;
            memcpy(y1, yb, sizeof(y1));
            complete(&c, S->y, y1);
            memcpy(f1, fb, sizeof(f1));
            cont = cb;
            tNew = S->t + hStep;
            hitBp = 0;
            switch (kind[which]) {
            case EN_IND_OPEN:
                ev = EVENT_OPEN;
                break;
            case EN_IND_SLIP:
                ev = EVENT_SLIP_START;
                break;
            case EN_IND_STOP:
                ev = EVENT_SLIP_STOP;
                break;
            case EN_IND_LAND:
                ev = EVENT_IMPACT;
                break;
            case EN_IND_OVERTURN:
                ev = EVENT_OVERTURN;
                break;
            case EN_IND_JAM:
                ev = EVENT_JAM;
                break;
            case EN_IND_OVERHANG:
                ev = EVENT_OVERHANG;
                break;
            default:
                ev = EVENT_FELL_OFF;
                break;
            }
            S->eventContact = body[which];
            S->eventEnd = corner[which];
        }
    }
    /* peaks of body 0's rotation (its rate's zeros) inside the step, while it rocks on one corner (flat, or in
     * flight, it has none to report) */
    double com[DENSE_ROWS], dcom[DENSE_ROWS], roots[DENSE_ROWS];
    int iw = EN_W(0), rocks = S->en.closed[0][0] != S->en.closed[0][1], deg = 0;
    S->nStepPeaks = 0;
    if (rocks) deg = dense_poly(&cont, iw, com);
    if (rocks && may_have_root(com, deg)) {
        int nr = poly_roots(com, deg, 0.0, 1.0, roots);
        for (int i = 1; i <= deg; i++) dcom[i - 1] = i * com[i];
        for (int j = 0; j < nr && S->nStepPeaks < MAX_STEP_PEAKS; j++) {
            double r = roots[j], d = poly_eval(dcom, deg - 1, r);
            if (r <= 0.0 || d == 0.0 || (ev != EVENT_NONE && r >= 1.0)) continue;
            if (r < 1e-6 && fabs(S->y[EN_W(0)]) <= 1e-12 * p) continue; /* the start from rest, no reversal */
            double yd[NMAX];
            memcpy(yd, S->y, sizeof(yd));
            dense_eval(&cont, n, r, yd);
            S->stepPeakTime[S->nStepPeaks] = S->t + r * hStep;
            S->stepPeakTheta[S->nStepPeaks] = yd[EN_TH(0)];
            S->nStepPeaks++;
        }
    }
    S->tOld = S->t;
    S->hDense = hStep;
    dense_copy(&S->cont, &cont, n);
    S->denseTaylor = 0;
    S->denseSide = S->side;
    S->denseValid = 1;
    S->enDense = S->en;
    memcpy(S->enDenseAnchor, S->enAnchor, sizeof(S->enAnchor));
    S->denseSigma = S->sigma;
    S->denseMode = S->mode;
    S->t = tNew;
    memcpy(S->y, y1, sizeof(double) * (size_t)nstate(M));
    memcpy(S->f, f1, sizeof(double) * (size_t)n);
    /* back onto the constraints of the contact set the step was taken in (at an event too: an impact's
     * velocities before must be those of the motion the contacts allow) */
    if (!c.chain) project_rates(M, &S->en, S->y, S->enAnchor); /* (a chain's are placed) */
    /* (the projection moves the centres by rounding: the derivative and indicators at the step's end
     * stay the next step's start, across a record's sample too: ground_continuous_after) */
    S->fValid = ev == EVENT_NONE && (!hitBp || ground_continuous_after(M, c.piece));
    S->enIndValid = S->fValid && haveEnd && first < 0;
    if (S->enIndValid) {
        memcpy(S->enInd, ind, sizeof(double) * (size_t)ni);
        int was = S->enIndN; /* (past it the kinds, bodies and corners are 0 already) */
        S->enIndN = ni;
        for (int k = 0; k < EN_MAX_BODIES; k++) { /* (the step's last evaluation was at its end) */
            S->enT[k] = k < nb ? c.f.T[k] : 0.0;
            S->enN[k] = k < nb ? c.f.N[k][0] + c.f.N[k][1] : 0.0;
        }
        for (int i = 0; i < ni || i < was; i++) { /* (the unused ones 0: a state holds no undefined bytes) */
            S->enIndKind[i] = i < ni ? kind[i] : 0;
            S->enIndBody[i] = i < ni ? body[i] : 0;
            S->enIndCorner[i] = i < ni ? corner[i] : 0;
            if (i >= ni) S->enInd[i] = 0.0;
        }
    }
    S->h = hNext;
    S->pending = ev;
    for (int k = 0; k < nb; k++) { /* (a body that touches has no gap) */
        if (!flying(&S->en, k)) continue;
        double gap;
        slip_of(c.sys, &S->en, k, S->y, NULL, &gap);
        if (gap > S->gapMax[k]) S->gapMax[k] = gap;
    }
    for (int k = 0; k < nb && nb >= 2; k++) {
        double *mx = track(S, k).maxTheta;
        *mx = fmax(*mx, dense_abs_max(&cont, EN_TH(k), 1.0));
    }
    if (!isfinite(S->y[0]) || !isfinite(S->y[EN_TH(0)])) {
        say(log, LOG_ERROR, "non-finite state at t=%.17g", S->t);
        return -1;
    }
    return 0;
}

/* The state at time t: of the last step's dense output when t lies inside it. With f, also the contact
 * forces there under the ground's (ah, av) (a sticking chain's from the evaluation that places it). */
static void state_forces_at(const Model *M, double t, double *y, EnMode *m, double ah, double av, EnForces *f) {
    const State *S = &M->s;
    int two = coupling_on(M);
    memcpy(y, S->y, sizeof(double) * NMAX);
    *m = S->en;
    int have = 0;
    if (S->t > t && S->denseValid && S->mode != MODE_OVERTURNED) {
        double s = (t - S->tOld) / S->hDense;
        if (s < 0) s = 0;
        if (s > 1) s = 1;
        Ctx c;
        context(&c, M, &S->enDense, S->tOld);
        memcpy(c.xi0, S->enDenseAnchor, sizeof(c.xi0));
        dense_eval(&S->cont, nstep(&c), s, y);
        have = complete_forces(&c, S->y, y, ah, av, two ? NULL : f);
        *m = S->enDense;
    }
    if (f && !have) solve_at(M, t, m, y, ah, av, f);
}

static void state_at(const Model *M, double t, double *y, EnMode *m) { state_forces_at(M, t, y, m, 0.0, 0.0, NULL); }

/* Reactions of the moving bodies at t (contact monitors). */
static void reactions(const Model *M, double t, int inStep, double T[2], double N[2]) {
    double y[NMAX], ah, av;
    EnMode m;
    EnForces f;
    const EnSystem *sys = &M->d.en;
    /* a sticking chain at the last step's end, in the same contact set: the forces of its last evaluation */
    if (!inStep && M->s.fValid && M->s.enIndValid && t == M->s.t && engine_touches(sys, &M->s.en)) {
        for (int k = 0; k < 2; k++) {
            T[k] = M->s.enT[k];
            N[k] = M->s.enN[k];
        }
        return;
    }
    model_ground(M, t, &ah, &av);
    if (inStep) state_forces_at(M, t, y, &m, ah, av, &f);
    else solve_at(M, t, &M->s.en, M->s.y, ah, av, &f);
    for (int k = 0; k < 2; k++) {
        T[k] = k < sys->nb ? f.T[k] : 0.0;
        N[k] = k < sys->nb ? f.N[k][0] + f.N[k][1] : 0.0;
    }
}

/* Leaving rest: the least margin of the rest's forces (each corner's normal force, each contact's
 * friction margin, over the weight it carries), negated: positive once the ground moves the bodies.
 * Linear in the ground's accelerations (|T| aside, which keeps the friction margin concave), so it
 * crosses zero at most once on a cell where they are monotone. */
static double rest_exit(const Model *M, double t, int piece) {
    const EnSystem *sys = &M->d.en;
    EnMode r;
    memset(&r, 0, sizeof(r));
    memcpy(r.over, M->s.en.over, sizeof(r.over));
    for (int k = 0; k < sys->nb; k++) r.closed[k][0] = r.closed[k][1] = 1;
    double ah, av;
    model_ground_piece(M, t, piece, &ah, &av);
    EnForces f;
    if (isnan(solve_at(M, t, &r, M->s.y, ah, av, &f))) return 1.0;
    return -engine_force_margin(sys, &r, &f);
}

/* Before each step: the peaks passed, and a contact set that no longer holds where the step starts (the
 * inputs, or a break of the excitation, changed the ground's accelerations there) chosen again. */
static void before_step(Model *M, const Logger *log) {
    State *S = &M->s;
    commit_peaks(M, log);
    if (S->mode != MODE_ROCKING) return;
    /* the last step's end, in the same contact set under the same inputs: every indicator positive there
     * leaves nothing to do */
    if (S->fValid && S->enIndValid) {
        int clear = 1;
        for (int i = 0; i < S->enIndN; i++) clear &= S->enInd[i] > 0;
        if (clear) return;
    }
    Ctx c;
    context(&c, M, &S->en, S->t);
    double ind[EN_IND];
    int kind[EN_IND], body[EN_IND], corner[EN_IND];
    int n = indicators(&c, S->t, S->y, NULL, ind, kind, body, corner);
    /* a flying corner that penetrates its face (a projection of the bodies below it, a pair switched at its corner):
     * it touches, an impact here (the step would start from a penetration its landing indicator never crosses) */
    for (int i = 0; i < n && S->lastImpactTime != S->t; i++) /* (once: an impact here that left it, the step's watch) */
        if (kind[i] == EN_IND_LAND && flying(&S->en, body[i]) && ind[i] < -LAND_PENETRATION) {
            S->pending = EVENT_IMPACT;
            S->eventContact = body[i];
            S->eventEnd = corner[i];
            apply_event(M, log);
            return;
        }
    for (int i = 0; i < n; i++) {
        if ((kind[i] == EN_IND_OPEN || kind[i] == EN_IND_SLIP) && ind[i] < -RECHOOSE_SLACK) {
            say(log, LOG_EVENTS, "rechoose t=%.17g body=%d", S->t, body[i] + 1);
            S->pending = EVENT_RECHOOSE;
            reselect(M, log);
            S->pending = EVENT_NONE;
            S->fValid = 0;
            resolve_approach(M, log);
            return;
        }
        /* a sliding contact whose slip rate is of the other sign stops here: its friction would push the slip
         * on instead of opposing it (a slip rate exactly 0 is a slide that starts here: the set was chosen with
         * its slip accelerating its way; a chain holds that 0 exactly) */
        if ((kind[i] == EN_IND_STOP && ind[i] < 0) || (kind[i] == EN_IND_JAM && !(ind[i] > 0))) {
            S->pending = kind[i] == EN_IND_STOP ? EVENT_SLIP_STOP : EVENT_JAM;
            S->eventContact = body[i];
            S->eventEnd = corner[i];
            apply_event(M, log);
            return;
        }
    }
}

/* After the bodies' run ended on a two-way support: the support carrying them on floor j (T = mtot a_f), its
 * components alone integrated (from index 0 of the step's vector) and stepped ahead of tc like the engine's steps,
 * their dense output kept for the outputs (engine_outputs). */
typedef struct {
    const Model *M;
    int piece;
} EndCtx;

static void end_rhs(const void *ctx, double t, const double *z, double *dz) {
    const EndCtx *c = ctx;
    const Model *M = c->M;
    int nb = M->d.en.nb;
    double ag, av, y[NMAX], dy[NMAX], r[SUPPORT_MAX_STOREYS], mtot;
    model_ground_piece(M, t, c->piece, &ag, &av);
    coupling_momentum(&M->d.en, M->s.y, &mtot);
    memcpy(y + EN_N(nb), z, sizeof(double) * (size_t)coupling_size(M));
    coupling_free(M, t, y, ag, r);
    double uj = coupling_floor(M, r, mtot * ag, mtot);
    coupling_rhs(M, y, r, uj, ag, av, 0.0, 0.0, dy);
    memcpy(dz, dy + EN_N(nb), sizeof(double) * (size_t)coupling_size(M));
}

static int support_after_end(Model *M, double tc, const Logger *log) {
    State *S = &M->s;
    if (S->rest.on) { /* in closed form: nothing to integrate (the outputs take it at tc) */
        S->t = tc;
        S->denseValid = 0;
        return 0;
    }
    /* (it steps ahead of tc: the outputs at tc come from its dense output) */
    int nb = M->d.en.nb, n = coupling_size(M), ns = M->d.sup.ns, hitBp;
    EndCtx c = {M, model_piece(M, S->t)};
    double *z = S->y + EN_N(nb), z1[NMAX], f0[NMAX], f1[NMAX], scale[NMAX], hNext;
    Dense cont;
    double bp = next_breakpoint(M, S->t, c.piece), h = S->h, R = M->d.R, p = sqrt(M->d.p2);
    for (int i = 0; i < ns; i++) {
        scale[2 * i] = R;
        scale[2 * i + 1] = R * p;
    }
    scale[2 * ns] = scale[2 * ns + 1] = 0.0;
    end_rhs(&c, S->t, z, f0);
    /* (bounded as the engine's steps: a free platform moves as a polynomial) */
    double hmax = fmin(bp - S->t, FREE_STEP_MAX * time_scale(M));
    if (adaptive_step_controlled(RK_DOPRI5, end_rhs, &c, n, n, scale, S->t, z, f0, &h, hmax, M->v.relTol,
                                 M->v.absTol, z1, f1, &cont, NULL, &hNext, &hitBp, &S->rejected)) {
        say(log, LOG_ERROR, "no acceptable step size for the support (last tried %g) at t=%.17g", h, S->t);
        return -1;
    }
    S->steps++;
    S->tOld = S->t;
    S->hDense = h;
    dense_copy(&S->cont, &cont, n);
    S->denseValid = 1;
    S->t = hitBp && hmax == bp - S->t ? bp : S->t + h;
    memcpy(z, z1, sizeof(double) * (size_t)n);
    S->h = hNext;
    return 0;
}

/* The support's components at tc after the bodies' run ended (the closed form, or the dense output of its last
 * step). */
static void support_after_end_at(Model *M, double tc, double *y) {
    const State *S = &M->s;
    if (S->rest.on) {
        rest_closed_at(M, tc, y);
        return;
    }
    if (!coupling_on(M) || !S->denseValid || !(S->t > tc)) return;
    double s = (tc - S->tOld) / S->hDense, z[NMAX];
    dense_eval(&S->cont, coupling_size(M), s < 0 ? 0 : s > 1 ? 1 : s, z);
    memcpy(y + EN_N(M->d.en.nb), z, sizeof(double) * (size_t)coupling_size(M));
}

static const SolverOps ENGINE = {apply_event, take_step, start_moving, before_step, reactions, rest_exit, NULL};
static const SolverOps ENGINE_ON_SUPPORT = {apply_event, take_step, start_moving, before_step, reactions, rest_exit,
                                            support_after_end};

/* ------------------------------------------------------------------ interface */

/* The side of a rotation (rate w) from rest: its sign, or the rate's where it is zero. */
static int side_from(double th, double w) { return th > 0 ? 1 : th < 0 ? -1 : (w > 0 ? 1 : -1); }

void engine_initialize(Model *M) {
    State *S = &M->s;
    const Variables *v = &M->v;
    const EnSystem *sys = &M->d.en;
    int nb = sys->nb;
    double y[NMAX] = {0};
    engine_rest_state(sys, y);
    rest_centres(sys, y, NULL);
    memset(&S->en, 0, sizeof(S->en));
    /* the pair at each end at rest, the axes aligned: an end of a block whose corner lies beyond the top of the one
     * below (a wider block) starts with that one's corner on its base (docs/columns.md, "Overhangs") */
    for (int k = 1; k < nb; k++)
        for (int i = 0; i < 2; i++) {
            const EnBody *B = &sys->body[k], *Sb = &sys->body[k - 1];
            S->en.over[k][i] = (2 * i - 1) * (B->xa[i] - Sb->tm) - Sb->tw > EN_EDGE_MARGIN * Sb->tw;
        }
    EnMode rest0 = S->en;
    S->slideTime = S->slideStartTime1 = S->slideStartTime2 = S->fellOffTime = -1;
    for (int k = 0; k < EN_MAX_BODIES; k++) S->flightSince[k] = -1;
    for (int k = 0; k < MAX_BLOCKS - 2; k++) S->colSlideFirst[k] = -1;
    /* blocks 3 and up start seated on the block below them (its rotation and rate) */
    double th[EN_MAX_BODIES] = {v->theta0, nb >= 2 ? v->theta02 : 0.0}, w[EN_MAX_BODIES] = {v->omega0, nb >= 2 ? v->omega02 : 0.0};
    for (int k = 2; k < nb; k++) th[k] = th[k - 1], w[k] = w[k - 1];
    int still = S->mode == MODE_REST && (nb == 1 || (th[1] == 0.0 && w[1] == 0.0));
    if (still) {
        memcpy(S->y, y, sizeof(y));
        for (int k = 0; k < nb; k++) S->en.closed[k][0] = S->en.closed[k][1] = 1;
        (void)rest0;
        /* (two-way: at rest in closed form, or as a contact set the engine integrates with the support, come_to_rest) */
        S->mode = coupling_on(M) && !rest_closed(M) ? MODE_ROCKING : MODE_REST;
        return;
    }
    S->mode = MODE_ROCKING;
    /* released rocking on the corners the rotations give (block 1 on the ground, block 2 on block 1's
     * top, centred), each pivot where it stands at rest */
    int touching[EN_MAX_BODIES][2] = {{0}}, stuck[EN_MAX_BODIES];
    for (int k = 0; k < EN_MAX_BODIES; k++) stuck[k] = 1;
    /* the support's frame: its centre O, velocity V, rotation thS and rate wS, its top's height hS above O and its
     * axis' x, xS, from O (the ground's: the origin, its axis x = 0) */
    double O[2] = {0.0, 0.0}, V[2] = {0.0, 0.0}, thS = 0.0, wS = 0.0, hS = 0.0, xS = 0.0;
    for (int k = 0; k < nb; k++) {
        const EnBody *B = &sys->body[k];
        double rel = th[k] - thS, wrel = w[k] - wS;
        int c = side_from(rel, wrel), i = c > 0;
        /* the pivot, in the support's frame: the corner where it stands at rest, the axes aligned */
        /* (with an overhang at that end, the support's corner, at its place on k's base) */
        int ov = k > 0 && rest0.over[k][i];
        double cs = cos(thS), sn = sin(thS), px = B->xa[i] + xS, py = hS, qx = B->cx[i];
        if (ov) {
            px = sys->body[k - 1].tm + c * sys->body[k - 1].tw + xS;
            qx = px - xS - B->xG;
        }
        double P[2] = {O[0] + px * cs + py * sn, O[1] - px * sn + py * cs};
        double Pv[2] = {V[0] + wS * (-px * sn + py * cs), V[1] + wS * (-px * cs - py * sn)};
        double ck = cos(th[k]), sk = sin(th[k]);
        double rx = -qx * ck - B->cy * sk, ry = qx * sk - B->cy * ck; /* pivot -> centre */
        y[EN_POS(nb, k, 0)] = P[0] + rx;
        y[EN_POS(nb, k, 1)] = P[1] + ry;
        y[EN_TH(k)] = th[k];
        y[EN_VEL(nb, k, 0)] = Pv[0] + w[k] * ry;
        y[EN_VEL(nb, k, 1)] = Pv[1] - w[k] * rx;
        y[EN_W(k)] = w[k];
        touching[k][c > 0 ? 1 : 0] = 1;
        /* released flat with no rate relative to its support: both corners touch; with one, only the
         * pivot (the other corner rises at 2 b |w|) */
        if (rel == 0.0 && wrel == 0.0) touching[k][0] = touching[k][1] = 1;
        O[0] = y[EN_POS(nb, k, 0)], O[1] = y[EN_POS(nb, k, 1)];
        V[0] = y[EN_VEL(nb, k, 0)], V[1] = y[EN_VEL(nb, k, 1)];
        thS = th[k], wS = w[k], hS = B->ht, xS = -B->xG;
    }
    memcpy(S->y, y, sizeof(y));
    EnMode m;
    if (choose(M, S->t, S->y, NULL, touching, stuck, &m) != 0) {
        m = rest0;
        for (int k = 0; k < nb; k++) memcpy(m.closed[k], touching[k], sizeof(m.closed[k]));
    }
    S->en = m;
    engine_hold_slips(sys, &m, S->y);
    S->side = side_of(&m, S->y);
    for (int k = 0; k < nb; k++) {
        S->enAnchor[k] = 0.0;
        if (flying(&m, k)) {
            S->flights[k] = 1;
            S->flightSince[k] = S->t;
        }
    }
    for (int k = 0; k < nb; k++) {
        Track r = track(S, k);
        if (m.sigma[k]) {
            *r.starts = 1;
            *r.since = *r.first = S->t;
            if (S->slideTime < 0) S->slideTime = S->t;
        }
        *r.maxTheta = fabs(th[k]);
    }
    S->maxAbsTheta2 = fabs(th[1]);
    S->sigma = m.sigma[0];
}

int engine_advance(Model *M, double tc, const Logger *log, EventStop *stop) {
    State *S = &M->s;
    if (S->rest.on && model_inputs_on(M)) {
        /* the base's inputs move the floor beyond the closed form (the record's alone): integrated from here */
        rest_closed_end(M, S->t);
        if (S->mode == MODE_REST) S->mode = MODE_ROCKING;
        S->h = 0.0;
        S->fValid = 0;
    }
    return advance_to(M, tc, log, coupling_on(M) ? &ENGINE_ON_SUPPORT : &ENGINE, stop);
}

void engine_rollback(Model *M, double tc) {
    State *S = &M->s;
    if (S->mode == MODE_OVERTURNED && S->t > tc && S->denseValid && coupling_on(M)) { /* the support alone moves */
        support_after_end_at(M, tc, S->y);
        S->t = tc;
        S->h = 0.0;
        S->denseValid = 0;
        return;
    }
    if (S->mode != MODE_ROCKING || S->t <= tc || !S->denseValid) return;
    double y[NMAX];
    EnMode m;
    state_at(M, tc, y, &m);
    memcpy(S->y, y, sizeof(y));
    S->en = m;
    S->sigma = m.sigma[0];
    S->t = tc;
    S->pending = EVENT_NONE;
    S->fValid = 0;
    S->denseValid = 0;
    keep_peaks_until(S, tc);
}

/* A contact set's mode of body k as block1.mode / block2.mode: 0 rest, 1 slide, 2 rock, 3 slide-rock,
 * 6 flight. */
static int contact_mode(const EnMode *m, int k) {
    if (flying(m, k)) return 6;
    if (m->closed[k][0] && m->closed[k][1]) return m->sigma[k] ? 1 : 0;
    return m->sigma[k] ? 3 : 2;
}

typedef struct {
    double slip, slipRate, gap, flightTime;
} BodyOut;

/* Body k's slip (its contact's), slip rate, gap and time in flight at tc (state y in contact set m). */
static BodyOut body_outputs(const Model *M, const EnSystem *sys, int k, const double *y, const EnMode *m, double tc,
                            int over) {
    const State *S = &M->s;
    BodyOut o;
    double rate = 0.0, gap = 0.0;
    if (over) m = &S->enFinal; /* the contacts as the run left them */
    if (!flying(m, k) && m->sigma[k] == 0) { /* a sticking contact stays where it stuck (and touches) */
        int inStep = S->t > tc && S->denseValid && S->mode != MODE_REST;
        o.slip = inStep ? S->enDenseAnchor[k] : S->enAnchor[k];
    } else {
        o.slip = slip_of(sys, m, k, y, &rate, &gap);
    }
    o.slipRate = over || S->mode == MODE_REST ? 0.0 : rate;
    o.gap = over ? 0.0 : gap;
    o.flightTime = S->flightDur[k] + (flying(m, k) && !over && tc > S->flightSince[k] ? tc - S->flightSince[k] : 0.0);
    return o;
}

/* Block k's contact mode (block*.mode) in a column (nBlocks > 2): a block that fell, or rides one that fell, is
 * overturned (4), the one that fell off the block below it 5. */
static int column_mode(const State *S, const EnMode *end, int k) {
    if (S->mode == MODE_REST) return 0;
    if (S->mode == MODE_OVERTURNED && S->fallenBody > 0 && S->fallenBody - 1 <= k)
        return S->fellOff && S->fallenBody - 1 == k ? 5 : 4;
    return contact_mode(end, k);
}

/* A column's blocks 3 to nBlocks: their family outputs (variables.def's BLOCK lines) */
static void column_outputs(Model *M, const double *y, const EnMode *m, const EnMode *end, double tc, int over) {
    State *S = &M->s;
    Variables *v = &M->v;
    const EnSystem *sys = &M->d.en;
    for (int k = 2; k < MAX_BLOCKS; k++) {
        int i = k - 2, on = k < sys->nb;
        BodyOut o = on ? body_outputs(M, sys, k, y, m, tc, over) : (BodyOut){0};
        v->thetaN[i] = on ? y[EN_TH(k)] : 0.0;
        v->omegaN[i] = on && !over ? y[EN_W(k)] : 0.0;
        v->slipN[i] = o.slip;
        v->modeN[i] = on ? column_mode(S, end, k) : 0;
        v->maxAbsThetaN[i] = on ? fmax(S->colMaxTheta[i], fabs(v->thetaN[i])) : 0.0;
        v->maxAbsSlipN[i] = on ? fmax(S->colMaxSlip[i], fabs(o.slip)) : 0.0;
        v->overturnedN[i] = on && over && S->fallenBody > 0 && S->fallenBody - 1 <= k;
        v->fellOffN[i] = on && S->fellOff && S->fallenBody - 1 == k;
    }
}

void engine_outputs(Model *M, double tc) {
    State *S = &M->s;
    Variables *v = &M->v;
    const EnSystem *sys = &M->d.en;
    double y[NMAX], ah, av;
    EnMode m;
    model_ground(M, tc, &ah, &av);
    v->ahTotal = ah;
    v->avTotal = av;
    int nb = sys->nb, over = S->mode == MODE_OVERTURNED, two = nb >= 2, column = nb > 2;
    EnForces f;
    memset(&f, 0, sizeof(f));
    if (S->mode == MODE_REST || over) {
        state_at(M, tc, y, &m);
        if (S->rest.on && S->mode == MODE_REST) rest_closed_at(M, tc, y);
    }
    int twoWay = coupling_on(M);
    if (S->mode != MODE_REST && !over) {
        state_forces_at(M, tc, y, &m, ah, av, twoWay ? NULL : &f);
        if (twoWay) v->ahTotal = solve_at(M, tc, &m, y, ah, av, &f); /* the floor's, with the blocks on it */
    }
    if (twoWay && over) { /* the floor carrying the bodies */
        double r[SUPPORT_MAX_STOREYS], mtot;
        support_after_end_at(M, tc, y);
        coupling_momentum(sys, y, &mtot);
        coupling_free(M, tc, y, ah, r);
        v->ahTotal = ah + coupling_floor(M, r, mtot * ah, mtot);
    }
    if (S->mode == MODE_REST) {
        EnMode r;
        memset(&r, 0, sizeof(r));
        memcpy(r.over, S->en.over, sizeof(r.over));
        for (int k = 0; k < nb; k++) r.closed[k][0] = r.closed[k][1] = 1;
        engine_solve(sys, &r, y, ah, av, &f);
    }
    /* one block overturned lies on its side; a stack's run that ended keeps its last state */
    v->theta = over && !two ? S->side * sys->body[0].over[S->side > 0] : y[EN_TH(0)];
    v->omega = over ? 0.0 : y[EN_W(0)];
    v->alphaDD = f.qdd[EN_Q(0, 2)];
    BodyOut b1 = body_outputs(M, sys, 0, y, &m, tc, over);
    v->slip = b1.slip;
    v->slipRate = b1.slipRate;
    v->gap = b1.gap;
    v->maxGap = S->gapMax[0];
    v->flights = S->flights[0];
    v->flightTime = b1.flightTime;
    peak_outputs(S, tc, v->theta, v);
    v->impacts = S->impacts;
    v->impactsGround = two ? S->impactsGround : S->impacts;
    v->lastImpactTime = S->lastImpactTime;
    v->overturned = column ? S->fallenBody > 0 && !S->fellOff : two ? S->overturned2 : over;
    v->overturned1 = two ? S->overturned1 : over;
    v->atRest = S->mode == MODE_REST;
    v->overturnTime = S->overturnTime;
    v->restTime = S->restTime;
    const EnMode *end = over ? &S->enFinal : &m;
    v->contactMode = S->mode == MODE_REST ? 0 : (over && (!two || S->overturned1)) ? 4 : contact_mode(end, 0);
    if (two) {
        v->theta2 = y[EN_TH(1)];
        v->omega2 = over ? 0.0 : y[EN_W(1)];
        v->alphaDD2 = f.qdd[EN_Q(1, 2)];
        v->maxAbsTheta2 = fmax(S->maxAbsTheta2, fabs(v->theta2));
        BodyOut b2 = body_outputs(M, sys, 1, y, &m, tc, over);
        v->slip2 = b2.slip;
        v->slipRate2 = b2.slipRate;
        v->gap2 = b2.gap;
        v->maxGap2 = S->gapMax[1];
        v->flights2 = S->flights[1];
        v->flightTime2 = b2.flightTime;
        v->impactsInterface = S->impactsInterface;
        v->overturned2 = S->overturned2;
        v->contactMode2 = column ? column_mode(S, end, 1)
                          : S->mode == MODE_REST ? 0 : S->fellOff ? 5 : S->overturned2 ? 4 : contact_mode(end, 1);
        v->maxAbsSlip2 = fmax(S->maxAbsSlip2, fabs(v->slip2));
        v->slideDuration2 =
            S->slideDur2 + (m.sigma[1] && !over && tc > S->slideSince2 ? tc - S->slideSince2 : 0.0);
        v->slideStartTime2 = S->slideStartTime2;
        v->slideStarts2 = S->slideStarts2;
        v->frictionLoss2 = y[EN_LOSS(nb, 1)];
        v->fellOff = column ? S->fellOff && S->fallenBody == 2 : S->fellOff;
        v->fellOffTime = S->fellOffTime;
        v->peaks = 0; /* a stack counts no peaks */
        v->lastPeakTime = -1.0;
        v->lastPeakTheta = 0.0;
        v->maxAbsTheta = fmax(v->maxAbsTheta, fabs(v->theta));
    } else {
        v->theta2 = v->omega2 = v->alphaDD2 = v->maxAbsTheta2 = 0.0;
        v->impactsInterface = 0;
    }
    /* rocking1: a block above block 1 rocks on the one below it */
    int rocking0 = !(m.closed[0][0] && m.closed[0][1]), rocking1 = 0, slides = m.sigma[0];
    for (int k = 1; k < nb; k++) {
        rocking1 |= !(m.closed[k][0] && m.closed[k][1]);
        slides |= m.sigma[k];
    }
    v->locked = two && !over && S->mode != MODE_REST && rocking0 && !rocking1 && !slides;
    v->pattern = over                      ? MODE_OVERTURNED
                 : S->mode == MODE_REST    ? MODE_REST
                 : slides                  ? MODE_SLIDE
                 : !two                    ? (v->contactMode == 1 ? MODE_SLIDE : 0)
                 : rocking0 && rocking1    ? MODE_BOTH
                 : rocking0                ? MODE_LOCKED
                 : rocking1                ? MODE_UPPER
                                           : MODE_REST;
    v->groundT = f.T[0];
    v->groundN = f.N[0][0] + f.N[0][1];
    v->interfaceT = two ? f.T[1] : 0.0;
    v->interfaceN = two ? f.N[1][0] + f.N[1][1] : 0.0;
    if (S->mode == MODE_REST) { /* bodies moving with the ground: their inertia and weight, exactly */
        double mass = 0.0;
        for (int k = 0; k < nb; k++) mass += sys->body[k].m;
        v->groundT = mass * ah;
        v->groundN = mass * (sys->g + av);
        if (two) {
            double above = 0.0; /* what the interface carries */
            for (int k = 1; k < nb; k++) above += sys->body[k].m;
            v->interfaceT = above * ah;
            v->interfaceN = above * (sys->g + av);
        }
    }
    double p = 0.0, q = 0.0;
    for (int k = 0; k < nb && !over; k++) {
        p += sys->body[k].m * y[EN_VEL(nb, k, 0)];
        q += sys->body[k].m * y[EN_POS(nb, k, 0)];
    }
    v->momentum = p;
    M->s.massMoment = q;
    v->energy = over ? engine_energy(sys, S->y) : engine_energy(sys, y);
    v->groundWork = y[EN_WORK(nb)];
    v->frictionLoss = y[EN_LOSS(nb, 0)];
    v->impactLoss = S->impactLoss;
    if (twoWay) {
        int j = M->d.sup.j, ns = M->d.sup.ns;
        v->supportU = y[COUPLING_U(nb, j)];
        v->supportV = y[COUPLING_V(nb, j)];
        v->supportEnergy = coupling_energy(M, y);
        v->supportDampingLoss = y[COUPLING_DAMP(nb, ns)];
        v->baseWork = y[COUPLING_WORK(nb, ns)];
        int still = !over;
        for (int k = 0; k < nb; k++) still &= m.closed[k][0] && m.closed[k][1] && m.sigma[k] == 0;
        v->atRest = still;
    }
    v->maxAbsSlip = fmax(S->maxAbsSlip, fabs(v->slip));
    v->slideDuration = S->slideDur + (m.sigma[0] && !over && tc > S->slideSince ? tc - S->slideSince : 0.0);
    v->slideStartTime = two ? S->slideStartTime1 : S->slideTime;
    v->slideStarts = S->slideStarts;
    v->painleve = S->painleve;
    column_outputs(M, y, &m, end, tc, over);
    contact_outputs(M, v);
}

static int finite_all(const double *x, int count) {
    for (int i = 0; i < count; i++)
        if (!isfinite(x[i])) return 0;
    return 1;
}

int engine_check_state(const Model *M, char *msg, size_t n) {
    const State *S = &M->s;
    int nb = M->d.en.nb, ny = nstate(M), mode = (int)S->mode, pending = (int)S->pending;
#define BAD(...)                       \
    do {                               \
        snprintf(msg, n, __VA_ARGS__); \
        return 1;                      \
    } while (0)
    if (!(mode == MODE_ROCKING || mode == MODE_REST || mode == MODE_OVERTURNED))
        BAD("pattern %d is not one of 0 (moving), 1 (rest), 2 (overturned)", mode);
    if (!(pending == EVENT_NONE || pending == EVENT_IMPACT || pending == EVENT_OVERTURN || pending == EVENT_OPEN ||
          pending == EVENT_SLIP_START || pending == EVENT_SLIP_STOP || pending == EVENT_JAM ||
          pending == EVENT_OVERHANG))
        BAD("pending event %d is not one of 0, 1, 2, 5, 6, 7, 11, 12", pending);
    if (pending != EVENT_NONE && (mode != MODE_ROCKING || S->eventContact < 0 || S->eventContact >= nb ||
                                  !(S->eventEnd == 1 || S->eventEnd == -1)))
        BAD("event %d is pending at contact %d, end %d of a state that does not move or has no such contact", pending,
            S->eventContact, S->eventEnd);
    if (S->nStepPeaks < 0 || S->nStepPeaks > MAX_STEP_PEAKS) BAD("nStepPeaks = %d is outside [0, %d]", S->nStepPeaks, MAX_STEP_PEAKS);
    if (S->fValid < 0 || S->fValid > 1 || S->denseValid < 0 || S->denseValid > 1 || S->denseTaylor != 0)
        BAD("flags fValid = %d, denseValid = %d must be 0 or 1 and denseTaylor = %d 0", S->fValid, S->denseValid,
            S->denseTaylor);
    if (S->impacts < 0 || S->peaks < 0 || S->slideStarts < 0 || S->steps < 0 || S->rejected < 0)
        BAD("negative counters");
    if (!finite_all(S->y, ny) || !finite_all(S->f, ny) || !isfinite(S->t) || !isfinite(S->h) || !isfinite(S->tOld) ||
        !(S->hDense >= 0 && isfinite(S->hDense)) || !finite_all(S->stepPeakTime, MAX_STEP_PEAKS))
        BAD("the integrator's state holds a number that is not finite");
    if (!((S->cont.method == RK_DOPRI5 && (S->cont.rows == 5 || S->cont.rows == 0)) ||
          (S->cont.method == RK_DOP853 && S->cont.rows == DENSE_ROWS)))
        BAD("the last step's dense output (method %d, %d rows) is neither DOPRI5's (5 rows) nor DOP853's (8)",
            S->cont.method, S->cont.rows);
    for (int k = 0; k < DENSE_ROWS; k++)
        if (!finite_all(S->cont.r[k], ny)) BAD("the last step's dense output holds a number that is not finite");
#undef BAD
    for (int k = 0; k < EN_MAX_BODIES; k++) {
        for (int i = 0; i < 2; i++)
            if (!(S->en.closed[k][i] == 0 || S->en.closed[k][i] == 1) ||
                !(S->enDense.closed[k][i] == 0 || S->enDense.closed[k][i] == 1)) {
                snprintf(msg, n, "contact %d of body %d is neither open nor closed", i, k + 1);
                return 1;
            }
        for (int i = 0; i < 2; i++) {
            const int *o[3] = {S->en.over[k], S->enDense.over[k], S->enFinal.over[k]};
            for (int j = 0; j < 3; j++)
                if (!(o[j][i] == 0 || o[j][i] == 1) || (o[j][i] && (k == 0 || k >= nb))) {
                    snprintf(msg, n, "the pair at end %d of body %d (over = %d) is neither 0 nor 1, or is 1 on the ground "
                             "or past the bodies", i, k + 1, o[j][i]);
                    return 1;
                }
        }
        if (S->en.sigma[k] < -1 || S->en.sigma[k] > 1 || S->enDense.sigma[k] < -1 || S->enDense.sigma[k] > 1) {
            snprintf(msg, n, "the slip direction of body %d is not -1, 0 or 1", k + 1);
            return 1;
        }
        if (S->flights[k] < 0 || !isfinite(S->flightDur[k]) || !isfinite(S->gapMax[k]) ||
            !isfinite(S->enAnchor[k]) || !isfinite(S->flightSince[k])) {
            snprintf(msg, n, "the flight record of body %d is not finite", k + 1);
            return 1;
        }
    }
    if (S->painleve < 0) {
        snprintf(msg, n, "painleve = %d is negative", S->painleve);
        return 1;
    }
    if (S->impactsNow < 0) {
        snprintf(msg, n, "impactsNow = %d is negative", S->impactsNow);
        return 1;
    }
    if (S->fallenBody < 0 || S->fallenBody > nb || (S->fallenBody > 0) != (mode == MODE_OVERTURNED)) {
        snprintf(msg, n, "fallenBody = %d is not a body of %d (0 unless the run ended by a fall)", S->fallenBody, nb);
        return 1;
    }
    for (int k = 0; k < MAX_BLOCKS - 2; k++)
        if (S->colSlideStarts[k] < 0 || !isfinite(S->colMaxTheta[k]) || !isfinite(S->colMaxSlip[k]) ||
            !isfinite(S->colSlideSince[k]) || !isfinite(S->colSlideDur[k]) || !isfinite(S->colSlideFirst[k])) {
            snprintf(msg, n, "the records of block %d are not finite, or count negative slides", k + 3);
            return 1;
        }
    /* the last step's end indicators, which the next step starts from */
    if (S->enIndValid != 0 && S->enIndValid != 1) {
        snprintf(msg, n, "the flag enIndValid = %d must be 0 or 1", S->enIndValid);
        return 1;
    }
    if (S->enIndValid) {
        if (S->enIndN < 0 || S->enIndN > EN_IND || !finite_all(S->enInd, EN_IND) || !finite_all(S->enT, EN_MAX_BODIES) ||
            !finite_all(S->enN, EN_MAX_BODIES)) {
            snprintf(msg, n, "the last step's %d indicators (at most %d) or its forces are not a step's", S->enIndN, EN_IND);
            return 1;
        }
        for (int i = 0; i < S->enIndN; i++)
            if (S->enIndKind[i] < EN_IND_OPEN || S->enIndKind[i] > EN_IND_OVERHANG || S->enIndBody[i] < 0 ||
                S->enIndBody[i] >= nb || !(S->enIndCorner[i] == 1 || S->enIndCorner[i] == -1)) {
                snprintf(msg, n, "the last step's indicator %d (kind %d, body %d, corner %d) is no indicator of these bodies",
                         i, S->enIndKind[i], S->enIndBody[i], S->enIndCorner[i]);
                return 1;
            }
    }
    return 0;
}
