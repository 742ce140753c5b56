/* Event-driven time stepping of the rocking block.
 *
 * solver_advance() integrates the model from its current time to tc with
 * the adaptive Dormand-Prince 5(4) integrator, locating impacts (theta = 0),
 * overturn (|theta| = pi/2) and peaks (omega = 0) on the dense output and
 * refining each to the integrator's own accuracy. The integrator keeps its
 * own step sequence and may end its last step after tc; values at tc come
 * from the dense output, so the result does not depend on how an importer
 * chooses its communication points.
 */
#ifndef ROCKING_SOLVER_H
#define ROCKING_SOLVER_H

#include "model.h"

/* Set the state from the initial parameters at time t0 (one or two blocks). */
void solver_initialize(Model *M, double t0);

/* Returns 0 on success, nonzero on failure (a message went to log). With
 * stop (may be NULL), ends early right after the first event it asks for
 * (an impact, uplift, overturn or pattern change; or an overturn only). */
int solver_advance(Model *M, double tc, const Logger *log, EventStop *stop);

/* A sample of the contact monitors at the current state of one block (Model
 * Exchange: at the importer's steps and events, where its event indicators
 * located a first sliding or lift-off). */
void solver_sample_contacts(Model *M, const Logger *log);

/* The ground's reaction (T, N) on one block in its current state, N. */
void solver_contact_now(const Model *M, double *T, double *N);

/* Write the output variables of M->v for time tc (<= integrator time). */
void solver_outputs(Model *M, double tc);

/* Bring the integrator back to tc (when an input changed there). */
/* Log the peaks up to tc that the outputs count but the integrator, which ran ahead of tc,
 * has not committed yet (at fmi2Terminate: no later step will). */
void solver_log_pending(const Model *M, double tc, const Logger *log);
void solver_rollback(Model *M, double tc);

/* What a restored state is for (state_validate). */
typedef enum {
    STATE_INERT = 0,   /* never stepped again: saved after a failed step or fmi2Terminate */
    STATE_INITIAL = 1, /* initialised, not yet stepped (initialization mode) */
    STATE_RUNNING = 2  /* between steps */
} StateUse;

/* Check the integrator and discrete state M->s of a restored FMU state, and its
 * outputs, against the parameters M->v and derived values M->d it comes with
 * (both checked already: model_validate, and M->d equal to what model_derive
 * gives; M->rec attached). t0 is the experiment's start time and tc the
 * communication point of the state (both finite, tc >= t0). An inert state has
 * its enumerations, flags and counts checked, which keeps every index the solver
 * takes from the state in range; the others must also hold finite numbers that
 * fit each other as a run leaves them: the last step taken again from its start
 * gives the same dense output and end values, the outputs are those of the state
 * at tc. Returns 0, or nonzero with a one-line reason in msg. */
int state_validate(const Model *M, double t0, double tc, StateUse use, char *msg, size_t n);

#endif
