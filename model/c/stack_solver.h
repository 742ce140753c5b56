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

/* Pattern changes allowed at one instant before the solver gives up. */
#define MAX_QUICK_SWITCHES 16

/* Initial pattern and pivots from the initial conditions (after the common
 * part of model_initialize). */
void stack_initialize(Model *M);

int stack_advance(Model *M, double tc, const Logger *log, EventStop *stop);

void stack_outputs(Model *M, double tc);
/* After a step with dense output cont ending at y1: the largest |theta1|, |theta2| so far, and
 * those before the step (for outputs inside it). Both stack models. */
void stack_track_peaks(State *S, const Dense *cont, const double *y1);
/* The outputs both stack models take from the state as they are: counters, times, flags, pattern
 * and the ground's accelerations (ah, av) at the output time. */
void stack_counter_outputs(const Model *M, Variables *v, double ah, double av);
void stack_rollback(Model *M, double tc);

/* For checking a restored state (state_validate): the derivative at the state's
 * time and values, and the last step taken again from its start (tOld, the dense
 * output at s = 0) in the state's pattern: its end values, derivative there and
 * dense output. */
void stack_state_rhs(const Model *M, double f[NMAX]);
void stack_replay_step(const Model *M, double y1[NMAX], double f1[NMAX], Dense *cont);

#endif
