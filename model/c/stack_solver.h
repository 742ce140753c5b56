/* Event-driven time stepping of two stacked blocks (nBlocks = 2).
 *
 * Same scheme as the one-block solver (solver.h): adaptive Dormand-Prince
 * 5(4) steps, events located on the dense output and refined to the
 * integrator's accuracy, the integrator running ahead of the communication
 * point. The events are the impacts (block 1 on the ground, block 2 on
 * block 1), overturning of either block, and the opening of a closed
 * contact; each changes the motion pattern (stack.h). The rules are in
 * docs/two_blocks.md, "Patterns and their changes".
 */
#ifndef ROCKING_STACK_SOLVER_H
#define ROCKING_STACK_SOLVER_H

#include "model.h"

/* Initial pattern and pivots from the initial conditions (after the common
 * part of model_initialize). */
void stack_initialize(Model *M);

int stack_advance(Model *M, double tc, const Logger *log);
void stack_outputs(Model *M, double tc);
void stack_rollback(Model *M, double tc);

#endif
