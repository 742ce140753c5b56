/* A minimal FMI 2.0 Co-Simulation importer, for tests/test_fmu_binaries.py: it runs the
 * FMU's Linux binary natively and its Windows binary under wine, so that the two can be
 * compared. Portable C99: LoadLibrary/GetProcAddress on Windows, dlopen/dlsym elsewhere.
 *
 *   fmi2_harness BINARY GUID RESOURCES_URI STOP STEP OUTPUTS [SETTING...]
 *
 * OUTPUTS: comma-separated value references of the outputs to print, each prefixed r
 * (Real) or i (Integer), e.g. r40,r41,i43. SETTING: r<vr>=<number>, i<vr>=<integer> or
 * s<vr>=<text>, set after fmi2Instantiate. RESOURCES_URI may be "" (none given).
 * The harness sets up the experiment from 0 to STOP, initializes, steps to STOP in steps
 * of STEP (communication points i*STEP, as fmpy's simulate_fmu computes them) and prints
 * one line per communication point, from 0: the time, then the outputs, reals with %.17g.
 * It exits with 1 when a call does not return fmi2OK (or the log had a warning or error). */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifdef _WIN32
#include <windows.h>
#else
#include <dlfcn.h>
#endif

#include "fmi2FunctionTypes.h"

#define MAX_OUTPUTS 16

static int logged_problem = 0;

static void logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status, fmi2String category,
                   fmi2String message, ...) {
    va_list ap;
    (void)env;
    if (status != fmi2OK) logged_problem = 1;
    fprintf(stderr, "[%s %s %d] ", instance ? instance : "?", category ? category : "?", (int)status);
    va_start(ap, message);
    vfprintf(stderr, message, ap);
    va_end(ap);
    fputc('\n', stderr);
}

static void *load(const char *path) {
#ifdef _WIN32
    return (void *)LoadLibraryA(path);
#else
    return dlopen(path, RTLD_NOW | RTLD_LOCAL);
#endif
}

static void *symbol(void *lib, const char *name) {
    void *f;
#ifdef _WIN32
    FARPROC p = GetProcAddress((HMODULE)lib, name);
    memcpy(&f, &p, sizeof(f)); /* a function pointer as void *, without a cast ISO C forbids */
#else
    f = dlsym(lib, name);
#endif
    if (!f) {
        fprintf(stderr, "fmi2_harness: the binary does not export %s\n", name);
        exit(2);
    }
    return f;
}

#define BIND(name) memcpy(&name, &(void *){symbol(lib, #name)}, sizeof(name))
#define CALL(expr)                                                               \
    do {                                                                         \
        fmi2Status st_ = (expr);                                                 \
        if (st_ != fmi2OK) {                                                     \
            fprintf(stderr, "fmi2_harness: %s returned status %d\n", #expr, (int)st_); \
            return 1;                                                            \
        }                                                                        \
    } while (0)

int main(int argc, char **argv) {
    fmi2InstantiateTYPE *fmi2Instantiate;
    fmi2SetRealTYPE *fmi2SetReal;
    fmi2SetIntegerTYPE *fmi2SetInteger;
    fmi2SetStringTYPE *fmi2SetString;
    fmi2SetupExperimentTYPE *fmi2SetupExperiment;
    fmi2EnterInitializationModeTYPE *fmi2EnterInitializationMode;
    fmi2ExitInitializationModeTYPE *fmi2ExitInitializationMode;
    fmi2DoStepTYPE *fmi2DoStep;
    fmi2GetRealTYPE *fmi2GetReal;
    fmi2GetIntegerTYPE *fmi2GetInteger;
    fmi2TerminateTYPE *fmi2Terminate;
    fmi2FreeInstanceTYPE *fmi2FreeInstance;
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    char kind[MAX_OUTPUTS];
    fmi2ValueReference vr[MAX_OUTPUTS];
    int nOut = 0;

    if (argc < 7) {
        fprintf(stderr, "usage: fmi2_harness BINARY GUID RESOURCES_URI STOP STEP OUTPUTS [SETTING...]\n");
        return 2;
    }
    double stop = strtod(argv[4], NULL), step = strtod(argv[5], NULL);
    for (char *p = argv[6]; *p && nOut < MAX_OUTPUTS; nOut++) {
        kind[nOut] = *p++;
        vr[nOut] = (fmi2ValueReference)strtoul(p, &p, 10);
        if (*p == ',') p++;
    }
    void *lib = load(argv[1]);
    if (!lib) {
        fprintf(stderr, "fmi2_harness: cannot load %s\n", argv[1]);
        return 2;
    }
    BIND(fmi2Instantiate);
    BIND(fmi2SetReal);
    BIND(fmi2SetInteger);
    BIND(fmi2SetString);
    BIND(fmi2SetupExperiment);
    BIND(fmi2EnterInitializationMode);
    BIND(fmi2ExitInitializationMode);
    BIND(fmi2DoStep);
    BIND(fmi2GetReal);
    BIND(fmi2GetInteger);
    BIND(fmi2Terminate);
    BIND(fmi2FreeInstance);

    fmi2Component c = fmi2Instantiate("harness", fmi2CoSimulation, argv[2], argv[3][0] ? argv[3] : NULL, &cb,
                                      fmi2False, fmi2False);
    if (!c) {
        fprintf(stderr, "fmi2_harness: fmi2Instantiate failed\n");
        return 1;
    }
    for (int i = 7; i < argc; i++) {
        char *eq = strchr(argv[i], '=');
        if (!eq) {
            fprintf(stderr, "fmi2_harness: a setting is r<vr>=<value>, i<vr>=<value> or s<vr>=<text>: %s\n", argv[i]);
            return 2;
        }
        fmi2ValueReference r = (fmi2ValueReference)strtoul(argv[i] + 1, NULL, 10);
        if (argv[i][0] == 'r') {
            fmi2Real v = strtod(eq + 1, NULL);
            CALL(fmi2SetReal(c, &r, 1, &v));
        } else if (argv[i][0] == 'i') {
            fmi2Integer v = (fmi2Integer)strtol(eq + 1, NULL, 10);
            CALL(fmi2SetInteger(c, &r, 1, &v));
        } else {
            fmi2String v = eq + 1;
            CALL(fmi2SetString(c, &r, 1, &v));
        }
    }
    CALL(fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2True, stop));
    CALL(fmi2EnterInitializationMode(c));
    CALL(fmi2ExitInitializationMode(c));
    long n = (long)(stop / step + 0.5);
    for (long i = 0;; i++) {
        double t = (double)i * step;
        printf("%.17g", t);
        for (int k = 0; k < nOut; k++) {
            if (kind[k] == 'i') {
                fmi2Integer v;
                CALL(fmi2GetInteger(c, &vr[k], 1, &v));
                printf(" %d", (int)v);
            } else {
                fmi2Real v;
                CALL(fmi2GetReal(c, &vr[k], 1, &v));
                printf(" %.17g", v);
            }
        }
        printf("\n");
        if (i == n) break;
        CALL(fmi2DoStep(c, t, (double)(i + 1) * step - t, fmi2True));
    }
    CALL(fmi2Terminate(c));
    fmi2FreeInstance(c);
    return logged_problem;
}
