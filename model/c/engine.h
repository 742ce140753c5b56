/* The planar contact engine of the rocking-sliding model (contact.model = 1): rigid bodies on
 * a moving support, each bottom corner a unilateral contact with Coulomb friction.
 * Derivation and every rule: docs/flight.md, "The contact engine".
 *
 * Bodies k = 0 .. nb-1 are convex polygons with a flat base, mass m, centre of mass G anywhere above the base
 * between its corners and inertia Ic about G (EnBody, model.h; engine_body_polygon, engine_body_rectangle: a
 * rectangle of half width b, half height h has G at its middle and Ic = m (b^2 + h^2) / 3); body k stands on its
 * support: the ground for k = 0, body k - 1 above that (a stack), on the support's flat top face. Each body has an
 * axis (x = 0 of its polygon): at rest a column's axes align. Coordinates are relative to the ground's frame
 * (which moves with a_h, a_v), origin at body 0's axis on its base at rest, signs of docs/conventions.md: x right,
 * y up, theta clockwise. Body k: q = (X, Y, theta) of its centre of mass.
 *
 * Contacts: body k's base corners c = -1 (left, index 0) and +1 (right, index 1) against
 * its support's top face (slips measured along it from the support's axis). Each corner is open or closed; the corners of one body share its
 * friction: the contact sticks (sigma = 0) or slides (sigma = +-1, the sign of the slip rate),
 * with |T| <= mu (N_left + N_right). Between events the accelerations and forces come from
 * Newton-Euler with the closed corners' constraints; at an event the consistent contact set is
 * the solution of a linear complementarity problem (Pfeiffer & Glocker 1996), and impacts are
 * the same problem on velocities and impulses (plastic, Coulomb friction).
 *
 * State vector (EN_N(nb) components): each body's rotation and its rate, the ground's work (J), the
 * friction loss at each body's support (J), each contact's slip and slip rate (EN_XI, EN_XID: held where
 * every body touches and a contact slides), each body's centre and its velocity (EN_POS, EN_VEL).
 */
#ifndef ROCKING_ENGINE_H
#define ROCKING_ENGINE_H

#include <float.h>
#include "model.h"

#define EN_NQ (3 * EN_MAX_BODIES)

/* index of generalised coordinate i (0 X, 1 Y, 2 theta) of body k in q-space (rows, forces, masses) */
#define EN_Q(k, i) (3 * (k) + (i))
/* indices into the state vector of a system of nb bodies: the rotations and their rates first,
 * (theta_k, omega_k) pairs, then the ground's work and each body's friction loss, then each contact's
 * (xi, xi'), then each body's (X, Y, X', Y'). A chain (every body touching its support, engine_touches)
 * integrates its reduced coordinates alone, a prefix of the vector: while every contact sticks the first
 * EN_CHAIN_N(nb) (the rotations and the work: no friction works), while one slides the first EN_SLIDE_N(nb)
 * (the losses and the slips too); its centres follow from them and the anchors of the contacts that stick.
 * The error control covers the rotations of a sticking chain, and the rotations, slips and centres of the
 * other contact sets. Outside a sliding chain the slips are not held (their derivatives are 0). */
#define EN_TH(k) (2 * (k))
#define EN_W(k) (2 * (k) + 1)
#define EN_WORK(nb) (2 * (nb))
#define EN_LOSS(nb, k) (2 * (nb) + 1 + (k))
#define EN_XI(nb, k) (3 * (nb) + 1 + 2 * (k))
#define EN_XID(nb, k) (3 * (nb) + 2 + 2 * (k))
#define EN_POS(nb, k, i) ((i) == 2 ? 2 * (k) : 5 * (nb) + 1 + 4 * (k) + (i))
#define EN_VEL(nb, k, i) ((i) == 2 ? 2 * (k) + 1 : 5 * (nb) + 3 + 4 * (k) + (i))
#define EN_N(nb) (9 * (nb) + 1)
#define EN_CHAIN_N(nb) (2 * (nb) + 1)
#define EN_SLIDE_N(nb) (5 * (nb) + 1)

/* EnBody, EnSystem: model.h (the system is derived from the parameters once, M->d.en). */

/* A rectangle of half width b, half height h (m) and mass m (kg), uniform: its axis through its middle. */
void engine_body_rectangle(EnBody *B, double b, double h, double m);
/* A convex polygon of n vertices (x[i], y[i]) (m; either orientation) in its rest pose, in its body frame (y = 0
 * its base, x = 0 its axis), of mass m (kg), centre of mass centre[0..1] (NULL: the polygon's centroid, a uniform
 * density) and inertia IG about it (kg m^2; < 0: the uniform polygon's, which needs centre NULL). Its base is the
 * edge at y = 0 (the lowest vertices: at least two), its contact corners the base's ends; its top face, if the
 * highest vertices are two, the edge they span (else tw = 0: it can carry no body, engine_check_stack). Collinear
 * vertices are dropped. Returns 0, or nonzero with a one-line reason in msg (len bytes; B then undefined) where
 * the polygon is not convex, not finite, has fewer than 3 vertices (or more than EN_POLY_MAX), no flat base at
 * y = 0, or where m or IG is not positive, or the centre does not lie inside the polygon strictly above the base
 * and strictly between its corners (the body could not stand). */
#define EN_POLY_MAX 64
int engine_body_polygon(EnBody *B, int n, const double *x, const double *y, double m, const double *centre,
                        double IG, char *msg, size_t len);
/* 0 if every body that carries another has a flat top (tw > 0); else nonzero with a one-line reason in msg. */
int engine_check_stack(const EnSystem *s, char *msg, size_t len);

/* A corner against its support: gap (m, > 0 open), slip coordinate along the support's top
 * (m, support's frame) and their rates; rows of the gap's and slip's accelerations,
 * gdd = wN . qdd + bN, xidd = wT . qdd + bT (wN, wT also map the forces to generalised ones). */
typedef struct {
    double g, gd, xi, xid;
    double wN[EN_NQ], wT[EN_NQ];
    double bN, bT;
} EnPoint;

/* Forces and accelerations of a mode: qdd, the normal force at each corner (N, 0 if open) and
 * the tangential force of the support on each body (N, along the support's top); from a chain (engine_solve,
 * engine_chain, engine_rhs where every body touches and a contact slides) also each contact's slip acceleration
 * (m/s2, along its support's top; 0 where it sticks; not set by the other contact sets). */
typedef struct {
    double qdd[EN_NQ];
    double N[EN_MAX_BODIES][2];
    double T[EN_MAX_BODIES];
    double xidd[EN_MAX_BODIES];
} EnForces;

/* A corner of body k (k > 0) at xi along its support's top lies beyond the support's edge: by more than
 * EN_EDGE_MARGIN of the support's half width (far above the rounding of positions, far below any size of
 * the bodies), so that a block 2 as wide as block 1, whose corners sit on block 1's edges, is not pushed
 * off by rounding. A sticking corner keeps its place exactly (its slip is anchored); a sliding one is
 * watched by an indicator that turns negative there. */
#define EN_EDGE_MARGIN 1e-9
/* Rounding, relative (of a corner's normal acceleration over g at an event): a value within it is zero. */
#define EN_ROUNDING (64.0 * DBL_EPSILON)
int engine_beyond_edge(const EnSystem *s, int k, double xi);

/* The corner c (-1, +1) of body k at the state y. */
void engine_point(const EnSystem *s, int k, int c, const double *y, EnPoint *p);
/* Its gap, slip and their rates alone (p's rows and biases left unset). */
void engine_corner(const EnSystem *s, int k, int c, const double *y, EnPoint *p);
/* The contact at end c (-1, +1) of body k in the pair mode m gives it (m->over; m NULL: body k's corner on its
 * support's top): with over, the support's top corner c against body k's base face (docs/columns.md, "Overhangs"):
 * its gap (the corner below k's base, along k's base normal), and as slip coordinate the value body k's corner c
 * would have on the support's top were it flat there, so that xi less the corner's offset xa is body k's slip (its
 * axis from the support's axis) in both pairs and at the switch (the corners coincide) the two agree. The rows are
 * the gap's and slip's gradients in the generalised coordinates (the forces act at the support's corner, normal to
 * k's base). */
void engine_point_m(const EnSystem *s, const EnMode *m, int k, int c, const double *y, EnPoint *p);
void engine_corner_m(const EnSystem *s, const EnMode *m, int k, int c, const double *y, EnPoint *p);
/* How far body k's corner c lies beyond its support's top corner c (m, > 0 beyond), measured along the support's top
 * (the projection of the corner on it): the overhang at that end; with over it has the sign of the overhang measured
 * along k's base. */
double engine_overhang(const EnSystem *s, int k, int c, const double *y);

/* Solve mode m at the state y under (ah, av): returns 0 if its system is singular. */
int engine_solve(const EnSystem *s, const EnMode *m, const double *y, double ah, double av, EnForces *f);

/* A chain: every body on a closed corner of its support (or flat on it), each contact sticking or sliding.
 * Its motion has one coordinate per body that rocks (its rotation; a flat body turns with its support) and
 * one per contact that slides (its slip), solved in those coordinates (engine_solve does so for such a mode:
 * the same accelerations and forces as Newton-Euler with the constraints, to rounding). engine_is_chain: a
 * chain in which every contact sticks. */
int engine_touches(const EnSystem *s, const EnMode *m);
int engine_is_chain(const EnSystem *s, const EnMode *m);
/* The chain m at the rotations and rates in y (and, of each contact that slides, its slip and slip rate at
 * EN_XI, EN_XID): with anchors xi0 (each sticking contact's slip, as in engine_project), the centres and their
 * velocities (and a flat body's rotation and rate) are first placed in y exactly; the accelerations and forces
 * go to f (NULL: the placement alone). Returns 0 if singular. */
int engine_chain(const EnSystem *s, const EnMode *m, const double *xi0, double *y, double ah, double av,
                 EnForces *f);

/* Derivatives of the state vector in mode m (forces written to f unless NULL). Returns 0 if singular. With
 * anchors xi0 and a chain, y's first EN_CHAIN_N(nb) components (EN_SLIDE_N(nb) where a contact slides) alone
 * are read (the centres are placed from them, engine_chain) and dy's first that many alone written; the state
 * placed goes to `placed` unless NULL (each body's EN_TH, EN_W, EN_POS and EN_VEL: as engine_chain places y). */
int engine_rhs(const EnSystem *s, const EnMode *m, const double *xi0, const double *y, double ah, double av,
               double *dy, EnForces *f, double *placed);
/* engine_rhs of one body on a chain (its anchors xi0 given) with the derivatives' and forces' slopes in ah too (dya,
 * fa: the contact set's accelerations and forces are affine in the support's acceleration), from one evaluation.
 * Returns 1, 0 where the set's system is singular, -1 where it does not apply (a stack, a flight): then evaluate
 * engine_rhs at two values of ah. */
int engine_rhs_slope(const EnSystem *s, const EnMode *m, const double *xi0, const double *y, double ah, double av,
                     double *dy, EnForces *f, double *placed, double *dya, EnForces *fa);

/* Event indicators of mode m at (y, forces f): each >= 0 while the mode holds, normalised by weights
 * (forces) or by the bodies' sizes (gaps). Writes up to EN_IND values; returns how many. kind[i]
 * says what a crossing means (EnIndicator). */
typedef enum {
    EN_IND_OPEN = 1,      /* a closed corner's normal force reaches 0 */
    EN_IND_SLIP = 2,      /* a sticking contact's friction margin reaches 0 */
    EN_IND_STOP = 3,      /* a sliding contact's slip rate reaches 0 */
    EN_IND_LAND = 4,      /* an open corner's gap reaches 0 */
    EN_IND_OVERTURN = 5,  /* a body's rotation relative to its support reaches its side's EnBody over (pi/2 for a
                           * rectangle: it lands on the hull edge next to its corner) */
    EN_IND_FELL_OFF = 6,  /* a closed corner passes its support's edge */
    EN_IND_JAM = 7,       /* a contact sliding on one corner nears Painleve's singularity (engine_jam_margin) */
    EN_IND_OVERHANG = 8   /* body k's corner passes its support's top corner at that end (the pair switches) */
} EnIndicator;
/* The margin of a contact sliding on one corner (body k in mode m) from Painleve's singularity: the normal
 * acceleration a unit normal force gives its corner with the sliding friction it carries, over that of the
 * normal force alone (1 without friction; at 0 the normal force needed grows without bound). */
double engine_jam_margin(const EnSystem *s, const EnMode *m, int k, const double *y);
/* The jam indicator fires at this margin (the motion after it converges as the margin falls: 1e-5, 1e-7 and
 * 1e-9 give slips within 4e-5 m, 4e-7 m of one another on the case of tests/test_engine_hostile.py). */
#define EN_JAM_MARGIN 1e-8
#define EN_IND (8 * EN_MAX_BODIES)
/* The least of mode m's force indicators (those of kinds EN_IND_OPEN and EN_IND_SLIP) under the forces f. */
double engine_force_margin(const EnSystem *s, const EnMode *m, const EnForces *f);
/* (a chain's sliding contacts' slip rates are read from y's EN_XID: it holds them, engine_project) */
int engine_indicators(const EnSystem *s, const EnMode *m, const double *y, const EnForces *f, double *ind,
                      int *kind, int *body, int *corner);

/* The contact set at an event: the solution of the complementarity problem over the corners
 * that touch with zero normal rate (touching[k][i]) and the friction of bodies whose slip rate
 * is zero (sticking candidates: stuck[k]). Bodies sliding keep their sigma. Returns 0 if solved,
 * 1 if no solution exists (Painleve: a sliding contact with no consistent force). */
int engine_choose(const EnSystem *s, const double *y, double ah, double av, const int touching[][2],
                  const int stuck[], EnMode *out, EnForces *f);
/* The same with the pairs of cur (cur->over; NULL: every corner on its support's top), which out keeps. */
int engine_choose_m(const EnSystem *s, const EnMode *cur, const double *y, double ah, double av,
                    const int touching[][2], const int stuck[], EnMode *out, EnForces *f);

/* A plastic impact with Coulomb friction of the corners touching (touching[k][i], gap 0): rates
 * in y become the rates after; P_N, P_T the impulses (N s). Writes which corners keep zero normal
 * rate after (touching) and which contacts have zero slip rate (stuck). Returns 0, or 1 if no
 * solution was found. */
int engine_impact(const EnSystem *s, double *y, int touching[][2], int stuck[], double PN[][2], double PT[]);
/* The same with the pairs of cur (cur->over; NULL: none). */
int engine_impact_m(const EnSystem *s, const EnMode *cur, double *y, int touching[][2], int stuck[], double PN[][2],
                    double PT[]);

/* The plastic impact onto the constraints of m (closed corners' normal rates and sticking contacts' slip
 * rates zero, sliding contacts' friction impulses at mu of their normal ones): the rates in y become the
 * rates after. The mass-orthogonal projection where nothing slides: it never adds kinetic energy. Returns 0
 * if singular. */
int engine_plastic(const EnSystem *s, const EnMode *m, double *y);

/* Kinetic energy relative to the ground, and kinetic plus g times the rise of the centres (J). */
double engine_kinetic(const EnSystem *s, const double *y);
double engine_energy(const EnSystem *s, const double *y);

/* The state of the bodies at rest (flat, stacked, at the given slips of each body): their heights, rotations and
 * rates (the centres' x are left as given: centred, a column's X_k = X_(k-1) - xG_(k-1) + slip_k + xG_k). */
void engine_rest_state(const EnSystem *s, double *y);

/* Move the positions (and, with rates, the rates) onto the constraints of mode m: closed corners at
 * zero gap and normal rate, sticking contacts at zero slip rate and at their anchors xi0[k] (the slip
 * of the contact: its corner's slip coordinate less the corner's offset; NULL: keep the slip). On a chain
 * with rates, each contact's slip and slip rate are written to EN_XI, EN_XID too (a sticking one's rate 0). */
void engine_project(const EnSystem *s, const EnMode *m, double *y, const double *xi0, int rates);
/* Write each touching contact's slip and slip rate (its closed corner's, as they are; a sticking one's rate 0) to
 * EN_XI, EN_XID: the reduced coordinates a sliding chain integrates, where the state enters one otherwise. */
void engine_hold_slips(const EnSystem *s, const EnMode *m, double *y);

#endif
