/* Event location shared by the solvers (see events.h). */
#include "events.h"

#include "contact.h"
#include "ground.h"

#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>

int says(const Logger *log, int category) { return log && log->fn && (category != LOG_EVENTS || log->events); }

void say(const Logger *log, int category, const char *fmt, ...) {
    char buf[512];
    va_list ap;
    if (!says(log, category)) return;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof(buf), fmt, ap);
    va_end(ap);
    log->fn(log->ctx, category, buf);
}

int adaptive_step(RhsFn f, const void *ctx, int n, double t, const double *y,
                  const double *f0, double *h, double hmax, double rtol, double atol,
                  double *y1, double *f1, Dense *cont, double *hNext,
                  int *hitMax, long long *rejected) {
    return adaptive_step_controlled(RK_DOPRI5, f, ctx, n, n, NULL, t, y, f0, h, hmax, rtol, atol, y1, f1, cont, NULL,
                                    hNext, hitMax, rejected);
}

/* rk_step with its error estimates (err3: DOP853's of order 3) */
static void rk_step_errors(int method, RhsFn f, const void *ctx, int n, double t, const double *y, const double *f0,
                           double h, double *y1, double *f1, Dense *cont, Dop853Stages *st, double *err,
                           double *err3) {
    if (method == RK_DOP853) dop853_step(f, ctx, n, t, y, f0, h, y1, f1, err, err3, cont, st);
    else dopri5_step(f, ctx, n, t, y, f0, h, y1, f1, err, cont);
}

void rk_step(int method, RhsFn f, const void *ctx, int n, double t, const double *y, const double *f0, double h,
             double *y1, double *f1, Dense *cont, Dop853Stages *st) {
    double err[NMAX], err3[NMAX];
    rk_step_errors(method, f, ctx, n, t, y, f0, h, y1, f1, cont, st, err, err3);
}

/* dopri5_error_norm with the absolute tolerance of component i scaled by scale[i] (0: not controlled). */
static double scaled_error_norm(int n, const double *scale, const double *y0, const double *y1, const double *err,
                                double rtol, double atol) {
    double sum = 0.0;
    int counted = 0;
    for (int i = 0; i < n; i++) {
        if (scale[i] == 0.0) continue; /* a component that rides along */
        double sc = atol * scale[i] + rtol * fmax(fabs(y0[i]), fabs(y1[i]));
        double e = err[i] / sc;
        sum += e * e;
        counted++;
    }
    return counted ? sqrt(sum / counted) : 0.0;
}

int adaptive_step_controlled(int method, RhsFn f, const void *ctx, int n, int nErr, const double *scale, double t,
                             const double *y, const double *f0, double *h, double hmax, double rtol, double atol,
                             double *y1, double *f1, Dense *cont, Dop853Stages *st, double *hNext,
                             int *hitMax, long long *rejected) {
    double err[NMAX], err3[NMAX], hh = *h;
    /* the step-size exponent: 1 / (the lower order + 1) */
    double expo = method == RK_DOP853 ? -1.0 / 8.0 : -0.2;
    double hmin = 16.0 * DBL_EPSILON * fmax(1.0, fabs(t));
    if (!(hh > 0)) hh = dopri5_initial_step(f, ctx, nErr, t, y, f0, rtol, atol, fmin(hmax, 1.0));
    if (!(hh >= hmin)) {                  /* zero, NaN, or below the resolution of t */
        if (hmax > 0 && hmax < hmin) {
            hh = hmax;                        /* the last sliver before a break point */
        } else {
            *h = hh;                          /* time would stand still */
            return -1;
        }
    }
    for (int tries = 0;; tries++) {
        if (!isfinite(hh) || tries >= MAX_REJECTS) { /* e.g. an infinite step with no break point ahead */
            *h = hh;
            return -1;
        }
        *hitMax = 0;
        double proposed = hh;
        if (hh >= hmax) {
            hh = hmax;
            *hitMax = 1;
        }
        rk_step_errors(method, f, ctx, n, t, y, f0, hh, y1, f1, cont, st, err, err3);
        double en = method == RK_DOP853 ? dop853_error_norm(nErr, scale, y, y1, err, err3, rtol, atol)
                    : scale             ? scaled_error_norm(nErr, scale, y, y1, err, rtol, atol)
                                        : dopri5_error_norm(nErr, y, y1, err, rtol, atol);
        if (en <= 1.0) {
            double fac = en > 0 ? 0.9 * pow(en, expo) : 5.0;
            *hNext = hh * fmin(5.0, fmax(0.2, fac));
            /* a sliver up to a break point (a communication point rounding a hair short of a record's sample) says
             * nothing of the next step: that would start below the resolution of t and stand still */
            if (*hitMax && hh < hmin) *hNext = proposed;
            *h = hh;
            return 0;
        }
        if (!isfinite(en)) en = 1e10;
        hh *= fmax(0.2, 0.9 * pow(en, expo));
        (*rejected)++;
        if (hh < 16.0 * DBL_EPSILON * fmax(1.0, fabs(t))) {
            *h = hh;
            return -1;
        }
    }
}

static double weighted(int n, const double *w, const double *y) {
    double s = 0.0;
    for (int i = 0; i < n; i++) s += w[i] * y[i];
    return s;
}

double refine_step(int method, RhsFn f, const void *ctx, int n, double t, const double *y,
                   const double *f0, double h, double hMax, const double *w,
                   double target, double *y1, double *f1, Dense *cont, Dop853Stages *st) {
    rk_step(method, f, ctx, n, t, y, f0, h, y1, f1, cont, st);
    return refine_step_from(method, f, ctx, n, t, y, f0, h, hMax, w, target, y1, f1, cont, st);
}

double refine_step_from(int method, RhsFn f, const void *ctx, int n, double t, const double *y, const double *f0,
                        double h, double hMax, const double *w, double target, double *y1, double *f1, Dense *cont,
                        Dop853Stages *st) {
    for (int it = 0; it < 8; it++) {
        double g = weighted(n, w, y1) - target, dg = weighted(n, w, f1);
        if (g == 0.0 || dg == 0.0 || !isfinite(dg)) break;
        double dh = -g / dg;
        if (fabs(dh) <= 4.0 * DBL_EPSILON * (fabs(t) + fabs(h))) break;
        double hn = h + dh;
        if (hn > hMax) hn = hMax;
        if (hn <= 0.0) hn = 0.5 * h;
        if (hn == h) break;
        h = hn;
        rk_step(method, f, ctx, n, t, y, f0, h, y1, f1, cont, st);
    }
    return h;
}

double first_negative(double (*f)(void *ctx, double x), void *ctx, double a, double fa, double b, double fb,
                      double epsFactor, double offset, double floor, int maxIter) {
    int side = 0;
    for (int it = 0; it < maxIter && b - a > epsFactor * DBL_EPSILON * fmax(floor, fabs(offset + b)); it++) {
        double x = (fa - fb > 0 && it % 4 != 3) ? b - fb * (b - a) / (fb - fa) : 0.5 * (a + b);
        if (!(x > a && x < b)) x = 0.5 * (a + b);
        double fx = f(ctx, x);
        if (fx < 0) {
            b = x, fb = fx;
            if (side == -1) fa *= 0.5;
            side = -1;
        } else {
            a = x, fa = fx;
            if (side == 1) fb *= 0.5;
            side = 1;
        }
    }
    return b;
}

double first_negative_costly(double (*f)(void *ctx, double x), void *ctx, double a, double fa, double b, double fb,
                             double epsFactor, double offset, double floor, int maxIter) {
    int side = 0;
    for (int it = 0; it < maxIter; it++) {
        double tol = epsFactor * DBL_EPSILON * fmax(floor, fabs(offset + b));
        if (!(b - a > tol)) break;
        double x = fa - fb > 0 ? b - fb * (b - a) / (fb - fa) : 0.5 * (a + b);
        if (x != x) x = 0.5 * (a + b);
        /* at least this far inside the bracket: an estimate on or past an end (rounding, or fa exactly 0,
         * where the root is a itself) moves just inside it, so the next evaluation closes the bracket */
        double step = fmin(0.5 * tol, 0.25 * (b - a));
        if (x - a < step) x = a + step;
        else if (b - x < step) x = b - step;
        double fx = f(ctx, x);
        if (fx < 0) {
            if (side == -1) {
                double m = 1.0 - fx / fb;
                fa *= m > 0 ? m : 0.5;
            }
            b = x, fb = fx;
            side = -1;
        } else {
            if (side == 1) {
                double m = 1.0 - fx / fa;
                fb *= m > 0 ? m : 0.5;
            }
            a = x, fa = fx;
            side = 1;
        }
    }
    return b;
}

double first_negative_sampled(double (*g)(void *ctx, double s), void *ctx, int samples) {
    double lo = 0.0;
    for (int k = 1; k <= samples; k++) {
        double hi = (double)k / samples;
        if (g(ctx, hi) < 0) {
            for (int it = 0; it < 60 && hi - lo > 4.0 * DBL_EPSILON; it++) {
                double mid = 0.5 * (lo + hi);
                if (g(ctx, mid) < 0) hi = mid;
                else lo = mid;
            }
            return hi;
        }
        lo = hi;
    }
    return 2.0;
}

int may_have_root(const double *c, int deg) {
    double lo = c[0], hi = c[0];
    for (int i = 1; i <= deg; i++) {
        if (c[i] < 0) lo += c[i];
        else hi += c[i];
    }
    return lo <= 0.0 && hi >= 0.0;
}

double first_crossing(const double *c, int deg, int slope) {
    double roots[DENSE_ROWS], d[DENSE_ROWS];
    if (!may_have_root(c, deg)) return 2.0;
    int nr = poly_roots(c, deg, 0.0, 1.0, roots);
    for (int i = 1; i <= deg; i++) d[i - 1] = i * c[i];
    for (int j = 0; j < nr; j++) {
        if (roots[j] <= 0.0) continue;
        double dv = poly_eval(d, deg - 1, roots[j]);
        if ((slope < 0 && dv < 0) || (slope > 0 && dv > 0)) return roots[j];
    }
    return 2.0;
}

/* The rigid models' uplift indicator: positive once the ground tips the body over either corner. */
static double uplift_indicator(const Model *M, double t, int piece) {
    return fmax(model_uplift_indicator_piece(M, t, 1, piece), model_uplift_indicator_piece(M, t, -1, piece));
}

double find_exit(const Model *M, double t, double tc, RestExitFn ind) {
    double a = t;
    int piece = model_piece(M, a);
    for (int first = 1, still = 0;; first = 0) {
        /* (still: a quiet span ended at a, certified to leave the indicator negative there too) */
        if (!still && ind(M, a, piece) > 0) return a;
        double quiet;
        if (ground_quiet(M, a, piece, M->d.upliftSlope, &quiet)) { /* a floor's span that cannot lift the blocks */
            if (quiet >= tc) return INFINITY;
            piece = next_piece(M, piece, quiet);
            a = quiet;
            still = 1;
            continue;
        }
        still = 0;
        double b = next_cell_edge(M, a, piece);
        /* no waveform left: the indicator stays put, or moves with a sloped input, linearly up to tc */
        if (!isfinite(b) && model_inputs_on(M) && tc > a) b = tc;
        if (!isfinite(b)) return INFINITY;
        if (!(b > a)) return NAN;
        /* Bisect on the whole cell (where the indicator is still <= 0 at its start), not from a:
         * the root then does not depend on where the previous call stopped, i.e. on the
         * communication points. */
        if (ind(M, b, piece) > 0) {
            double c0 = first ? cell_start(M, a, piece) : a;
            double lo = (c0 < a && ind(M, c0, piece) <= 0) ? c0 : a, hi = b;
            for (int it = 0; it < 200 && hi - lo > 2.0 * DBL_EPSILON * fabs(hi); it++) {
                double mid = 0.5 * (lo + hi);
                if (ind(M, mid, piece) > 0) hi = mid;
                else lo = mid;
            }
            return hi > tc ? INFINITY : hi;
        }
        if (b >= tc) return INFINITY;
        piece = next_piece(M, piece, b);
        a = b;
    }
}

int find_uplift(const Model *M, double t, double tc, double *tu) {
    double x = find_exit(M, t, tc, uplift_indicator);
    if (isnan(x)) return UPLIFT_STUCK;
    if (!(x <= tc)) return 0;
    *tu = x;
    /* the side whose indicator is positive at the crossing */
    return model_uplift_indicator_piece(M, x, 1, model_piece(M, x)) > 0 ? 1 : -1;
}

void commit_peaks(Model *M, const Logger *log) {
    State *S = &M->s;
    for (int i = 0; i < S->nStepPeaks; i++) {
        S->peaks++;
        S->lastPeakTime = S->stepPeakTime[i];
        S->lastPeakTheta = S->stepPeakTheta[i];
        if (fabs(S->lastPeakTheta) > S->maxAbsTheta) S->maxAbsTheta = fabs(S->lastPeakTheta);
        say(log, LOG_EVENTS, "peak t=%.17g theta=%.17g", S->lastPeakTime, S->lastPeakTheta);
    }
    S->nStepPeaks = 0;
    if (fabs(S->y[0]) > S->maxAbsTheta) S->maxAbsTheta = fabs(S->y[0]);
}

void peak_outputs(const State *S, double tc, double theta, Variables *v) {
    int peaks = S->peaks;
    double lastT = S->lastPeakTime, lastTh = S->lastPeakTheta, mx = S->maxAbsTheta;
    for (int i = 0; i < S->nStepPeaks; i++)
        if (S->stepPeakTime[i] <= tc) {
            peaks++;
            lastT = S->stepPeakTime[i];
            lastTh = S->stepPeakTheta[i];
            if (fabs(lastTh) > mx) mx = fabs(lastTh);
        }
    if (fabs(theta) > mx) mx = fabs(theta);
    v->peaks = peaks;
    v->lastPeakTime = lastT;
    v->lastPeakTheta = lastTh;
    v->maxAbsTheta = mx;
}

void keep_peaks_until(State *S, double tc) {
    int k = 0;
    for (int i = 0; i < S->nStepPeaks; i++)
        if (S->stepPeakTime[i] <= tc) {
            S->stepPeakTime[k] = S->stepPeakTime[i];
            S->stepPeakTheta[k] = S->stepPeakTheta[i];
            k++;
        }
    S->nStepPeaks = k;
}

/* Does the event just applied at S->t end the advance? */
static int stops_here(const Model *M, EventStop *stop) {
    const State *S = &M->s;
    if (!stop || !(S->t > stop->after)) return 0;
    if (!(stop->any || (stop->overturn && S->mode == MODE_OVERTURNED))) return 0;
    stop->stopped = 1;
    stop->time = S->t;
    return 1;
}

/* An event is applied, with samples just before it (joined to the last step)
 * and after it. */
static int apply_sampled(Model *M, const SolverOps *ops, const Logger *log) {
    contact_sample_state(M, ops->reactions, log, 1);
    if (ops->apply_event(M, log)) return -1;
    contact_sample_state(M, ops->reactions, log, 0);
    return 0;
}

int advance_to(Model *M, double tc, const Logger *log, const SolverOps *ops, EventStop *stop) {
    State *S = &M->s;
    double last = S->t;
    for (int stalls = 0;; stalls++) {
        if (S->t > last) {
            last = S->t;
            stalls = 0;
        } else if (stalls > MAX_STALLS) {
            say(log, LOG_ERROR, "time does not advance from t=%.17g (pattern %d): %d passes without progress",
                S->t, (int)S->mode, MAX_STALLS);
            return -1;
        }
        if (S->pending != EVENT_NONE && S->t <= tc) {
            if (apply_sampled(M, ops, log)) return -1;
            if (stops_here(M, stop)) return 0;
        }
        if (S->t >= tc) return 0;
        if (ops->before_step) ops->before_step(M, log);
        contact_sample_state(M, ops->reactions, log, 1);
        if (S->mode == MODE_OVERTURNED) {
            if (ops->ended) {
                if (ops->ended(M, tc, log)) return -1;
                continue;
            }
            S->t = tc;
            S->denseValid = 0;
        } else if (S->mode == MODE_REST) {
            double tu = 0.0;
            int side;
            if (ops->rest_exit) { /* the model's own indicator: side 1 once it turns positive */
                tu = find_exit(M, S->t, tc, ops->rest_exit);
                side = isnan(tu) ? UPLIFT_STUCK : tu <= tc ? 1 : 0;
            } else {
                side = find_uplift(M, S->t, tc, &tu);
            }
            S->denseValid = 0;
            if (side == UPLIFT_STUCK) {
                say(log, LOG_ERROR, "at rest at t=%.17g: the time is too large to resolve the excitation", S->t);
                return -1;
            }
            contact_sample_rest(M, side ? tu : tc, log);
            if (side) {
                ops->start_moving(M, tu, side, log);
                if (stops_here(M, stop)) return 0;
            } else {
                S->t = tc;
            }
        } else if (ops->take_step(M, log)) {
            return -1;
        }
    }
}
