/* Event-driven time stepping of the contact engine (engine.h): the rocking-sliding model with
 * flight (contact.model = 1). Same scheme as the rigid models' solvers: adaptive Dormand-Prince
 * 5(4) steps, events located with real steps and applied by the complementarity problems of
 * engine.h, the integrator running ahead of the communication point. Rules: docs/flight.md. */
#ifndef ROCKING_ENGINE_SOLVER_H
#define ROCKING_ENGINE_SOLVER_H

#include "model.h"

/* Nonzero where the engine runs the model (contact.model = 1, one block). */
int engine_on(const Model *M);

/* Set the state from the initial parameters (after model_initialize's common part). */
void engine_initialize(Model *M);
int engine_advance(Model *M, double tc, const Logger *log, EventStop *stop);
void engine_outputs(Model *M, double tc);
void engine_rollback(Model *M, double tc);

/* Checks of a restored state's engine fields: 0, or 1 with a one-line reason. */
int engine_check_state(const Model *M, char *msg, size_t n);

#endif
