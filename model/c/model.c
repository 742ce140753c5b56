/* Rocking rigid block: parameters, excitation, equation of motion, energy.
 * Conventions in model.h and docs/conventions.md. */
#include "model.h"
#include "engine.h" /* engine_body_rectangle */
#include "ground.h"
#include "stack.h"
#include "support.h"

#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void model_set_defaults(Model *M) {
#define VAR(T, vr, field, name, caus, var, start, unit, desc) DEFAULT_##T(field, start)
#define DEFAULT_REAL(field, start) M->v.field = start;
#define DEFAULT_INTEGER(field, start) M->v.field = start;
#define DEFAULT_BOOLEAN(field, start) M->v.field = start;
#define DEFAULT_STRING(field, start) snprintf(M->v.field, sizeof(M->v.field), "%s", start);
#include "variables.def"
#undef DEFAULT_REAL
#undef DEFAULT_INTEGER
#undef DEFAULT_BOOLEAN
#undef DEFAULT_STRING
#undef VAR
}

#define FAIL(...)                        \
    do {                                 \
        snprintf(msg, n, __VA_ARGS__);   \
        return 1;                        \
    } while (0)

/* half sizes (m) and gravity (m/s2) beyond these are mistakes of units, and would make the
   block's time scale 1/p too short or too long for any integrator step */
#define MIN_SIZE 1e-6
#define MAX_SIZE 1e4
#define MIN_G 0.1
#define MAX_G 1000.0

int model_validate(const Variables *v, char *msg, size_t n) {
    /* every Real must be finite, every Boolean 0 or 1, every String terminated */
#define VAR(T, vr, field, name, caus, var, start, unit, desc) CHECK_##T(field, name)
#define CHECK_REAL(field, name) \
    if (!isfinite(v->field)) FAIL("%s = %g is not a finite number", name, v->field);
#define CHECK_INTEGER(field, name)
#define CHECK_BOOLEAN(field, name) \
    if (v->field != 0 && v->field != 1) FAIL("%s = %d is not a Boolean (0 or 1)", name, v->field);
#define CHECK_STRING(field, name) \
    if (!memchr(v->field, '\0', sizeof(v->field))) FAIL("%s is not terminated", name);
#include "variables.def"
#undef CHECK_REAL
#undef CHECK_INTEGER
#undef CHECK_BOOLEAN
#undef CHECK_STRING
#undef VAR
    if (v->nBlocks < 1 || v->nBlocks > MAX_BLOCKS)
        FAIL("nBlocks = %d must be 1 (one block) to %d (a column: block k + 1 on block k)", v->nBlocks, MAX_BLOCKS);
    if (!(v->halfWidth > 0)) FAIL("block1.halfWidth = %g must be > 0 m", v->halfWidth);
    if (!(v->halfHeight > 0)) FAIL("block1.halfHeight = %g must be > 0 m", v->halfHeight);
    if (!(v->halfWidth >= MIN_SIZE && v->halfWidth <= MAX_SIZE && v->halfHeight >= MIN_SIZE &&
          v->halfHeight <= MAX_SIZE))
        FAIL("block1 half sizes %g x %g m must be in [%g, %g] m (half width and half height, in metres)",
             v->halfWidth, v->halfHeight, MIN_SIZE, MAX_SIZE);
    if (!(v->mass > 0)) FAIL("block1.mass = %g must be > 0 kg", v->mass);
    if (!(v->g >= MIN_G && v->g <= MAX_G)) FAIL("g = %g must be in [%g, %g] m/s2", v->g, MIN_G, MAX_G);
    if (v->law < 0 || v->law > 2)
        FAIL("restitution.law = %d must be 0 (Housner), 1 (modified) or 2 (constant)", v->law);
    if (!(v->k >= 0 && v->k <= 1)) FAIL("restitution.k = %g must be in [0, 1]", v->k);
    if (!(v->eta >= 0 && v->eta <= 1)) FAIL("restitution.eta = %g must be in [0, 1]", v->eta);
    if (!(v->correction > 0)) FAIL("restitution.correction = %g must be > 0", v->correction);
    {
        double alpha = atan(v->halfWidth / v->halfHeight);
        double eta = model_law_restitution(v, alpha) * v->correction;
        if (v->law == 0 && v->nBlocks == 1 && !model_block_polygon(v, 0) && model_law_restitution(v, alpha) < 0)
            FAIL("block1 is too squat for Housner's law (b/h = %g > sqrt(2) gives the negative coefficient "
                 "1 - 3/2 sin^2(alpha) = %g): set restitution.law = 2 (constant) and restitution.eta",
                 v->halfWidth / v->halfHeight, model_law_restitution(v, alpha));
        if (v->nBlocks == 1 && model_block_polygon(v, 0) && (v->law != 0 || v->correction != 1.0))
            FAIL("block1.outline: one body of real shape takes restitution.law = 0 (its plastic impact: the angular "
                 "momentum about the landing corner kept) with restitution.correction = 1, not law %d x %g", v->law,
                 v->correction);
        if (v->nBlocks == 1 && !(eta >= 0 && eta <= 1)) /* a stack's laws: momentum, or etaGround/etaInterface */
            FAIL("effective restitution %g (law %d x correction %g) must be in [0, 1]",
                 eta, v->law, v->correction);
        if (!(fabs(v->theta0) < M_PI / 2))
            FAIL("block1.theta0 = %g must satisfy |theta0| < pi/2 (the block would lie on its side)",
                 v->theta0);
    }
    if (v->nBlocks >= 2) {
        if (!(v->halfWidth2 > 0)) FAIL("block2.halfWidth = %g must be > 0 m", v->halfWidth2);
        if (!(v->halfHeight2 > 0)) FAIL("block2.halfHeight = %g must be > 0 m", v->halfHeight2);
        if (!(v->halfWidth2 >= MIN_SIZE && v->halfWidth2 <= MAX_SIZE && v->halfHeight2 >= MIN_SIZE &&
              v->halfHeight2 <= MAX_SIZE))
            FAIL("block2 half sizes %g x %g m must be in [%g, %g] m (half width and half height, in metres)",
                 v->halfWidth2, v->halfHeight2, MIN_SIZE, MAX_SIZE);
        if (!(v->mass2 > 0)) FAIL("block2.mass = %g must be > 0 kg", v->mass2);
        if (v->law == 1)
            FAIL("restitution.law = 1 (modified, impact position k) is defined for one block only; "
                 "use 0 (momentum) or 2 (constant per interface) with nBlocks = %d", v->nBlocks);
        if (v->correction != 1.0)
            FAIL("restitution.correction = %g must be 1 with nBlocks = %d (use law 2 with "
                 "restitution.etaGround and restitution.etaInterface)", v->correction, v->nBlocks);
        if (!(v->etaGround >= 0 && v->etaGround <= 1))
            FAIL("restitution.etaGround = %g must be in [0, 1]", v->etaGround);
        if (!(v->etaInterface >= 0 && v->etaInterface <= 1))
            FAIL("restitution.etaInterface = %g must be in [0, 1]", v->etaInterface);
        if (!(fabs(v->theta02 - v->theta0) < M_PI / 2))
            FAIL("block2.theta0 - block1.theta0 = %g must be below pi/2 in magnitude "
                 "(block 2 would lie on its side)", v->theta02 - v->theta0);
        if (v->earlyOverturn)
            FAIL("solver.earlyOverturn is available for nBlocks = 1 only");
    }
    for (int k = 0; k < v->nBlocks; k++) { /* bodies of real shape: their outlines */
        double I = k == 0 ? v->inertia1 : k == 1 ? v->inertia2 : v->inertiaN[k - 2];
        if (!(I >= 0)) FAIL("block%d.inertia = %g must be >= 0 kg m2 (0: a uniform polygon's)", k + 1, I);
        EnBody B;
        if (model_block_body(v, k, &B, msg, n)) return 1;
    }
    for (int k = 2; k < v->nBlocks; k++) { /* blocks 3 to nBlocks: the families (variables.def's BLOCK lines) */
        double b = v->halfWidthN[k - 2], h = v->halfHeightN[k - 2], m = v->massN[k - 2], mu = v->muN[k - 2];
        if (!(b >= MIN_SIZE && b <= MAX_SIZE && h >= MIN_SIZE && h <= MAX_SIZE))
            FAIL("block%d half sizes %g x %g m must be in [%g, %g] m (half width and half height, in metres)", k + 1, b,
                 h, MIN_SIZE, MAX_SIZE);
        if (!(m > 0)) FAIL("block%d.mass = %g must be > 0 kg", k + 1, m);
        if (!(mu > 0 || mu == -1))
            FAIL("block%d.mu = %g must be > 0 (or -1: contact.muInterface)", k + 1, mu);
    }
    if (!(v->muGround > 0)) FAIL("contact.muGround = %g must be > 0", v->muGround);
    if (v->contactModel != 0 && v->contactModel != 1)
        FAIL("contact.model = %d must be 0 (rigid rocking) or 1 (rocking-sliding)", v->contactModel);
    if (model_engine(v)) {
        /* the contact engine's runs: rocking-sliding, and rigid rocking on a two-way support */
        const char *who = v->contactModel == 1                              ? "contact.model = 1 (rocking-sliding)"
                          : v->supportKind != 0 && v->supportCoupling == 1 ? "rigid rocking on a two-way support"
                          : v->nBlocks > 2                                 ? "rigid rocking of a column (nBlocks > 2)"
                                                                           : "rigid rocking of a body of real shape";
        double alpha = atan(v->halfWidth / v->halfHeight), s2 = sin(alpha) * sin(alpha);
        double eta = model_law_restitution(v, alpha) * v->correction;
        for (int k = 1; k < v->nBlocks; k++) {
            double b, h, m, below, hb, mb;
            model_block(v, k, &b, &h, &m);
            model_block(v, k - 1, &below, &hb, &mb);
            if (!model_block_polygon(v, k) && !model_block_polygon(v, k - 1)) {
                if (b > below)
                    FAIL("%s needs block %d no wider than block %d (block%d.halfWidth = %g > block%d.halfWidth = %g): "
                         "a wider block would turn about the edge of the one below, not modelled", who, k + 1, k, k + 1,
                         b, k, below);
                continue;
            }
            EnBody B, S;
            model_block_body(v, k, &B, msg, n);
            model_block_body(v, k - 1, &S, msg, n);
            if (!(S.tw > 0))
                FAIL("block %d carries block %d but its outline has no flat top (two highest vertices)", k, k + 1);
            if (B.xa[0] < S.tm - S.tw || B.xa[1] > S.tm + S.tw)
                FAIL("block %d's base [%g, %g] m (from its axis) must stand within the top face [%g, %g] m of block %d "
                     "(from its axis; the axes align at rest): a block beyond it would turn about the edge below, not "
                     "modelled", k + 1, B.xa[0], B.xa[1], S.tm - S.tw, S.tm + S.tw, k);
        }
        if (v->method == 1) FAIL("%s needs solver.method = 0 (Dormand-Prince) or 2 (auto)", who);
        if (v->earlyOverturn) FAIL("solver.earlyOverturn is not available for %s", who);
        if (!(v->restRatio >= 1e-12))
            FAIL("solver.restRatio = %g must be >= 1e-12 with %s (a smaller rebound lies below what "
                 "double precision resolves of the angle and the slip)", v->restRatio, who);
        if (!(eta >= 0.5 - 1.5 * s2))
            FAIL("restitution %g is below 0.5 - 1.5 sin^2(alpha) = %g: with %s an impact of a "
                 "sliding block could then gain energy (use a larger coefficient or restitution.law = 0)",
                 eta, 0.5 - 1.5 * s2, who);
    }
    if (!(v->muInterface > 0)) FAIL("contact.muInterface = %g must be > 0", v->muInterface);
    if (ground_validate(v, msg, n)) return 1;
    if (support_validate(v, msg, n)) return 1;
    if (v->method < 0 || v->method > 2)
        FAIL("solver.method = %d must be 0 (Dormand-Prince 5(4)), 1 (Taylor series) or 2 (auto: the Taylor series "
             "for one block in rigid rocking, else Dormand-Prince)", v->method);
    if (v->method == 1 && v->nBlocks >= 2)
        FAIL("solver.method = 1 (Taylor series) is available for nBlocks = 1 only");
    if (!(v->relTol >= REL_TOL_MIN && v->relTol <= 0.1))
        FAIL("solver.relTol = %g must be in [1e-14, 0.1] (a tighter one is below double precision's rounding)",
             v->relTol);
    if (!(v->absTol >= ABS_TOL_MIN && v->absTol <= 1e-3))
        FAIL("solver.absTol = %g must be in [1e-20, 1e-3] (rad and rad/s: a looser one misses impacts, a tighter "
             "one is below double precision's rounding)", v->absTol);
    if (!(v->restRatio > 0 && v->restRatio < 1))
        FAIL("solver.restRatio = %g must be in (0, 1)", v->restRatio);
    return 0;
}
#undef FAIL

double model_law_restitution(const Variables *v, double alpha) {
    double s2 = sin(alpha) * sin(alpha);
    switch (v->law) {
    case 0: /* Housner (1963): conservation of angular momentum, corner impact */
        return 1.0 - 1.5 * s2;
    case 1: /* modified law (Kalliontzis et al.; Ceh and Jelenic eq. 10) */
        return (4.0 - 3.0 * s2 * (1.0 + v->k * v->k)) /
               (4.0 - 3.0 * s2 * (1.0 - v->k * v->k));
    default:
        return v->eta;
    }
}

int model_engine(const Variables *v) {
    return v->contactModel == 1 || (v->contactModel == 0 && v->supportKind != 0 && v->supportCoupling == 1) ||
           v->nBlocks > 2 || model_polygons(v);
}

void model_block(const Variables *v, int k, double *b, double *h, double *m) {
    *b = k == 0 ? v->halfWidth : k == 1 ? v->halfWidth2 : v->halfWidthN[k - 2];
    *h = k == 0 ? v->halfHeight : k == 1 ? v->halfHeight2 : v->halfHeightN[k - 2];
    *m = k == 0 ? v->mass : k == 1 ? v->mass2 : v->massN[k - 2];
}

static const char *block_outline(const Variables *v, int k) {
    return k == 0 ? v->outline1 : k == 1 ? v->outline2 : v->outlineN[k - 2];
}

int model_block_polygon(const Variables *v, int k) { return block_outline(v, k)[0] != '\0'; }

int model_polygons(const Variables *v) {
    for (int k = 0; k < v->nBlocks; k++)
        if (model_block_polygon(v, k)) return 1;
    return 0;
}

/* The vertices of an outline "x,y; x,y; ..." (m; separators: ',' between the coordinates, ';' between the vertices,
 * spaces anywhere): their count, or -1 with a reason in msg. */
static int parse_outline(const char *text, double *x, double *y, char *msg, size_t n) {
    int count = 0;
    const char *p = text;
    for (;;) {
        while (isspace((unsigned char)*p)) p++;
        if (*p == '\0') break;
        if (count == EN_POLY_MAX) {
            snprintf(msg, n, "has more than %d vertices", EN_POLY_MAX);
            return -1;
        }
        char *end;
        double c[2];
        for (int i = 0; i < 2; i++) {
            c[i] = strtod(p, &end);
            if (end == p) {
                snprintf(msg, n, "vertex %d: '%.20s' is not a number (write 'x,y; x,y; ...' in m)", count + 1, p);
                return -1;
            }
            p = end;
            while (isspace((unsigned char)*p)) p++;
            if (i == 0) {
                if (*p != ',') {
                    snprintf(msg, n, "vertex %d: x and y must be separated by ',' (write 'x,y; x,y; ...' in m)",
                             count + 1);
                    return -1;
                }
                p++;
            }
        }
        x[count] = c[0];
        y[count] = c[1];
        count++;
        if (*p == ';') p++;
        else if (*p != '\0') {
            snprintf(msg, n, "vertex %d: vertices must be separated by ';' (write 'x,y; x,y; ...' in m)", count);
            return -1;
        }
    }
    return count;
}

int model_block_body(const Variables *v, int k, EnBody *B, char *msg, size_t n) {
    double b, h, m;
    model_block(v, k, &b, &h, &m);
    if (!model_block_polygon(v, k)) {
        engine_body_rectangle(B, b, h, m);
        return 0;
    }
    double x[EN_POLY_MAX], y[EN_POLY_MAX];
    char reason[240];
    int count = parse_outline(block_outline(v, k), x, y, reason, sizeof(reason));
    if (count < 0) {
        snprintf(msg, n, "block%d.outline %s", k + 1, reason);
        return 1;
    }
    double I = k == 0 ? v->inertia1 : k == 1 ? v->inertia2 : v->inertiaN[k - 2];
    double centre[2] = {k == 0 ? v->centreX1 : k == 1 ? v->centreX2 : v->centreXN[k - 2],
                        k == 0 ? v->centreY1 : k == 1 ? v->centreY2 : v->centreYN[k - 2]};
    if (!(I >= 0)) {
        snprintf(msg, n, "block%d.inertia = %g must be >= 0 kg m2 (0: the uniform polygon's)", k + 1, I);
        return 1;
    }
    if (engine_body_polygon(B, count, x, y, m, I > 0 ? centre : NULL, I > 0 ? I : -1.0, reason, sizeof(reason))) {
        snprintf(msg, n, "block%d.outline: %s", k + 1, reason);
        return 1;
    }
    return 0;
}

double model_block_mu(const Variables *v, int k) {
    if (v->contactModel != 1) return RIGID_MU;
    return k == 0 ? v->muGround : k == 1 || v->muN[k - 2] == -1 ? v->muInterface : v->muN[k - 2];
}

/* The contact engine's bodies (the memset of model_derive leaves the rest 0). Rigid rocking (on a two-way support)
 * is the engine's contacts with friction that never lets them slip, RIGID_MU. */
static void engine_bodies(const Variables *v, EnSystem *s) {
    s->nb = v->nBlocks;
    s->g = v->g;
    char msg[8];
    for (int k = 0; k < s->nb; k++) {
        s->mu[k] = model_block_mu(v, k);
        model_block_body(v, k, &s->body[k], msg, sizeof(msg)); /* (valid: model_validate) */
    }
    for (int k = s->nb - 1; k >= 0; k--)
        s->weight[k] = s->body[k].m * s->g + (k + 1 < s->nb ? s->weight[k + 1] : 0.0);
}

void model_derive(Model *M) {
    const Variables *v = &M->v;
    Derived *d = &M->d;
    memset(d, 0, sizeof(*d)); /* a function of the parameters alone, unused values 0 */
    double b = v->halfWidth, h = v->halfHeight;
    d->R = sqrt(b * b + h * h);
    d->alpha = atan(b / h);
    d->tanAlpha = b / h;
    d->I0 = 4.0 / 3.0 * v->mass * d->R * d->R;
    d->mROverI0 = 3.0 / (4.0 * d->R);
    d->p2 = 3.0 * v->g / (4.0 * d->R);
    d->eta = model_law_restitution(v, d->alpha) * v->correction;
    ground_derive(M);
    /* rocking-sliding: a block at rest starts to move (slide or rock) at the lower threshold */
    d->upliftSlope = v->contactModel == 1 ? fmin(d->tanAlpha, v->muGround) : d->tanAlpha;
    if (v->nBlocks == 2) stack_derive(v, d);
    /* the rocking-sliding stack at rest also starts to slide at either contact */
    if (v->nBlocks == 2 && v->contactModel == 1)
        d->upliftSlope = fmin(d->upliftSlope, fmin(v->muGround, v->muInterface));
    engine_bodies(v, &d->en);
    if (model_block_polygon(v, 0)) { /* block 1 of real shape: its quantities about the corner it lifts from first */
        const EnBody *B = &d->en.body[0];
        double h = -B->cy, bs = fmin(-B->cx[0], B->cx[1]); /* the side of the smaller slenderness angle */
        d->R = hypot(bs, h);
        d->alpha = atan(bs / h);
        d->tanAlpha = bs / h;
        d->I0 = B->Ic + B->m * d->R * d->R;
        d->mROverI0 = B->m * d->R / d->I0;
        d->p2 = v->g * d->mROverI0;
        d->eta = model_law_restitution(v, d->alpha) * v->correction;
        d->upliftSlope = v->contactModel == 1 ? fmin(d->tanAlpha, v->muGround) : d->tanAlpha;
    }
    d->weight[0] = v->nBlocks == 1 ? v->mass * v->g : v->nBlocks == 2 ? (v->mass + v->mass2) * v->g : d->en.weight[0];
    d->weight[1] = v->nBlocks > 2 ? d->en.weight[1] : v->mass2 * v->g; /* what the interface carries */
    support_derive(v, &d->sup);
    /* two-way: the support with every block at rest on its floor, in closed form where it can be */
    double mb = 0.0;
    for (int k = 0; k < d->en.nb; k++) mb += d->en.body[k].m;
    if (!d->sup.twoWay || support_rest_modes(&d->sup, mb, &d->supRest, &d->restShapes)) {
        memset(&d->supRest, 0, sizeof(d->supRest));
        memset(&d->restShapes, 0, sizeof(d->restShapes));
    }
}

void model_rhs_terms(const Model *M, double t, const double y[2], int side, int piece, double dy[2],
                     RhsTerms *k) {
    model_ground_piece(M, t, piece, &k->ah, &k->av);
    double phi = side * M->d.alpha - y[0];
    k->sphi = sin(phi);
    k->cphi = cos(phi);
    dy[0] = y[1];
    dy[1] = -M->d.mROverI0 * ((M->v.g + k->av) * k->sphi + k->ah * k->cphi);
}

void model_rhs_piece(const Model *M, double t, const double y[2], int side,
                     int piece, double dy[2]) {
    RhsTerms k;
    model_rhs_terms(M, t, y, side, piece, dy, &k);
}

void model_rhs(const Model *M, double t, const double y[2], int side, double dy[2]) {
    model_rhs_piece(M, t, y, side, model_piece(M, t), dy);
}

int model_rebound_negligible(const Model *M, double t, double wp) {
    double ah, av;
    model_ground(M, t, &ah, &av);
    double geff = M->v.g + av;
    if (!(geff > 0 && fabs(ah) <= geff * M->d.tanAlpha)) return 0;
    double pe2 = M->d.mROverI0 * geff;
    double cmax = cos(M->d.alpha) + wp * wp / (2.0 * pe2);
    return cmax < 1.0 && M->d.alpha - acos(cmax) < M->v.restRatio * M->d.alpha;
}

int model_impact(const Model *M, double t, double wm, double *wp) {
    *wp = M->d.eta * wm;
    return model_rebound_negligible(M, t, *wp);
}

double model_energy(const Model *M, double theta, double omega) {
    double a = M->d.alpha;
    return 0.5 * M->d.I0 * omega * omega +
           M->v.mass * M->v.g * M->d.R * (cos(a - fabs(theta)) - cos(a));
}

double model_uplift_indicator_piece(const Model *M, double t, int side, int piece) {
    double ah, av;
    model_ground_piece(M, t, piece, &ah, &av);
    /* positive once the ground tips the block over that corner; never while g + av <= 0,
     * when the ground falls faster than the block: the block is held where it stands (it
     * would fly, which the model does not cover; the lift monitor reports it) */
    double ge = M->v.g + av;
    return fmin(-side * ah - ge * M->d.upliftSlope, ge);
}

void model_initialize(Model *M, double t0) {
    State *S = &M->s;
    memset(S, 0, sizeof(*S));
    S->t = t0;
    S->y[0] = M->v.theta0;
    S->y[1] = M->v.omega0;
    if (M->v.theta0 == 0.0 && M->v.omega0 != 0.0) {
        /* Released flat with a rate too small to lift the block to restRatio * alpha: it is
         * at rest, by the criterion that ends rocking at an impact (its excursion would last
         * less than any step could resolve, and the return to theta = 0 would be missed) */
        double ah, av;
        model_ground(M, t0, &ah, &av);
        double geff = M->v.g + av, w = M->v.omega0;
        if (geff > 0 && fabs(ah) <= geff * M->d.tanAlpha) {
            double cmax = cos(M->d.alpha) + w * w / (2.0 * M->d.mROverI0 * geff);
            if (cmax < 1.0 && M->d.alpha - acos(cmax) < M->v.restRatio * M->d.alpha) S->y[1] = 0.0;
        }
    }
    if (S->y[0] == 0.0 && S->y[1] == 0.0) {
        S->mode = MODE_REST;
        S->side = 1;
    } else {
        S->mode = MODE_ROCKING;
        S->side = M->v.theta0 > 0 ? 1 : M->v.theta0 < 0 ? -1 : (M->v.omega0 > 0 ? 1 : -1);
    }
    S->lastImpactTime = -1;
    S->lastPeakTime = -1;
    S->overturnTime = -1;
    S->restTime = -1;
    S->maxAbsTheta = fabs(M->v.theta0);
    S->slideTime = S->liftTime = -1;
    S->withinTime = t0; /* a block released beyond its limit falls from the start */
}
