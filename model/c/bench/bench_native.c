/* Native cost of RockingBlock simulations: dlopen the FMU binary, run each
 * case `repeats` times through the FMI 2.0 API (instantiate, set parameters,
 * initialise, one doStep over the whole horizon, read outputs, free) and print
 * one line per case: name, microseconds per simulation, impacts, outcome.
 *
 * usage: bench_native LIBRARY GUID REPEATS [CASE]   (CASE: run only that row, from 0)
 *        bench_native LIBRARY GUID REPEATS custom STOP VR=VALUE ...
 * The second form times one scene given by value references (a VR written
 * iVR=VALUE is an Integer, sVR=VALUE a String) up to STOP seconds and prints
 * microseconds per simulation and the number of impacts.
 */
#define _POSIX_C_SOURCE 200809L
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "fmi2Functions.h"

typedef struct {
    const char *name;
    double b, h, theta0, amplitude, frequency, relTol, stop, restRatio;
    int kind, law;
    /* two blocks (nBlocks = 2): lower block mass, upper block, table displacement */
    int nBlocks;
    double m, b2, h2, m2, theta02, displacement;
    /* rocking-sliding (contact.model = 1) with friction coefficient mu; 0: rigid rocking */
    int sliding;
    double mu;
} Case;

static void *xcalloc(size_t n, size_t s) { return calloc(n, s); }
static void quiet(fmi2ComponentEnvironment e, fmi2String n, fmi2Status s, fmi2String c, fmi2String m, ...) {
    (void)e, (void)n, (void)c;
    if (s >= fmi2Error) fprintf(stderr, "FMU error: %s\n", m);
}

static double now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

#define LOAD(name) name##TYPE *name = (name##TYPE *)dlsym(lib, #name); if (!name) { fprintf(stderr, "missing %s\n", #name); return 1; }

/* The "custom" form: one scene from the command line. */
static int run_custom(void *lib, const char *guid, int repeats, int argc, char **argv) {
    LOAD(fmi2Instantiate) LOAD(fmi2SetupExperiment) LOAD(fmi2SetReal) LOAD(fmi2SetInteger)
    LOAD(fmi2SetString) LOAD(fmi2EnterInitializationMode) LOAD(fmi2ExitInitializationMode) LOAD(fmi2DoStep)
    LOAD(fmi2GetInteger) LOAD(fmi2FreeInstance)
    fmi2CallbackFunctions cb = {quiet, xcalloc, free, NULL, NULL};
    double stop = atof(argv[0]);
    const fmi2ValueReference vrImp = 43;
    int impacts = 0;
    double t0 = now();
    for (int r = 0; r < repeats; r++) {
        fmi2Component m = fmi2Instantiate("bench", fmi2CoSimulation, guid, "", &cb, 0, 0);
        if (!m) return 1;
        for (int i = 1; i < argc; i++) {
            const char *a = argv[i];
            int integer = a[0] == 'i', string = a[0] == 's';
            char *eq = strchr(a, '=');
            if (!eq) return 2;
            fmi2ValueReference vr = (fmi2ValueReference)atoi(a + integer + string);
            if (string) {
                fmi2String value = eq + 1;
                if (fmi2SetString(m, &vr, 1, &value) != fmi2OK) return 1;
            } else if (integer) {
                int value = atoi(eq + 1);
                if (fmi2SetInteger(m, &vr, 1, &value) != fmi2OK) return 1;
            } else {
                double value = atof(eq + 1);
                if (fmi2SetReal(m, &vr, 1, &value) != fmi2OK) return 1;
            }
        }
        fmi2SetupExperiment(m, 0, 0, 0, 0, 0);
        if (fmi2EnterInitializationMode(m) != fmi2OK || fmi2ExitInitializationMode(m) != fmi2OK) return 1;
        if (fmi2DoStep(m, 0, stop, 1) != fmi2OK) return 1;
        fmi2GetInteger(m, &vrImp, 1, &impacts);
        fmi2FreeInstance(m);
    }
    printf("%.3f\t%d\n", (now() - t0) / repeats * 1e6, impacts);
    return 0;
}

int main(int argc, char **argv) {
    if (argc >= 6 && strcmp(argv[4], "custom") == 0) {
        void *lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
        if (!lib) {
            fprintf(stderr, "cannot load %s: %s\n", argv[1], dlerror());
            return 1;
        }
        int rc = run_custom(lib, argv[2], atoi(argv[3]), argc - 5, argv + 5);
        dlclose(lib);
        return rc;
    }
    if (argc != 4 && argc != 5) {
        fprintf(stderr, "usage: %s LIBRARY GUID REPEATS [CASE]\n", argv[0]);
        return 2;
    }
    void *lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        fprintf(stderr, "cannot load %s: %s\n", argv[1], dlerror());
        return 1;
    }
    LOAD(fmi2Instantiate) LOAD(fmi2SetupExperiment) LOAD(fmi2SetReal) LOAD(fmi2SetInteger)
    LOAD(fmi2EnterInitializationMode) LOAD(fmi2ExitInitializationMode) LOAD(fmi2DoStep)
    LOAD(fmi2GetInteger) LOAD(fmi2GetBoolean) LOAD(fmi2FreeInstance)
    int repeats = atoi(argv[3]);
    fmi2CallbackFunctions cb = {quiet, xcalloc, free, NULL, NULL};
    /* b, h, theta0, amplitude, frequency, relTol, stop, restRatio, kind, law
     * [, nBlocks, m, b2, h2, m2, theta02, displacement] */
#define ONE 1, 10.0, 0.1, 0.2, 5.0, 0.0, 0.0
#define FIG17 2, 1.3, 0.030, 0.050, 2.3, 0.0 /* Anagnostopoulos's Blocks 1 (lower) and 4 (upper) */
    Case cases[] = {
        {"sine pulse to rest, rtol 1e-10, restRatio 1e-6 (defaults)", 0.1, 0.3, 0, 5.0, 3.0, 1e-10, 5.0, 1e-6, 1, 0, ONE},
        {"sine pulse to rest, rtol 1e-6, restRatio 1e-6", 0.1, 0.3, 0, 5.0, 3.0, 1e-6, 5.0, 1e-6, 1, 0, ONE},
        {"sine pulse to rest, rtol 1e-10, restRatio 1e-3", 0.1, 0.3, 0, 5.0, 3.0, 1e-10, 5.0, 1e-3, 1, 0, ONE},
        {"sine pulse to rest, rtol 1e-6, restRatio 1e-3", 0.1, 0.3, 0, 5.0, 3.0, 1e-6, 5.0, 1e-3, 1, 0, ONE},
        {"sine pulse overturning, rtol 1e-10", 0.1, 0.3, 0, 6.0, 2.0, 1e-10, 5.0, 1e-6, 1, 0, ONE},
        {"free rocking 10 impacts, rtol 1e-10", 0.1, 0.3, 0.2, 0, 1, 1e-10, 0, 1e-6, 0, 2, ONE},
        {"free rocking 10 impacts, rtol 1e-6", 0.1, 0.3, 0.2, 0, 1, 1e-6, 0, 1e-6, 0, 2, ONE},
        {"two blocks, free from opposite tilts, rtol 1e-10", 0.1, 0.3, 0.05, 0, 1, 1e-10, 3.0, 1e-6, 0, 0,
         2, 10.0, 0.1, 0.2, 5.0, -0.08, 0.0},
        {"two blocks, Anagnostopoulos Fig. 17A (7 Hz / 3 mm), 10 s, rtol 1e-10", 0.0145, 0.060, 0, 0, 7.0, 1e-10, 10.0, 1e-6, 3, 2, FIG17, 0.003},
        {"two blocks, Anagnostopoulos Fig. 17A (7 Hz / 3 mm), 10 s, rtol 1e-6", 0.0145, 0.060, 0, 0, 7.0, 1e-6, 10.0, 1e-6, 3, 2, FIG17, 0.003},
        {"two blocks, Anagnostopoulos Fig. 17B (5.5 Hz / 3 mm), 10 s, rtol 1e-10", 0.0145, 0.060, 0, 0, 5.5, 1e-10, 10.0, 1e-6, 3, 2, FIG17, 0.003},
        /* rocking-sliding: rows 0, 4 and 5 again with mu = 100 (nothing slides in 0 and 5; an overturning block's
         * pivot slides just before it would lift off), then blocks that slide */
        {"rocking-sliding, mu 100: sine pulse to rest, rtol 1e-10", 0.1, 0.3, 0, 5.0, 3.0, 1e-10, 5.0, 1e-6, 1, 0, ONE, 1, 100.0},
        {"rocking-sliding, mu 100: sine pulse overturning (slides as it lifts off), rtol 1e-10", 0.1, 0.3, 0, 6.0, 2.0, 1e-10, 5.0, 1e-6, 1, 0, ONE, 1, 100.0},
        {"rocking-sliding, mu 100: free rocking 10 impacts, rtol 1e-10", 0.1, 0.3, 0.2, 0, 1, 1e-10, 0, 1e-6, 0, 2, ONE, 1, 100.0},
        {"rocking-sliding, mu 0.3: squat block slides (12 m/s2, 2 Hz), rtol 1e-10", 0.3, 0.36, 0, 12.0, 2.0, 1e-10, 5.0, 1e-6, 1, 0, ONE, 1, 0.3},
        {"rocking-sliding, mu 0.35: rocks and slide-rocks (6 m/s2, 1.5 Hz), rtol 1e-10", 0.15, 0.45, 0, 6.0, 1.5, 1e-10, 5.0, 1e-6, 1, 0, ONE, 1, 0.35},
    };
#undef ONE
#undef FIG17
    const fmi2ValueReference vrReal[] = {2, 3, 5, 13, 14, 19, 21, 4, 60, 61, 62, 63, 18, 15};
    const fmi2ValueReference vrInt[] = {12, 8, 1};
    const fmi2ValueReference vrImp = 43, vrOver = 44, vrRest = 45;
    int only = argc == 5 ? atoi(argv[4]) : -1;
    for (size_t c = 0; c < sizeof(cases) / sizeof(cases[0]); c++) {
        if (only >= 0 && (size_t)only != c) continue;
        Case k = cases[c];
        double stop = k.stop; /* one-block free-rocking rows (law 2): until the 10th impact */
        int impacts = 0, over = 0, rest = 0;
        double t0 = now();
        for (int r = 0; r < repeats; r++) {
            fmi2Component m = fmi2Instantiate("bench", fmi2CoSimulation, argv[2], "", &cb, 0, 0);
            if (!m) return 1;
            double real[] = {k.b, k.h, k.theta0, k.amplitude, k.frequency, k.relTol, k.restRatio,
                             k.m, k.b2, k.h2, k.m2, k.theta02, k.displacement,
                             k.kind == 3 ? 0.0 : 1.0 /* cycles: harmonic endless */};
            int ints[] = {k.kind, k.law, k.nBlocks};
            fmi2SetReal(m, vrReal, 14, real);
            fmi2SetInteger(m, vrInt, 3, ints);
            if (k.sliding) {
                const fmi2ValueReference vrModel = 106, vrMu = 90;
                int model = 1;
                if (fmi2SetInteger(m, &vrModel, 1, &model) != fmi2OK || fmi2SetReal(m, &vrMu, 1, &k.mu) != fmi2OK) {
                    fmi2FreeInstance(m);
                    impacts = -1;
                    break; /* an FMU from before rocking-sliding: no such row */
                }
            }
            fmi2SetupExperiment(m, 0, 0, 0, 0, 0);
            fmi2EnterInitializationMode(m);
            fmi2ExitInitializationMode(m);
            if (k.law == 2 && k.nBlocks == 1) {
                /* advance in 10 ms steps until the 10th impact (step-independent results) */
                double t = 0;
                impacts = 0;
                while (impacts < 10 && t < 20) {
                    fmi2DoStep(m, t, 0.01, 1);
                    t += 0.01;
                    fmi2GetInteger(m, &vrImp, 1, &impacts);
                }
                stop = t;
            } else if (fmi2DoStep(m, 0, stop, 1) != fmi2OK) return 1;
            fmi2GetInteger(m, &vrImp, 1, &impacts);
            fmi2GetBoolean(m, &vrOver, 1, &over);
            fmi2GetBoolean(m, &vrRest, 1, &rest);
            fmi2FreeInstance(m);
        }
        if (impacts < 0) continue;
        double us = (now() - t0) / repeats * 1e6;
        printf("%s\t%.2f\t%d\t%s\t%.2f\n", k.name, us, impacts,
               over ? "overturned" : rest ? "at rest" : "rocking", stop);
    }
    dlclose(lib);
    return 0;
}
