/* A minimal FMI 3.0 Co-Simulation importer, for tests/test_fmu_binaries.py: it runs the
 * FMI 3.0 FMU's Linux binary natively and its Windows binary under wine, so that the two
 * can be compared (fmi2_harness.c does the same for FMI 2.0). Portable C99:
 * LoadLibrary/GetProcAddress on Windows, dlopen/dlsym elsewhere.
 *
 *   fmi3_harness BINARY TOKEN RESOURCE_PATH STOP STEP OUTPUTS [SETTING...]
 *
 * OUTPUTS: comma-separated value references of the outputs to print, each prefixed r
 * (Float64) or i (Int32), e.g. r40,r41,i43. SETTING: r<vr>=<number> (Float64),
 * i<vr>=<integer> (Int32), e<vr>=<integer> (an Enumeration: fmi3SetInt64) or s<vr>=<text>,
 * set after instantiation. RESOURCE_PATH may be "" (none given). No event mode, no early
 * return: the experiment from 0 to STOP in steps of STEP (communication points i*STEP),
 * one line per communication point from 0: the time, then the outputs, reals with %.17g.
 * It exits with 1 when a call does not return fmi3OK (or the log had a warning or error). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifdef _WIN32
#include <windows.h>
#else
#include <dlfcn.h>
#endif

#include "fmi3FunctionTypes.h"

#define MAX_OUTPUTS 16

static int logged_problem = 0;

static void logger(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category, fmi3String message) {
    (void)env;
    if (status != fmi3OK) logged_problem = 1;
    fprintf(stderr, "[%s %d] %s\n", category ? category : "?", (int)status, message ? message : "");
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
        fprintf(stderr, "fmi3_harness: the binary does not export %s\n", name);
        exit(2);
    }
    return f;
}

#define BIND(name) memcpy(&name, &(void *){symbol(lib, #name)}, sizeof(name))
#define CALL(expr)                                                               \
    do {                                                                         \
        fmi3Status st_ = (expr);                                                 \
        if (st_ != fmi3OK) {                                                     \
            fprintf(stderr, "fmi3_harness: %s returned status %d\n", #expr, (int)st_); \
            return 1;                                                            \
        }                                                                        \
    } while (0)

int main(int argc, char **argv) {
    fmi3InstantiateCoSimulationTYPE *fmi3InstantiateCoSimulation;
    fmi3SetFloat64TYPE *fmi3SetFloat64;
    fmi3SetInt32TYPE *fmi3SetInt32;
    fmi3SetInt64TYPE *fmi3SetInt64;
    fmi3SetStringTYPE *fmi3SetString;
    fmi3EnterInitializationModeTYPE *fmi3EnterInitializationMode;
    fmi3ExitInitializationModeTYPE *fmi3ExitInitializationMode;
    fmi3DoStepTYPE *fmi3DoStep;
    fmi3GetFloat64TYPE *fmi3GetFloat64;
    fmi3GetInt32TYPE *fmi3GetInt32;
    fmi3TerminateTYPE *fmi3Terminate;
    fmi3FreeInstanceTYPE *fmi3FreeInstance;
    char kind[MAX_OUTPUTS];
    fmi3ValueReference vr[MAX_OUTPUTS];
    int nOut = 0;

    if (argc < 7) {
        fprintf(stderr, "usage: fmi3_harness BINARY TOKEN RESOURCE_PATH STOP STEP OUTPUTS [SETTING...]\n");
        return 2;
    }
    double stop = strtod(argv[4], NULL), step = strtod(argv[5], NULL);
    for (char *p = argv[6]; *p && nOut < MAX_OUTPUTS; nOut++) {
        kind[nOut] = *p++;
        vr[nOut] = (fmi3ValueReference)strtoul(p, &p, 10);
        if (*p == ',') p++;
    }
    void *lib = load(argv[1]);
    if (!lib) {
        fprintf(stderr, "fmi3_harness: cannot load %s\n", argv[1]);
        return 2;
    }
    BIND(fmi3InstantiateCoSimulation);
    BIND(fmi3SetFloat64);
    BIND(fmi3SetInt32);
    BIND(fmi3SetInt64);
    BIND(fmi3SetString);
    BIND(fmi3EnterInitializationMode);
    BIND(fmi3ExitInitializationMode);
    BIND(fmi3DoStep);
    BIND(fmi3GetFloat64);
    BIND(fmi3GetInt32);
    BIND(fmi3Terminate);
    BIND(fmi3FreeInstance);

    fmi3Instance c = fmi3InstantiateCoSimulation("harness", argv[2], argv[3][0] ? argv[3] : NULL, fmi3False, fmi3True,
                                                 fmi3False, fmi3False, NULL, 0, NULL, logger, NULL);
    if (!c) {
        fprintf(stderr, "fmi3_harness: fmi3InstantiateCoSimulation failed\n");
        return 1;
    }
    for (int i = 7; i < argc; i++) {
        char *eq = strchr(argv[i], '=');
        if (!eq) {
            fprintf(stderr, "fmi3_harness: a setting is r<vr>=, i<vr>=, e<vr>= or s<vr>=: %s\n", argv[i]);
            return 2;
        }
        fmi3ValueReference r = (fmi3ValueReference)strtoul(argv[i] + 1, NULL, 10);
        if (argv[i][0] == 'r') {
            fmi3Float64 v = strtod(eq + 1, NULL);
            CALL(fmi3SetFloat64(c, &r, 1, &v, 1));
        } else if (argv[i][0] == 'i') {
            fmi3Int32 v = (fmi3Int32)strtol(eq + 1, NULL, 10);
            CALL(fmi3SetInt32(c, &r, 1, &v, 1));
        } else if (argv[i][0] == 'e') {
            fmi3Int64 v = (fmi3Int64)strtoll(eq + 1, NULL, 10);
            CALL(fmi3SetInt64(c, &r, 1, &v, 1));
        } else {
            fmi3String v = eq + 1;
            CALL(fmi3SetString(c, &r, 1, &v, 1));
        }
    }
    CALL(fmi3EnterInitializationMode(c, fmi3False, 0.0, 0.0, fmi3True, stop));
    CALL(fmi3ExitInitializationMode(c));
    long n = (long)(stop / step + 0.5);
    for (long i = 0;; i++) {
        double t = (double)i * step;
        printf("%.17g", t);
        for (int k = 0; k < nOut; k++) {
            if (kind[k] == 'i') {
                fmi3Int32 v;
                CALL(fmi3GetInt32(c, &vr[k], 1, &v, 1));
                printf(" %d", (int)v);
            } else {
                fmi3Float64 v;
                CALL(fmi3GetFloat64(c, &vr[k], 1, &v, 1));
                printf(" %.17g", v);
            }
        }
        printf("\n");
        if (i == n) break;
        fmi3Boolean event, terminate, early;
        fmi3Float64 last;
        CALL(fmi3DoStep(c, t, (double)(i + 1) * step - t, fmi3True, &event, &terminate, &early, &last));
    }
    CALL(fmi3Terminate(c));
    fmi3FreeInstance(c);
    return logged_problem;
}
