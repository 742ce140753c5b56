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

/* Returns 0 on success, nonzero on failure (a message went to log). */
int solver_advance(Model *M, double tc, const Logger *log);

/* Write the output variables of M->v for time tc (<= integrator time). */
void solver_outputs(Model *M, double tc);

/* Bring the integrator back to tc (when an input changed there). */
void solver_rollback(Model *M, double tc);

#endif
