/* Two-way coupling of a support with the contact engine (support.coupling = 1, docs/supports.md): the
 * support's floors are integrated with the blocks in one state vector, the blocks' horizontal force acts
 * on their floor, and impacts move the floor.
 *
 * The support (support.h's physical form): floors i = 0 .. ns-1 of mass m_i, displacements u_i relative to
 * the base (+x), M u'' + C u' + K u = -M 1 a_g + e_j F, C = a0 M + a1 K, F = -T the blocks' force on floor j
 * (T: the floor's horizontal force on body 0, EnForces.T[0]). In a contact set and at a state the engine's
 * accelerations and forces are affine in the floor's acceleration a_f = a_g + u_j'', T = T0 + Ta (a_f - a_g),
 * so floor j's row solves in closed form:
 *     u_j'' = (m_j r_j - T0) / (m_j + Ta),   r_i = -((C u')_i + (K u)_i) / m_i - a_g,
 * and u_i'' = r_i on the other floors (M is diagonal). At an impact the floor takes minus the blocks'
 * horizontal impulse: its velocity jumps by -P_T / m_j.
 *
 * Components (after the engine's EN_N(nb)): COUPLING_U(nb, i), COUPLING_V(nb, i) for each floor, then the
 * base's work on blocks plus support and the dampers' loss (J). Units SI. */
#ifndef ROCKING_COUPLING_H
#define ROCKING_COUPLING_H

#include "engine.h"

#define COUPLING_U(nb, i) (EN_N(nb) + 2 * (i))
#define COUPLING_V(nb, i) (EN_N(nb) + 2 * (i) + 1)
#define COUPLING_WORK(nb, ns) (EN_N(nb) + 2 * (ns))
#define COUPLING_DAMP(nb, ns) (EN_N(nb) + 2 * (ns) + 1)
#define COUPLING_N(ns) (2 * (ns) + 2)

/* The support is coupled two ways (its components are in the state). */
int coupling_on(const struct Model *M);
/* How many components it adds to the engine's (0 unless coupling_on). */
int coupling_size(const struct Model *M);
/* Each floor's acceleration relative to the base without the blocks' force, r (m/s2), at time t (s), the support's
 * state in y and the base's acceleration ag; the input support.force at t included. */
void coupling_free(const struct Model *M, double t, const double *y, double ag, double *r);
/* Floor j's acceleration relative to the base (m/s2) with the blocks' force T = T0 + Ta (a_f - a_g). */
double coupling_floor(const struct Model *M, const double *r, double T0, double Ta);
/* The support's derivatives (written at its components of dy) with floor j's acceleration uj (relative to
 * the base), the free accelerations r, the base's accelerations (ag, av) and the blocks' horizontal and
 * vertical momenta relative to the floor, px and py (kg m/s; the base's work's rate is
 * -ag (1^T M u' + px + mtot u_j') - av py). */
void coupling_rhs(const struct Model *M, const double *y, const double *r, double uj, double ag, double av, double px,
                  double py, double *dy);
/* Floor j's velocity relative to the base (m/s). */
double coupling_floor_velocity(const struct Model *M, const double *y);
/* The support's kinetic plus strain energy (J). */
double coupling_energy(const struct Model *M, const double *y);
/* Floor j's mass (kg). */
double coupling_floor_mass(const struct Model *M);
/* The blocks' horizontal momentum relative to the floor, sum m_k X_k' (kg m/s), and their total mass (kg). */
double coupling_momentum(const EnSystem *s, const double *y, double *mtot);
/* The blocks' kinetic plus potential energy in the base's frame (J): engine_energy with floor j's velocity. */
double coupling_block_energy(const struct Model *M, const double *y);
/* And with the support's (coupling_energy): what the two-way energy balance follows (J). */
double coupling_total_energy(const struct Model *M, const double *y);
/* The kinetic energy of blocks and support in the base's frame (J). */
double coupling_kinetic(const struct Model *M, const double *y);
/* The blocks, whose horizontal momentum relative to the floor was px (kg m/s, their mass mtot), stopped on their
 * floor by a plastic hit: the floor's velocity takes the momentum of both. */
void coupling_carry(const struct Model *M, double *y, double px, double mtot);

#endif
