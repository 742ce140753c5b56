/* The contact engine's cost against the number of bodies of a column of drums (each b = 0.25 m, h = 0.4 m, 500 kg,
 * mu = 0.8, standing on the one below), built with EN_MAX_BODIES = 8: one evaluation of the equations of motion of
 * the column rocking as one on the bottom drum's corner (every interface closed and sticking: the chain in reduced
 * coordinates, the step's work), and one choice of the contact set by the complementarity problem (Lemke) for the
 * column at rest under a ground acceleration above its uplift (the likely set fails; the problem has 4 unknowns per
 * drum).
 *
 * usage: bench_column N OP REPS   (OP: rhs or choose) prints: N, the operation, microseconds per call, the choice's
 * problem size. runners bench --columns runs it for N = 1 to 8, and under valgrind for instructions per call. */
#define _POSIX_C_SOURCE 200809L
#include "engine.c"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static double now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

int main(int argc, char **argv) {
    if (argc < 4) {
        fprintf(stderr, "usage: bench_column N rhs|choose REPS\n");
        return 2;
    }
    int N = atoi(argv[1]), choose = strcmp(argv[2], "choose") == 0;
    long reps = atol(argv[3]);
    if (N < 1 || N > EN_MAX_BODIES || reps < 0) return 2;
    EnSystem s;
    memset(&s, 0, sizeof(s));
    s.nb = N;
    s.g = 9.81;
    for (int k = 0; k < N; k++) {
        engine_body_rectangle(&s.body[k], 0.25, 0.4, 500.0);
        s.mu[k] = 0.8;
    }
    for (int k = N - 1; k >= 0; k--) s.weight[k] = s.body[k].m * s.g + (k + 1 < N ? s.weight[k + 1] : 0.0);
    EnMode mode;
    memset(&mode, 0, sizeof(mode));
    for (int k = 0; k < N; k++) mode.closed[k][0] = mode.closed[k][1] = 1;
    double y[NMAX] = {0}, xi0[EN_MAX_BODIES] = {0}, dy[NMAX], placed[NMAX];
    EnForces f;
    int touching[EN_MAX_BODIES][2], stuck[EN_MAX_BODIES], size = 0;
    double lift = s.g * 0.25 / (N * 0.4), sink = 0.0, t0;
    if (choose) {
        if (!engine_chain(&s, &mode, xi0, y, 0.0, 0.0, &f)) return 2; /* the column at rest, placed */
        for (int k = 0; k < N; k++) touching[k][0] = touching[k][1] = stuck[k] = 1;
        size = 4 * N;
        t0 = now();
        for (long r = 0; r < reps; r++) {
            EnMode out;
            if (engine_choose(&s, y, 1.01 * lift + 1e-9 * (double)(r & 7), 0.0, (const int(*)[2])touching, stuck, &out,
                              &f))
                return 3;
            sink += out.closed[0][0];
        }
    } else {
        mode.closed[0][0] = 0; /* on the bottom drum's right corner */
        for (int k = 0; k < N; k++) y[EN_TH(k)] = 0.05, y[EN_W(k)] = 0.3;
        t0 = now();
        for (long r = 0; r < reps; r++) {
            if (!engine_rhs(&s, &mode, xi0, y, 1.5 + 1e-9 * (double)(r & 7), 0.0, dy, &f, placed)) return 3;
            sink += dy[EN_W(0)];
        }
    }
    double us = reps ? 1e6 * (now() - t0) / (double)reps : 0.0;
    printf("%d %s %.4f %d %g\n", N, choose ? "choose" : "rhs", us, size, sink == 12345.678 ? 1.0 : 0.0);
    return 0;
}
