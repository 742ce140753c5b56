/* Ground motion: the excitation selected by excitation.kind, plus the inputs
 * ground.ah and ground.av. Formulas and their sources: docs/records.md.
 *
 *   1 sine pulse      A sin(w (t - t0)) on [t0, t0 + cycles / f]
 *   2 cosine pulse    A cos(w (t - t0)) on the same window
 *   3 harmonic        table displacement D sin(w (t - t0)), acceleration -D w^2 sin(...)
 *   4 record          samples of a record file, linear between samples, times scale
 *   5 Ricker wavelet  A (1 - 2 x^2) exp(-x^2), x = pi f (t - tc), tc = t0 + 3 / f
 *   6 antisymmetric Ricker  A (x^3 - 3 x) exp(-x^2 / 2) / beta, x = 2 pi f (t - tc) / sqrt(3)
 *   7 Mavroeidis-Papageorgiou pulse: the derivative of their velocity pulse,
 *                     scaled so that its peak is A, on [t0, t0 + gamma / f]
 *
 * w = 2 pi f, A = excitation.amplitude, t0 = excitation.startTime. The
 * vertical acceleration is excitation.verticalAmplitude times the same
 * waveform (a record has its own vertical column).
 *
 * A "piece" is the analytic expression valid on a step: 0 outside the
 * excitation, 1 inside a built-in waveform's window, i + 1 on a record's
 * segment [t_i, t_i+1). A step never crosses a break point (window edges and
 * record samples), so evaluating a piece at a step's end points gives the
 * correct one-sided values at discontinuities.
 */
#ifndef ROCKING_GROUND_H
#define ROCKING_GROUND_H

#include "model.h"

/* Checks of the excitation parameters (a record is checked once attached). */
int ground_validate(const Variables *v, char *msg, size_t n);

/* Checks that need the record's samples (vertical acceleration below -g). */
int ground_validate_record(const Model *M, char *msg, size_t n);

/* The excitation's derived quantities (window, pulse shape, cells). */
void ground_derive(Model *M);

/* Piece active on a step starting at tStart. */
int model_piece(const Model *M, double tStart);

/* Total ground accelerations (excitation plus inputs), m/s^2, of the piece at t: with a moving support
 * (support.h) the horizontal one is its floor's absolute acceleration plus the input. */
void model_ground_piece(const Model *M, double t, int piece, double *ah, double *av);

/* The base's horizontal acceleration at t (m/s2): the excitation alone, without a support's motion or
 * the input ground.ah. */
double ground_base_ah(const Model *M, double t);

/* The input ground.ah (which = 0) or ground.av (1) at t (m/s2): its value, extended by the time derivatives an importer
 * set (fmi2SetRealInputDerivatives: State's inD) into a polynomial from their communication point. */
double model_input(const Model *M, int which, double t);
/* The least and largest value of input `which` over [t0, t1] (m/s2; with a margin for rounding). */
void model_input_range(const Model *M, int which, double t0, double t1, double *lo, double *hi);
/* Input `which` (any, for model_inputs_on) is nonzero or has a nonzero derivative: it moves the base beyond the
 * excitation. */
int model_input_on(const Model *M, int which);
int model_inputs_on(const Model *M);

/* Total ground accelerations at t (the piece that starts at t). */
void model_ground(const Model *M, double t, double *ah, double *av);

/* Taylor coefficients ah[0..n], av[0..n] of the total ground accelerations of
 * the piece about t: ah(t + s) = sum_k ah[k] s^k. */
void ground_series(const Model *M, double t, int piece, int n, double *ah, double *av);

/* True once the excitation is over (or there is none). */
int excitation_over(const Model *M, double t);

/* Next break point after t (a step stops there), +inf if none; piece is
 * model_piece(M, t), which the caller has already found. */
double next_breakpoint(const Model *M, double t, int piece);
/* The base's acceleration, and with it every right-hand side, is continuous where piece ends: a record's interior
 * sample (the straight lines of the two pieces meet there), on the ground or on a support the solver integrates with
 * the blocks. A step that ends there keeps its last derivative as the next step's first. (Not under a one-way
 * support: its table gives the floor's acceleration on each segment by the segment's own polynomial, equal at the
 * sample to rounding only.) */
int ground_continuous_after(const Model *M, int piece);

/* Cells on which the excitation is monotone, for the uplift search: the next
 * cell edge after a (of the piece active at a), the start of the cell that
 * holds a (a itself outside the excitation), and the piece that starts at
 * the edge b that follows piece. */
double next_cell_edge(const Model *M, double a, int piece);
/* On a moving support: whether |horizontal acceleration| <= slope (g + vertical acceleration) holds, by a bound,
 * from a to the end of the span of cells that holds it (written to end: a cell edge); 0 elsewhere. The rest phases
 * skip such spans: no uplift (slope = upliftSlope), no new extreme of the monitors (a running friction demand). */
int ground_quiet(const Model *M, double a, int piece, double slope, double *end);
double cell_start(const Model *M, double a, int piece);
int next_piece(const Model *M, int piece, double b);

#endif
