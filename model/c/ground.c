/* Ground motion: built-in waveforms, pulses and records (see ground.h). */
#include "ground.h"
#include "support.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#define FAIL(...)                      \
    do {                               \
        snprintf(msg, n, __VA_ARGS__); \
        return 1;                      \
    } while (0)

/* Half width of the window of a Ricker wavelet, in periods 1 / f: the
 * Gaussian factor there is below 1e-22 of the peak. */
#define RICKER_HALF_WINDOW 3.0

/* Samples per period of the fastest sine when the cells of a
 * Mavroeidis-Papageorgiou pulse are located. */
#define MP_SAMPLES_PER_PERIOD 32

/* Largest gamma of the Mavroeidis-Papageorgiou pulse (its cells must fit in
 * MAX_CELLS). */
#define MP_MAX_GAMMA 20.0

/* Ground motions beyond these are refused as mistakes (units, a stray exponent):
 * at 100 g or 1 kHz the rigid-rocking model says nothing about a real block. */
#define MAX_GROUND_ACCELERATION 1000.0 /* m/s^2 */
#define MIN_FREQUENCY 1e-4 /* Hz */
#define MAX_FREQUENCY 1e3  /* Hz */

static const char *const KIND_NAMES =
    "0 (none), 1 (sine pulse), 2 (cosine pulse), 3 (harmonic), 4 (record), 5 (Ricker wavelet), "
    "6 (antisymmetric Ricker wavelet) or 7 (Mavroeidis-Papageorgiou pulse)";

int ground_validate(const Variables *v, char *msg, size_t n) {
    int k = v->kind;
    if (k < 0 || k >= KIND_COUNT) FAIL("excitation.kind = %d must be %s", k, KIND_NAMES);
    if (k == KIND_NONE) return 0;
    if (k == KIND_RECORD) {
        if (v->verticalAmplitude != 0.0)
            FAIL("excitation.verticalAmplitude = %g applies to built-in waveforms: a record's vertical "
                 "acceleration is the third column of its file", v->verticalAmplitude);
        if (v->amplitude != 0.0)
            FAIL("excitation.amplitude = %g applies to built-in waveforms: scale a record with "
                 "excitation.scale", v->amplitude);
        return 0;
    }
    if (!(v->frequency > 0)) FAIL("excitation.frequency = %g must be > 0 Hz", v->frequency);
    if (!(v->frequency >= MIN_FREQUENCY && v->frequency <= MAX_FREQUENCY))
        FAIL("excitation.frequency = %g Hz is outside [%g, %g] Hz: a mistake rather than a ground motion",
             v->frequency, MIN_FREQUENCY, MAX_FREQUENCY);
    double peak = k == KIND_HARMONIC ? fabs(v->displacement) * pow(2.0 * M_PI * v->frequency, 2) : fabs(v->amplitude);
    if (!(peak <= MAX_GROUND_ACCELERATION))
        FAIL("the %s peak acceleration %g m/s2 exceeds %g m/s2 (about 100 g): check excitation.%s",
             k == KIND_HARMONIC ? "harmonic's" : "pulse's", peak, MAX_GROUND_ACCELERATION,
             k == KIND_HARMONIC ? "displacement and frequency" : "amplitude");
    if ((k == KIND_SINE_PULSE || k == KIND_COSINE_PULSE) && !(v->cycles > 0))
        FAIL("excitation.cycles = %g must be > 0 for a pulse", v->cycles);
    if (k == KIND_HARMONIC && !(v->cycles >= 0))
        FAIL("excitation.cycles = %g must be >= 0 (0: endless harmonic)", v->cycles);
    if (k == KIND_MP_PULSE && !(v->gamma > 1.0 && v->gamma <= MP_MAX_GAMMA))
        FAIL("excitation.gamma = %g must be in (1, %g] for the Mavroeidis-Papageorgiou pulse", v->gamma,
             MP_MAX_GAMMA);
    if (!(fabs(v->verticalAmplitude) <= MAX_GROUND_ACCELERATION))
        FAIL("excitation.verticalAmplitude = %g m/s2 exceeds %g m/s2 (about 100 g)", v->verticalAmplitude,
             MAX_GROUND_ACCELERATION);
    return 0;
}

int ground_validate_record(const Model *M, char *msg, size_t n) {
    const Record *r = M->rec;
    if (!r || r->n < 2) FAIL("excitation.kind = 4 (record) but no record is attached");
    if (!(fabs(M->v.scale) * r->peak <= MAX_GROUND_ACCELERATION))
        FAIL("record file '%s': excitation.scale %g brings its peak acceleration to %g m/s2, beyond %g m/s2 "
             "(about 100 g)", M->v.file, M->v.scale, fabs(M->v.scale) * r->peak, MAX_GROUND_ACCELERATION);
    return 0;
}

/* ------------------------------------------------------------ pulses */

/* beta: the peak of |(x^3 - 3x) exp(-x^2/2)|, at x^2 = 3 - sqrt(6) */
static double ricker_antisymmetric_peak(void) {
    double x2 = 3.0 - sqrt(6.0);
    return sqrt(6.0) * sqrt(x2) * exp(-0.5 * x2);
}

/* The Mavroeidis-Papageorgiou acceleration without its factor -pi fp A:
 * sum_j c_j sin(w_j tau + nu), and its derivative in tau. */
static double mp_raw(const Derived *d, double nu, double tau) {
    double s = 0.0;
    for (int j = 0; j < 3; j++) s += d->mpCoef[j] * sin(d->mpOmega[j] * tau + nu);
    return s;
}

static double mp_raw_dot(const Derived *d, double nu, double tau) {
    double s = 0.0;
    for (int j = 0; j < 3; j++) s += d->mpCoef[j] * d->mpOmega[j] * cos(d->mpOmega[j] * tau + nu);
    return s;
}

static void add_cell(Derived *d, double t) {
    if (d->nCells < MAX_CELLS) d->cell[d->nCells++] = t;
}

/* Mavroeidis-Papageorgiou: extrema of the acceleration (zeros of its
 * derivative, sampled and bisected) become cell edges; the largest |value|
 * there is the peak that normalises the pulse. */
static void mp_derive(const Variables *v, Derived *d) {
    double w = 2.0 * M_PI * v->frequency, g = v->gamma, nu = v->phase;
    d->mpOmega[0] = w;
    d->mpOmega[1] = w * (1.0 + 1.0 / g);
    d->mpOmega[2] = w * (1.0 - 1.0 / g);
    d->mpCoef[0] = 1.0;
    d->mpCoef[1] = 0.5 * (1.0 + 1.0 / g);
    d->mpCoef[2] = 0.5 * (1.0 - 1.0 / g);
    double half = 0.5 * g / v->frequency;
    d->pulseCentre = v->startTime + half;
    int samples = (int)ceil(MP_SAMPLES_PER_PERIOD * (g + 1.0)) + 8;
    double peak = 0.0, lo = -half, flo = mp_raw_dot(d, nu, lo);
    add_cell(d, d->excStart);
    for (int i = 1; i <= samples; i++) {
        double hi = -half + 2.0 * half * i / samples, fhi = mp_raw_dot(d, nu, hi);
        if (flo == 0.0 || flo * fhi < 0.0) { /* every interval, the last one included */
            double a = lo, b = hi, fa = flo;
            if (flo != 0.0) {
                for (int it = 0; it < 80 && b - a > 4e-16 * half; it++) {
                    double m = 0.5 * (a + b), fm = mp_raw_dot(d, nu, m);
                    if ((fm < 0) == (fa < 0)) a = m, fa = fm;
                    else b = m;
                }
            }
            double root = flo == 0.0 ? lo : 0.5 * (a + b);
            if (root > -half && root < half) add_cell(d, d->pulseCentre + root);
            peak = fmax(peak, fabs(mp_raw(d, nu, root)));
        }
        lo = hi, flo = fhi;
    }
    add_cell(d, d->excEnd);
    d->pulseNorm = peak > 0 ? peak : 1.0;
}

void ground_derive(Model *M) {
    const Variables *v = &M->v;
    Derived *d = &M->d;
    d->omegaExc = 2.0 * M_PI * v->frequency;
    d->accAmp = v->kind == KIND_HARMONIC ? v->displacement * d->omegaExc * d->omegaExc
                : v->kind == KIND_RECORD ? v->scale
                                         : v->amplitude;
    d->nCells = 0;
    d->pulseNorm = 1.0;
    d->recN = 0;
    d->recHash = 0;
    d->excStart = v->startTime;
    switch (v->kind) {
    case KIND_NONE:
        d->excStart = d->excEnd = INFINITY;
        break;
    case KIND_SINE_PULSE:
    case KIND_COSINE_PULSE:
        d->excEnd = v->startTime + v->cycles / v->frequency;
        break;
    case KIND_HARMONIC:
        d->excEnd = v->cycles == 0 ? INFINITY : v->startTime + v->cycles / v->frequency;
        break;
    case KIND_RECORD:
        d->excStart = v->startTime + M->rec->t[0];
        d->excEnd = v->startTime + M->rec->t[M->rec->n - 1];
        d->recN = M->rec->n;
        d->recHash = M->rec->hash;
        break;
    case KIND_RICKER:
    case KIND_RICKER_ANTISYMMETRIC: {
        int anti = v->kind == KIND_RICKER_ANTISYMMETRIC;
        d->excEnd = v->startTime + 2.0 * RICKER_HALF_WINDOW / v->frequency;
        d->pulseCentre = v->startTime + RICKER_HALF_WINDOW / v->frequency;
        d->pulseRate = anti ? 2.0 * M_PI * v->frequency / sqrt(3.0) : M_PI * v->frequency;
        d->pulseNorm = anti ? ricker_antisymmetric_peak() : 1.0;
        /* extrema: x = 0, +-sqrt(3/2) (symmetric); x^2 = 3 -+ sqrt(6) (antisymmetric) */
        double x[4];
        int nx;
        if (anti) {
            x[0] = -sqrt(3.0 + sqrt(6.0)), x[1] = -sqrt(3.0 - sqrt(6.0));
            x[2] = -x[1], x[3] = -x[0], nx = 4;
        } else {
            x[0] = -sqrt(1.5), x[1] = 0.0, x[2] = sqrt(1.5), nx = 3;
        }
        add_cell(d, d->excStart);
        for (int i = 0; i < nx; i++) add_cell(d, d->pulseCentre + x[i] / d->pulseRate);
        add_cell(d, d->excEnd);
        break;
    }
    case KIND_MP_PULSE:
        d->excEnd = v->startTime + v->gamma / v->frequency;
        mp_derive(v, d);
        break;
    default:
        d->excStart = d->excEnd = INFINITY;
    }
}

/* ------------------------------------------------------------ values */

/* The built-in waveform inside its window, peak 1 (no window test). */
static double wave_inside(const Model *M, double t) {
    const Derived *d = &M->d;
    switch (M->v.kind) {
    case KIND_SINE_PULSE:
        return sin(d->omegaExc * (t - M->v.startTime));
    case KIND_COSINE_PULSE:
        return cos(d->omegaExc * (t - M->v.startTime));
    case KIND_HARMONIC:
        return -sin(d->omegaExc * (t - M->v.startTime)); /* table displacement D sin(...) */
    case KIND_RICKER: {
        double x = d->pulseRate * (t - d->pulseCentre), x2 = x * x;
        return (1.0 - 2.0 * x2) * exp(-x2);
    }
    case KIND_RICKER_ANTISYMMETRIC: {
        double x = d->pulseRate * (t - d->pulseCentre), x2 = x * x;
        return x * (x2 - 3.0) * exp(-0.5 * x2) / d->pulseNorm;
    }
    case KIND_MP_PULSE:
        return -mp_raw(d, M->v.phase, t - d->pulseCentre) / d->pulseNorm;
    default:
        return 0.0;
    }
}

/* Sample i of the record, placed in time. */
static double record_time(const Model *M, int i) { return M->v.startTime + M->rec->t[i]; }

/* A record piece (segment i + 1 between samples i and i + 1) that exists in the
 * attached record: anything else (a corrupted restored state) counts as outside. */
static int record_piece_ok(const Model *M, int piece) { return piece >= 1 && piece <= M->rec->n - 1; }

int model_piece(const Model *M, double tStart) {
    if (tStart >= M->d.excEnd && tStart >= M->d.excStart && support_moves(M)) return M->rec->n; /* free vibration */
    if (tStart < M->d.excStart || tStart >= M->d.excEnd) return 0;
    if (M->v.kind != KIND_RECORD) return 1;
    /* record_time(lo) <= tStart < record_time(hi) (a record has two samples at least): first at the sample an evenly
     * sampled record would put tStart after (records nearly always are: then that piece or the next), then by
     * bisection */
    int n = M->rec->n, lo = 0, hi = n - 1;
    double span = record_time(M, n - 1) - record_time(M, 0);
    int g = span > 0.0 ? (int)fmin(fmax((tStart - record_time(M, 0)) / span * (n - 1), 0.0), n - 2.0) : 0;
    if (record_time(M, g) <= tStart) {
        if (tStart < record_time(M, g + 1)) return g + 1;
        if (g + 2 < n && tStart < record_time(M, g + 2)) return g + 2;
        lo = g + 1;
    } else {
        if (g > 0 && record_time(M, g - 1) <= tStart) return g;
        hi = g;
    }
    while (hi - lo > 1) {
        int mid = lo + (hi - lo) / 2;
        if (record_time(M, mid) <= tStart) lo = mid;
        else hi = mid;
    }
    return lo + 1;
}

/* The excitation alone (the base's motion, no support, no inputs) of the piece at t. */
static void excitation_piece(const Model *M, double t, int piece, double *ah, double *av) {
    double h = 0.0, vert = 0.0;
    if (M->v.kind == KIND_RECORD) {
        if (record_piece_ok(M, piece)) {
            const Record *r = M->rec;
            int i = piece - 1;
            double t0 = record_time(M, i), t1 = record_time(M, i + 1), s = (t - t0) / (t1 - t0);
            /* (1 - s) a0 + s a1 is exact at both ends of the segment */
            h = M->d.accAmp * ((1.0 - s) * r->ah[i] + s * r->ah[i + 1]);
            if (r->vertical) vert = M->d.accAmp * ((1.0 - s) * r->av[i] + s * r->av[i + 1]);
        }
    } else if (piece) {
        double w = wave_inside(M, t);
        h = M->d.accAmp * w;
        vert = M->v.verticalAmplitude * w;
    }
    *ah = h;
    *av = vert;
}

static double input_value(const Model *M, int which) {
    return which == 0 ? M->v.ahIn : which == 1 ? M->v.avIn : M->v.supportForce;
}

static int input_moves(const Model *M, int which) { return M->s.inD[which][0] != 0.0 || M->s.inD[which][1] != 0.0; }

double model_input(const Model *M, int which, double t) {
    if (!input_moves(M, which)) return input_value(M, which);
    double x = t - M->s.inT0[which];
    return input_value(M, which) + x * (M->s.inD[which][0] + 0.5 * M->s.inD[which][1] * x);
}

void model_input_range(const Model *M, int which, double t0, double t1, double *lo, double *hi) {
    double u = input_value(M, which);
    *lo = *hi = u;
    if (!input_moves(M, which)) return;
    double d1 = M->s.inD[which][0], d2 = M->s.inD[which][1], x0 = t0 - M->s.inT0[which], x1 = t1 - M->s.inT0[which];
    double ends[3];
    ends[0] = model_input(M, which, t0);
    ends[1] = ends[2] = model_input(M, which, t1);
    if (d2 != 0.0 && -d1 / d2 > x0 && -d1 / d2 < x1) ends[2] = u - 0.5 * d1 * d1 / d2; /* the vertex */
    double X = fmax(fabs(x0), fabs(x1)), slack = 8.0 * DBL_EPSILON * (fabs(u) + fabs(d1) * X + fabs(d2) * X * X);
    *lo = fmin(fmin(ends[0], ends[1]), ends[2]) - slack;
    *hi = fmax(fmax(ends[0], ends[1]), ends[2]) + slack;
}

int model_input_on(const Model *M, int which) { return input_value(M, which) != 0.0 || input_moves(M, which); }

int model_inputs_on(const Model *M) { return model_input_on(M, 0) || model_input_on(M, 1) || model_input_on(M, 2); }

void model_ground_piece(const Model *M, double t, int piece, double *ah, double *av) {
    double h, vert;
    excitation_piece(M, t, piece, &h, &vert);
    /* a support moves under it: its floor's acceleration relative to the base (0 without one; the
     * support is rigid vertically) */
    if (M->sup) h += support_relative_acceleration(M, t, piece);
    *ah = h + model_input(M, 0, t);
    *av = vert + model_input(M, 1, t);
}

double ground_base_ah(const Model *M, double t) {
    double h, vert;
    excitation_piece(M, t, model_piece(M, t), &h, &vert);
    return h;
}

void model_ground(const Model *M, double t, double *ah, double *av) {
    model_ground_piece(M, t, model_piece(M, t), ah, av);
}

/* ------------------------------------------------------------ Taylor coefficients */

/* Coefficients of sin(w (t0 + s) + phi) in s (cos(...) if cosine). */
static void sine_series(double w, double t0, double phi, int cosine, int n, double *c) {
    double u = w * t0 + phi, su = sin(u), cu = cos(u), f = 1.0;
    for (int k = 0; k <= n; k++) {
        /* d^k/du^k sin(u) = sin(u + k pi / 2), and cos(u + k pi / 2) = sin(u + (k + 1) pi / 2) */
        int m = (k + cosine) % 4;
        c[k] = (m == 0 ? su : m == 1 ? cu : m == 2 ? -su : -cu) * f;
        f *= w / (k + 1);
    }
}

/* Coefficients of P(s) exp(-q (x0 + r s)^2) with P the polynomial p[0..3] in s:
 * exp's coefficients follow (k + 1) e[k+1] = -2 q r x0 e[k] - 2 q r^2 e[k-1]. */
static void gauss_series(double q, double r, double x0, const double *p, int n, double *c) {
    double e[TAYLOR_MAX + 2];
    e[0] = exp(-q * x0 * x0);
    if (n >= 1) e[1] = -2.0 * q * r * x0 * e[0];
    for (int k = 1; k < n; k++) e[k + 1] = (-2.0 * q * r * x0 * e[k] - 2.0 * q * r * r * e[k - 1]) / (k + 1);
    for (int k = 0; k <= n; k++) {
        double s = 0.0;
        for (int j = 0; j <= 3 && j <= k; j++) s += p[j] * e[k - j];
        c[k] = s;
    }
}

static void wave_series(const Model *M, double t, int n, double *w) {
    const Derived *d = &M->d;
    double c[TAYLOR_MAX + 1];
    for (int k = 0; k <= n; k++) w[k] = 0.0;
    switch (M->v.kind) {
    case KIND_SINE_PULSE:
    case KIND_HARMONIC:
        sine_series(d->omegaExc, t - M->v.startTime, 0.0, 0, n, w);
        if (M->v.kind == KIND_HARMONIC)
            for (int k = 0; k <= n; k++) w[k] = -w[k];
        break;
    case KIND_COSINE_PULSE:
        sine_series(d->omegaExc, t - M->v.startTime, 0.0, 1, n, w);
        break;
    case KIND_RICKER: {
        double r = d->pulseRate, x0 = r * (t - d->pulseCentre);
        double p[4] = {1.0 - 2.0 * x0 * x0, -4.0 * r * x0, -2.0 * r * r, 0.0};
        gauss_series(1.0, r, x0, p, n, w);
        break;
    }
    case KIND_RICKER_ANTISYMMETRIC: {
        double r = d->pulseRate, x0 = r * (t - d->pulseCentre), b = d->pulseNorm;
        double p[4] = {(x0 * x0 * x0 - 3.0 * x0) / b, (3.0 * x0 * x0 - 3.0) * r / b, 3.0 * x0 * r * r / b,
                       r * r * r / b};
        gauss_series(0.5, r, x0, p, n, w);
        break;
    }
    case KIND_MP_PULSE:
        for (int j = 0; j < 3; j++) {
            sine_series(d->mpOmega[j], t - d->pulseCentre, M->v.phase, 0, n, c);
            for (int k = 0; k <= n; k++) w[k] -= d->mpCoef[j] * c[k] / d->pulseNorm;
        }
        break;
    default:
        break;
    }
}

void ground_series(const Model *M, double t, int piece, int n, double *ah, double *av) {
    for (int k = 0; k <= n; k++) ah[k] = av[k] = 0.0;
    if (M->v.kind == KIND_RECORD && !record_piece_ok(M, piece)) {
        /* outside the record: only the inputs */
    } else if (M->v.kind == KIND_RECORD) {
        const Record *r = M->rec;
        int i = piece - 1;
        double t0 = record_time(M, i), t1 = record_time(M, i + 1), s = (t - t0) / (t1 - t0);
        double k = M->d.accAmp;
        ah[0] = k * ((1.0 - s) * r->ah[i] + s * r->ah[i + 1]);
        if (n >= 1) ah[1] = k * (r->ah[i + 1] - r->ah[i]) / (t1 - t0);
        if (r->vertical) {
            av[0] = k * ((1.0 - s) * r->av[i] + s * r->av[i + 1]);
            if (n >= 1) av[1] = k * (r->av[i + 1] - r->av[i]) / (t1 - t0);
        }
    } else if (piece) {
        double w[TAYLOR_MAX + 1];
        wave_series(M, t, n, w);
        for (int k = 0; k <= n; k++) {
            ah[k] = M->d.accAmp * w[k];
            av[k] = M->v.verticalAmplitude * w[k];
        }
    }
    if (M->sup) support_series(M, t, piece, n, ah);
    for (int i = 0; i < 2; i++) { /* the inputs' polynomials about t */
        double *c = i ? av : ah;
        c[0] += model_input(M, i, t);
        if (!input_moves(M, i)) continue;
        if (n >= 1) c[1] += M->s.inD[i][0] + M->s.inD[i][1] * (t - M->s.inT0[i]);
        if (n >= 2) c[2] += 0.5 * M->s.inD[i][1];
    }
}

/* ------------------------------------------------------------ break points and cells */

/* (a moving support vibrates on after its base's record: never over) */
int excitation_over(const Model *M, double t) {
    return M->v.kind == KIND_NONE || (t >= M->d.excEnd && !support_moves(M));
}

double next_breakpoint(const Model *M, double t, int piece) {
    if (M->v.kind == KIND_NONE) return INFINITY;
    if (t < M->d.excStart) return M->d.excStart;
    if (t >= M->d.excEnd) return INFINITY;
    if (M->v.kind == KIND_RECORD) return record_piece_ok(M, piece) ? record_time(M, piece) : M->d.excEnd;
    return M->d.excEnd;
}

int ground_continuous_after(const Model *M, int piece) {
    return M->v.kind == KIND_RECORD && M->rec && !M->sup && record_piece_ok(M, piece) && record_piece_ok(M, piece + 1);
}

/* The built-in sine waveforms are monotone on quarter periods from their start. */
static int quarter_cells(const Model *M) { return M->v.kind >= KIND_SINE_PULSE && M->v.kind <= KIND_HARMONIC; }

/* A moving support: its cells are the record's segments (after the end, the free vibration's stretches)
 * cut at the floor acceleration's extrema. Its piece's span [t0, t1] and base slope (m/s3). */
static void support_span(const Model *M, double a, int piece, double *t0, double *t1, double *slope) {
    const Record *r = M->rec;
    if (piece >= r->n) {
        support_free_cell(M, a, M->d.excEnd, t0, t1);
        *slope = 0.0;
        return;
    }
    *t0 = record_time(M, piece - 1);
    *t1 = record_time(M, piece);
    *slope = M->d.accAmp * (r->ah[piece] - r->ah[piece - 1]) / (r->t[piece] - r->t[piece - 1]);
}

static int support_piece(const Model *M, double a, int piece) {
    return support_moves(M) && a >= M->d.excStart && piece >= 1 && piece <= M->rec->n;
}

int ground_quiet(const Model *M, double a, int piece, double slope, double *end) {
    if (!support_piece(M, a, piece)) return 0;
    double t0, t1, s, h0, v0, h1, v1;
    support_span(M, a, piece, &t0, &t1, &s);
    /* the base is a straight line on the piece (0 after the record): its extremes are at the ends */
    excitation_piece(M, a, piece, &h0, &v0);
    excitation_piece(M, t1, piece, &h1, &v1);
    double hLo, hHi, vLo, vHi;
    model_input_range(M, 0, a, t1, &hLo, &hHi);
    model_input_range(M, 1, a, t1, &vLo, &vHi);
    double gmin = M->v.g + fmin(v0, v1) + vLo, limit = (1.0 - 1e-9) * slope * gmin, hIn = fmax(fabs(hLo), fabs(hHi));
    *end = t1;
    if (!(gmin > 0)) return 0;
    /* a bound of the floor's acceleration (the base's, plus the support's from its polynomial on the segment), and
     * where that is not enough, the segment's exact peak (found once and kept by the table) */
    if (fmax(fabs(h0), fabs(h1)) + support_acceleration_bound(M, piece, a, t1) + hIn < limit) return 1;
    double peak = support_segment_peak(M, piece);
    return peak >= 0 && peak + hIn < limit;
}

/* Where the total horizontal acceleration on piece turns, when an input's second derivative bends it (State's inD): its
 * excitation there a straight line of slope s (a record's segment, or none), s + d1 + d2 (t - inT0) vanishes; NAN if
 * the input is not bent. (Only on the ground: instance_set_real_derivative.) */
static double input_vertex(const Model *M, double a, int piece) {
    const State *S = &M->s;
    if (S->inD[0][1] == 0.0) return NAN;
    double s = 0.0;
    if (M->v.kind == KIND_RECORD && a >= M->d.excStart && a < M->d.excEnd && record_piece_ok(M, piece)) {
        const Record *r = M->rec;
        s = M->d.accAmp * (r->ah[piece] - r->ah[piece - 1]) / (r->t[piece] - r->t[piece - 1]);
    }
    return S->inT0[0] - (s + S->inD[0][0]) / S->inD[0][1];
}

static double cell_edge(const Model *M, double a, int piece);

double next_cell_edge(const Model *M, double a, int piece) {
    double b = cell_edge(M, a, piece), v = input_vertex(M, a, piece);
    return v > a && v < b ? v : b;
}

static double cell_edge(const Model *M, double a, int piece) {
    const Derived *d = &M->d;
    if (M->v.kind == KIND_NONE) return INFINITY;
    if (a < d->excStart) return d->excStart;
    if (support_piece(M, a, piece)) {
        double t0, t1, slope;
        support_span(M, a, piece, &t0, &t1, &slope);
        return support_next_edge(M, a, piece, t0, t1, slope + M->s.inD[0][0]); /* (a sloped input's too) */
    }
    if (a >= d->excEnd) return INFINITY;
    if (M->v.kind == KIND_RECORD) return record_piece_ok(M, piece) ? record_time(M, piece) : d->excEnd;
    if (quarter_cells(M)) {
        double T4 = 0.25 / M->v.frequency;
        double j = floor((a - d->excStart) / T4) + 1.0;
        double b = d->excStart + j * T4;
        if (b <= a) b = d->excStart + (j + 1.0) * T4;
        return fmin(b, d->excEnd);
    }
    for (int i = 0; i < d->nCells; i++)
        if (d->cell[i] > a) return d->cell[i];
    return d->excEnd;
}

static double cell_begin(const Model *M, double a, int piece);

double cell_start(const Model *M, double a, int piece) {
    double lo = cell_begin(M, a, piece), v = input_vertex(M, a, piece);
    return v <= a && v > lo ? v : lo;
}

static double cell_begin(const Model *M, double a, int piece) {
    const Derived *d = &M->d;
    if (support_piece(M, a, piece)) {
        double t0, t1, slope;
        support_span(M, a, piece, &t0, &t1, &slope);
        return support_cell_start(M, a, piece, t0, t1, slope + M->s.inD[0][0]);
    }
    if (M->v.kind == KIND_NONE || a < d->excStart || a >= d->excEnd) return a;
    if (M->v.kind == KIND_RECORD) return record_piece_ok(M, piece) ? record_time(M, piece - 1) : a;
    if (quarter_cells(M)) {
        double T4 = 0.25 / M->v.frequency;
        double lo = d->excStart + floor((a - d->excStart) / T4) * T4;
        return lo <= a ? lo : a;
    }
    double lo = d->excStart;
    for (int i = 0; i < d->nCells; i++)
        if (d->cell[i] <= a) lo = d->cell[i];
    return lo;
}

int next_piece(const Model *M, int piece, double b) {
    if (M->v.kind != KIND_RECORD) return model_piece(M, b);
    /* a moving support's cells end inside a segment too: the piece goes on there */
    if (support_piece(M, b, piece) && (piece == M->rec->n || b < record_time(M, piece))) return piece;
    if (b >= M->d.excEnd && support_moves(M)) return M->rec->n;
    if (b < M->d.excStart || b >= M->d.excEnd) return 0;
    int next = piece == 0 ? 1 : piece + 1; /* the segment after the edge b */
    return record_piece_ok(M, next) ? next : 0;
}
