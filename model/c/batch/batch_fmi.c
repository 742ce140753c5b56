/* Many grid points through one FMU instance, in C: the sweep workers' batch loop.
 *
 * A tiny FMI 2.0 Co-Simulation master. It loads the FMU's shared library with dlopen,
 * instantiates it once and, for each point of a batch, resets the instance, sets the
 * point's parameters, initialises, takes one fmi2DoStep to the point's stop time and reads
 * its outputs, with no Python in between. The FMI API is the only way in: this file knows
 * nothing of the model, only value references and values handed to it by
 * runners/engine/batch.py (through ctypes), and it runs any FMU of this project, old or new.
 *
 * Every array is row-major, one row per point. A point's failure (a parameter the FMU
 * refuses, a failed step) is reported in status[] with the FMU's last error message, and
 * the batch goes on with the next point. A step that ends with fmi2Discard because the FMU
 * terminated the run (solver.stopAtOverturn) counts as done, as in runners/engine/fmu.py.
 *
 * Build: cc -O2 -shared -fPIC -I FMI2_HEADERS batch_fmi.c -o rocking_batch.so -ldl
 */
#define _POSIX_C_SOURCE 200809L
#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "fmi2Functions.h"

#define BATCH_MESSAGE 512 /* bytes kept of a point's last error message */

typedef struct {
    void *lib;
    fmi2Component c;
    fmi2CallbackFunctions cb;
    char message[BATCH_MESSAGE]; /* the last error the FMU logged */
    fmi2InstantiateTYPE *instantiate;
    fmi2FreeInstanceTYPE *freeInstance;
    fmi2ResetTYPE *reset;
    fmi2SetupExperimentTYPE *setupExperiment;
    fmi2EnterInitializationModeTYPE *enterInit;
    fmi2ExitInitializationModeTYPE *exitInit;
    fmi2SetRealTYPE *setReal;
    fmi2SetIntegerTYPE *setInteger;
    fmi2SetBooleanTYPE *setBoolean;
    fmi2SetStringTYPE *setString;
    fmi2GetRealTYPE *getReal;
    fmi2GetIntegerTYPE *getInteger;
    fmi2GetBooleanTYPE *getBoolean;
    fmi2GetBooleanStatusTYPE *getBooleanStatus;
    fmi2DoStepTYPE *doStep;
} Batch;

/* The FMU's logger: keep the last message of status fmi2Error or worse. */
static void batch_log(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                      fmi2String message, ...) {
    (void)name, (void)category;
    Batch *b = (Batch *)env;
    if (status < fmi2Error || !b || !message) return;
    va_list ap;
    va_start(ap, message);
    vsnprintf(b->message, sizeof b->message, message, ap);
    va_end(ap);
}

static void copy_text(char *dst, int len, const char *src) {
    if (dst && len > 0) snprintf(dst, (size_t)len, "%s", src);
}

void batch_close(Batch *b);

/* Load `library`, instantiate it (Co-Simulation, logging off) and return the batch, or NULL
 * with the reason in err. */
Batch *batch_open(const char *library, const char *guid, const char *resourceUri, char *err, int errLen) {
    Batch *b = (Batch *)calloc(1, sizeof *b);
    if (!b) {
        copy_text(err, errLen, "out of memory");
        return NULL;
    }
    b->lib = dlopen(library, RTLD_NOW | RTLD_LOCAL);
    if (!b->lib) {
        copy_text(err, errLen, dlerror());
        free(b);
        return NULL;
    }
#define FIND(field, symbol)                                                                                          \
    if (!(b->field = (symbol##TYPE *)dlsym(b->lib, #symbol))) {                                                     \
        copy_text(err, errLen, "the FMU's library lacks " #symbol);                                                 \
        batch_close(b);                                                                                              \
        return NULL;                                                                                                 \
    }
    FIND(instantiate, fmi2Instantiate)
    FIND(freeInstance, fmi2FreeInstance)
    FIND(reset, fmi2Reset)
    FIND(setupExperiment, fmi2SetupExperiment)
    FIND(enterInit, fmi2EnterInitializationMode)
    FIND(exitInit, fmi2ExitInitializationMode)
    FIND(setReal, fmi2SetReal)
    FIND(setInteger, fmi2SetInteger)
    FIND(setBoolean, fmi2SetBoolean)
    FIND(setString, fmi2SetString)
    FIND(getReal, fmi2GetReal)
    FIND(getInteger, fmi2GetInteger)
    FIND(getBoolean, fmi2GetBoolean)
    FIND(getBooleanStatus, fmi2GetBooleanStatus)
    FIND(doStep, fmi2DoStep)
#undef FIND
    b->cb.logger = batch_log;
    b->cb.allocateMemory = calloc;
    b->cb.freeMemory = free;
    b->cb.componentEnvironment = b;
    b->c = b->instantiate("batch", fmi2CoSimulation, guid, resourceUri, &b->cb, fmi2False, fmi2False);
    if (!b->c) {
        copy_text(err, errLen, b->message[0] ? b->message : "fmi2Instantiate failed");
        batch_close(b);
        return NULL;
    }
    return b;
}

void batch_close(Batch *b) {
    if (!b) return;
    if (b->c) b->freeInstance(b->c);
    if (b->lib) dlclose(b->lib);
    free(b);
}

static double now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

/* One point: 0 on success, else 1 with the reason in b->message. */
static int run_point(Batch *b, double stop, int nr, const unsigned *rvr, const double *rval, int ni,
                     const unsigned *ivr, const int *ival, int nb, const unsigned *bvr, const int *bval, int ns,
                     const unsigned *svr, const char *const *sval, int nor, const unsigned *orvr, double *oreal,
                     int noi, const unsigned *oivr, int *oint, int nob, const unsigned *obvr, int *obool) {
    fmi2Component c = b->c;
    b->message[0] = '\0';
    if (b->reset(c) > fmi2Warning) return 1;
    if (b->setupExperiment(c, fmi2False, 0.0, 0.0, fmi2True, stop) > fmi2Warning) return 1;
    if (nr && b->setReal(c, rvr, (size_t)nr, rval) > fmi2Warning) return 1;
    if (ni && b->setInteger(c, ivr, (size_t)ni, ival) > fmi2Warning) return 1;
    if (nb && b->setBoolean(c, bvr, (size_t)nb, bval) > fmi2Warning) return 1;
    if (ns && b->setString(c, svr, (size_t)ns, sval) > fmi2Warning) return 1;
    if (b->enterInit(c) > fmi2Warning || b->exitInit(c) > fmi2Warning) return 1;
    fmi2Status s = b->doStep(c, 0.0, stop, fmi2True);
    if (s == fmi2Discard) {
        fmi2Boolean terminated = fmi2False;
        if (b->getBooleanStatus(c, fmi2Terminated, &terminated) != fmi2OK || !terminated) return 1;
    } else if (s > fmi2Warning) {
        return 1;
    }
    if (nor && b->getReal(c, orvr, (size_t)nor, oreal) > fmi2Warning) return 1;
    if (noi && b->getInteger(c, oivr, (size_t)noi, oint) > fmi2Warning) return 1;
    if (nob && b->getBoolean(c, obvr, (size_t)nob, obool) > fmi2Warning) return 1;
    return 0;
}

/* Run n points. Inputs per point: stop[n] (s), Reals rval[n][nr], Integers ival[n][ni],
 * Booleans bval[n][nb] (0 or 1), Strings sval[n][ns]; outputs per point: oreal[n][nor],
 * oint[n][noi], obool[n][nob], seconds[n] (wall time of the point), status[n] (0 done, 1
 * failed) and messages[n][msgLen] (the reason of a failed point; a done point's row is not
 * written). Returns the number
 * of failed points. */
int batch_run(Batch *b, int n, const double *stop, int nr, const unsigned *rvr, const double *rval, int ni,
              const unsigned *ivr, const int *ival, int nb, const unsigned *bvr, const int *bval, int ns,
              const unsigned *svr, const char *const *sval, int nor, const unsigned *orvr, double *oreal, int noi,
              const unsigned *oivr, int *oint, int nob, const unsigned *obvr, int *obool, double *seconds,
              int *status, char *messages, int msgLen) {
    int failed = 0;
    for (int k = 0; k < n; k++) {
        double t0 = now();
        int bad = run_point(b, stop[k], nr, rvr, rval + (size_t)k * nr, ni, ivr, ival + (size_t)k * ni, nb, bvr,
                            bval + (size_t)k * nb, ns, svr, sval + (size_t)k * ns, nor, orvr,
                            oreal + (size_t)k * nor, noi, oivr, oint + (size_t)k * noi, nob, obvr,
                            obool + (size_t)k * nob);
        seconds[k] = now() - t0;
        status[k] = bad;
        failed += bad;
        if (bad && messages && msgLen > 0)
            copy_text(messages + (size_t)k * msgLen, msgLen, b->message[0] ? b->message : "error");
    }
    return failed;
}
