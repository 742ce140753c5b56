/* Model Exchange interface of the rocking block: the importer's own solver
 * (CVode, Euler, ...) integrates the continuous states, and the model gives
 * derivatives, event indicators and the event update.
 *
 * Continuous states x = (theta, omega) of block 1 (rad, rad/s); one block
 * only (nBlocks = 1). Event indicators, each changing sign at its event:
 *   z0 = theta                     rocking: an impact (theta passes 0)
 *   z1 = pi/2 - |theta|            rocking: overturn
 *   z2 = (g + av) tan(alpha) - |ah| at rest: uplift
 *   z3 = omega                     rocking: a peak (counted, no state change)
 * An indicator whose event cannot happen in the current pattern is 1.
 * Excitation break points (a pulse's start and end, a record's samples) are
 * time events. The event update applies the same impact map
 * (model_impact: restitution and rest criterion) as the built-in solver.
 */
#ifndef ROCKING_ME_H
#define ROCKING_ME_H

#include <stddef.h>

#include "instance.h"

#define ME_STATES 2
#define ME_INDICATORS 6

typedef struct {
    int newDiscreteStatesNeeded;
    int terminate;
    int statesChanged;
    int nextTimeDefined;
    double nextTime;
} MeEventInfo;

/* Nonzero (after logging why) when the parameters are not for Model Exchange. */
int me_check(Instance *I);
/* Leave initialization: the discrete state at the start time (a block at rest that the
 * ground tips over already rocks). */
void me_start(Instance *I);
/* Entering continuous-time mode: a block at rest that inputs or the time set in event mode
 * made tip (or one rocking flat on its base that they hold down) changes its mode. */
void me_enter_continuous(Instance *I);
Status me_set_time(Instance *I, double t, const char *fn);
Status me_set_states(Instance *I, const double *x, size_t nx, const char *fn);
Status me_get_states(Instance *I, double *x, size_t nx, const char *fn);
Status me_get_nominals(Instance *I, double *x, size_t nx, const char *fn);
Status me_get_derivatives(Instance *I, double *dx, size_t nx, const char *fn);
Status me_get_event_indicators(Instance *I, double *z, size_t nz, const char *fn);
/* Event iteration: apply what happened at the current time; nonzero on failure. */
int me_event_update(Instance *I, MeEventInfo *info);
/* Would fmi2NewDiscreteStates change anything now (states set that do not fit the motion
 * pattern, an event passed)? */
int me_event_pending(Instance *I);
/* After an accepted step of the importer's solver: enterEventMode when an event is pending. */
int me_completed_step(Instance *I, int *enterEventMode);
/* Outputs at the current time and states. */
void me_update_outputs(Instance *I);

#endif
