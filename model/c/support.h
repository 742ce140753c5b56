/* Supports: what the blocks stand on, between the base's ground motion and the blocks
 * (docs/supports.md).
 *
 *   support.kind 0  the ground itself (the default): the blocks feel the excitation;
 *                1  a linear shear building: the base moves with the record, the blocks stand on
 *                   floor j (building.floor, 0 = the top);
 *                2  an isolation platform: a mass on a linear spring and a viscous damper to the base.
 *
 * One-way coupling: the support moves with its base and does not feel the blocks. Its motion is
 * then exact in closed form: the record is a straight line on each segment between samples and the
 * support linear, so each mode's displacement x_r (x_r'' + k1_r x_r' + k2_r x_r = -a_g) is a
 * polynomial plus exponentials on each segment, and so is the floor's displacement relative to the
 * base, u = sum_r c_r x_r. The support's table holds, for each segment, u's coefficients there
 * (computed once at initialisation by propagating every mode exactly from sample to sample); the
 * blocks feel the floor's absolute acceleration a_f = a_g + u''. After the record's last sample the
 * support vibrates freely, forever (piece n of a record of n samples).
 *
 * Units SI; u > 0 towards +x (docs/conventions.md).
 */
#ifndef ROCKING_SUPPORT_H
#define ROCKING_SUPPORT_H

#include <stddef.h>

#include "record.h"

#define SUPPORT_GROUND 0
#define SUPPORT_BUILDING 1
#define SUPPORT_PLATFORM 2
#define SUPPORT_MAX_STOREYS 10
#define SUPPORT_MAX_TERMS (2 * SUPPORT_MAX_STOREYS)
/* Extrema of the floor's acceleration kept per record segment in the table (support_attach). */
#define SUPPORT_EDGES 8
/* The largest degree of a segment's polynomial of the floor's acceleration (support_attach). */
#define SUPPORT_ACC_MAX 24

/* The support's modes (derived from the parameters, part of Derived: no pointers). Mode r:
 * x_r'' + k1[r] x_r' + k2[r] x_r = -a_g, and the floor's displacement u = sum_r c[r] x_r. Its
 * exponential terms (one per underdamped or critically damped mode, two per overdamped one, one
 * for a damper without spring, none for a free mass): e^(lambda s) with lambda = lre + i lim. */
typedef struct {
    int nm, nt;
    double k1[SUPPORT_MAX_STOREYS], k2[SUPPORT_MAX_STOREYS], c[SUPPORT_MAX_STOREYS];
    double lre[SUPPORT_MAX_TERMS], lim[SUPPORT_MAX_TERMS], labs[SUPPORT_MAX_TERMS]; /* and |lambda| */
    double freq[SUPPORT_MAX_STOREYS]; /* natural frequencies, Hz (0: a platform without spring) */
    double fastest;                   /* largest |lambda|, 1/s */
    /* Its physical form, for two-way coupling (support.coupling = 1, coupling.c): ns floors of mass mass[i]
     * (kg), storey i of stiffness stiff[i] (N/m) between floor i - 1 and floor i (floor -1 the base), damping
     * C = a0 M + a1 K (a platform: a0 = its damping / its mass, a1 = 0); the blocks on floor j (0-based). */
    int twoWay, ns, j;
    double mass[SUPPORT_MAX_STOREYS], stiff[SUPPORT_MAX_STOREYS], a0, a1;
    /* first = 1: the support with the blocks (mass mb, kg) at rest on floor j, as first-order modes
     * (support_rest_modes): term t's modal coordinate z_t' = lambda_t z_t + beta_t a_g, floor j's
     * u_j = sum_t Re(Yj_t z_t) (Y_t the mode's shape, twice it for a complex pair: every floor's in
     * SupportShapes), and mu_t = 1^T M' Y_t (M' the floors' masses with the blocks' on floor j); up to 2 n
     * terms (a real root each where a mode is overdamped). nm = 0: the per-mode arrays above are unused. */
    int first;
    double mb;
    double bre[SUPPORT_MAX_TERMS], bim[SUPPORT_MAX_TERMS], mure[SUPPORT_MAX_TERMS], muim[SUPPORT_MAX_TERMS];
    double yjre[SUPPORT_MAX_TERMS], yjim[SUPPORT_MAX_TERMS];
} SupportModes;

/* The first-order modes' shapes on every floor (Y_t, as SupportModes' Yj: u = sum_t Re(Y_t z_t),
 * u' = sum_t Re(lambda_t Y_t z_t)) and their norms N_t = y_t^T (2 lambda_t M' + C) y_t (y_t = Y_t / 2 for a
 * complex pair, Y_t for a real root), from which a state's modal coordinates follow:
 * z_t = (y_t^T (lambda_t M' + C) u + y_t^T M' u') / N_t. */
typedef struct {
    double Yre[SUPPORT_MAX_TERMS][SUPPORT_MAX_STOREYS], Yim[SUPPORT_MAX_TERMS][SUPPORT_MAX_STOREYS];
    double Nre[SUPPORT_MAX_TERMS], Nim[SUPPORT_MAX_TERMS];
} SupportShapes;

/* The table of a record's segments: entry i (i = 0 .. n - 2: between samples i and i + 1; n - 1:
 * after the last sample) holds u(s) = q0 + q1 s + q2 s^2 + q3 s^3 + sum_j Re((Z_j + Y_j s) e^(lambda_j s)),
 * s the time since sample i, at the record's scale 1: q[4], then (Re Z, Im Z, Re Y, Im Y) for each term, then the
 * count and times s of the floor acceleration's extrema inside the segment (SUPPORT_EDGES of them at most) and its
 * peak, then u''(s) as one polynomial in s of degree accDeg: each term's exponential replaced by its Taylor series
 * about the segment's start, cut where the rest is below the rounding of the terms' own sum. The integrator's
 * right-hand side reads the floor's acceleration from it (a few multiplications instead of an exponential, a sine
 * and a cosine per term). */
typedef struct {
    int n, nt, stride;
    /* the degree of each record segment's polynomial of u'' kept after its extrema (SUPPORT_ACC_MAX at most; -1:
     * none, the segments too long for the record's sampling against the fastest mode: u'' evaluated term by term) */
    int accDeg;
    double *data;
    /* what it was built from */
    unsigned long long recHash;
    double startTime;
    SupportModes modes;
    /* the largest |a_f| at scale 1 over the record and its free vibration after it (support_peak: computed when
     * first asked for, peakKnown) */
    double peak;
    int peakKnown;
} SupportTable;

/* Blocks at rest on a two-way support, in closed form (engine_solver.c's rest, docs/supports.md): from t0 the
 * support with the blocks on it moves as the record's response of its first-order modes (the model's restTable: at
 * scale 1 from rest, its modal coordinates kept at each sample) times the record's scale, plus the free vibration
 * of those modes from what differed at t0 (each term's amplitude d there). The floors' state at any time follows
 * (support_rest_floors), and the base's work since t0 (support_rest_work), both in closed form. Part of the state. */
typedef struct {
    int on;
    double t0;
    double dre[SUPPORT_MAX_TERMS], dim[SUPPORT_MAX_TERMS];
    double workA0, b0re[SUPPORT_MAX_TERMS], b0im[SUPPORT_MAX_TERMS]; /* support_rest_work's values at t0 */
    /* the free vibration's bound on |u''| at t0 (sum |Y_tj d_t| |lambda_t|^2) and its slowest decay (1/s) */
    double accBound, decay;
} SupportRest;

struct Model;
struct Variables;

/* Build (or keep) the table of M's support with the blocks at rest on it (M->d.supRest, first-order modes) under
 * M's record, as support_attach; emptied where M has none (support_rest_needed false). */
int support_rest_attach(const struct Model *M, SupportTable *T, RecordAlloc alloc, RecordFree release, char *msg,
                        size_t n);
/* T was built for M's support with the blocks at rest on it and M's record. */
int support_rest_matches(const struct Model *M, const SupportTable *T);
/* M's support can hold its blocks at rest in closed form: two-way, under a record, its first-order modes found. */
int support_rest_needed(const struct Model *M);
/* Start the closed form at t (M->sup is then M->restTable, the floors' state z = (u_0, u_0', u_1, ...) relative to
 * the base at t). Returns 0, or 1 where it cannot (before the record starts, no table). */
int support_rest_start(struct Model *M, double t, const double *z);
/* The floors' state (u_0, u_0', u_1, u_1', ...) relative to the base at t (at or after the start), and the base's
 * work on blocks and support since the start (J), exact. */
void support_rest_floors(const struct Model *M, double t, double *z);
double support_rest_work(const struct Model *M, double t);

/* The bare support's peak floor acceleration at scale 1 (m/s^2) of M's record, T the table built for it: computed
 * on the first call (a few ms for a long record; a sweep's runs that do not read it do not pay for it), kept. */
double support_peak(const struct Model *M, SupportTable *T);
/* Checks of the support's parameters (with the excitation's kind, which a support needs a record of). */
int support_validate(const struct Variables *v, char *msg, size_t n);
/* The modes of the support's parameters. */
void support_derive(const struct Variables *v, SupportModes *sm);
/* The first-order modes (first = 1) of the support sm (its physical form) with blocks of mass mb (kg) at rest on
 * its floor j, which then moves them with it: the eigenvalues and eigenvectors of M' u'' + C u' + K u = -M' 1 a_g,
 * M' the floors' masses with mb on floor j (support_rest.c). Returns 0, or 1 where that form is not available to
 * full precision (a support without stiffness, a repeated or zero eigenvalue, ill-conditioned modes): the blocks at
 * rest are then integrated with the support. */
int support_rest_modes(const SupportModes *sm, double mb, SupportModes *out, SupportShapes *shapes);
/* The modal coordinates (zre + i zim per term) of the floors' state z = (u_0, u_0', u_1, ...) relative to the base. */
void support_rest_coordinates(const SupportModes *sm, const SupportShapes *shapes, const double *z, double *zre,
                              double *zim);

/* Build (or keep, when its key matches) the table of M's support under M's record. Returns 0, or
 * nonzero with a one-line reason (out of memory). A model without a moving support needs none:
 * the table is then emptied. */
int support_attach(const struct Model *M, SupportTable *T, RecordAlloc alloc, RecordFree release, char *msg, size_t n);
void support_free(SupportTable *T, RecordFree release);

/* The length of the free vibration after the record that the peak floor acceleration covers: SUPPORT_TAIL_PERIODS
 * periods of the slowest mode, at most SUPPORT_TAIL_MAX s (runners.engine.floor_motion follows the same). */
#define SUPPORT_TAIL_PERIODS 5.0
#define SUPPORT_TAIL_MAX 60.0
/* The model needs a table: a building or a platform under a record (with its record attached); with two-way
 * coupling it gives the bare support's peak floor acceleration alone (the support then moves with the blocks). */
int support_needed(const struct Model *M);
/* T was built for M's support and record. */
int support_matches(const struct Model *M, const SupportTable *T);
/* The support moves: it needs a table and has it. */
int support_moves(const struct Model *M);
/* The floor's acceleration relative to the base (m/s2) at t on piece `piece` (record pieces 1..n-1,
 * n after the end; 0 before the start: at rest). */
double support_relative_acceleration(const struct Model *M, double t, int piece);
/* The floor's absolute acceleration's largest magnitude (m/s^2) over record piece `piece` (1 .. n - 1), exact (the
 * table's, at its extrema), or -1 where the table does not know it (after the record, or more extrema than it keeps). */
double support_segment_peak(const struct Model *M, int piece);
/* A bound on its magnitude over [t0, t1] (t0 at or after the piece's start). */
double support_acceleration_bound(const struct Model *M, int piece, double t0, double t1);
/* Its Taylor coefficients c[0..nc] about t (added to c). */
void support_series(const struct Model *M, double t, int piece, int nc, double *c);
/* The floor's displacement (m) and velocity (m/s) relative to the base. */
void support_motion(const struct Model *M, double t, int piece, double *u, double *v);
/* Cells on which the floor's absolute acceleration is monotone (ground.h's next_cell_edge and cell_start):
 * each record segment (after the end, each stretch of SUPPORT_FREE_CELL periods of the fastest mode) cut where
 * the floor's acceleration has an extremum. aBase1 is the base's acceleration slope on the piece (m/s3). */
double support_next_edge(const struct Model *M, double a, int piece, double t0, double t1, double aBase1);
double support_cell_start(const struct Model *M, double a, int piece, double t0, double t1, double aBase1);
/* The cell [t0, t1] of the free vibration that holds a (t0 = the last sample's time, then cells of fixed length). */
void support_free_cell(const struct Model *M, double a, double tEnd, double *t0, double *t1);

#endif
