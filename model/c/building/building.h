/* ShearBuilding: a linear shear building of N storeys (1 <= N <= 10) under base acceleration
 * and horizontal floor forces. The model only: parameters, validation, natural frequencies,
 * Rayleigh damping, derivatives, the integration of a communication step, energy and outputs.
 * The FMI 2.0 layer (fmi2_building.c) owns the instance and calls these functions.
 *
 * Floor i (1..N) has the lumped mass m_i; the storey below it (between floor i-1 and floor i,
 * floor 0 being the base) the lateral stiffness k_i. u_i is floor i's displacement relative to
 * the base, positive towards +x (docs/conventions.md):
 *
 *     M u'' + C u' + K u = -M 1 a_g(t) + F(t)
 *
 * M = diag(m), K tridiagonal (K_ii = k_i + k_{i+1}, K_{i,i+1} = -k_{i+1}, k_{N+1} = 0),
 * C = a0 M + a1 K (Rayleigh) with the damping ratio zeta at modes 1 and 2:
 * a0 = 2 zeta w1 w2 / (w1 + w2), a1 = 2 zeta / (w1 + w2); for N = 1 stiffness-proportional,
 * a0 = 0, a1 = 2 zeta / w1, so that C = 2 zeta w1 m, the storey's own dashpot.
 * a_g = scale * record(t - startTime) (linear between samples, zero outside) + base.a.
 *
 * The state y = (u_1..u_N, u'_1..u'_N, baseWork, forceWork, dampingLoss): three quadratures,
 * so that energy(t) - energy(0) = baseWork + forceWork - dampingLoss holds to the tolerance,
 * energy = 1/2 u'^T M u' + 1/2 u^T K u (relative motion), baseWork = int -a_g 1^T M u' dt,
 * forceWork = int F^T u' dt, dampingLoss = int u'^T C u' dt.
 */
#ifndef BUILDING_H
#define BUILDING_H

#include <stddef.h>

#include "record.h"

#define BUILDING_MAX_STOREYS 10
/* the integrator's size: 2 N displacements and velocities and the three quadratures */
#define BUILDING_NMAX (2 * BUILDING_MAX_STOREYS + 3)
#ifndef NMAX
#define NMAX BUILDING_NMAX
#endif
#include "integrator.h"
#if NMAX < BUILDING_NMAX
#error "ShearBuilding needs NMAX >= 2 * BUILDING_MAX_STOREYS + 3"
#endif

#define BUILDING_FILE_CAPACITY 4096 /* bytes of excitation.file, its terminating NUL included */
/* The record a copy of the FMU carries in its resources for its base, run when excitation.file is empty: a system
 * file's copy (runners' SSP) reaches its record in a tool that sets no String parameters (docs/cosimulation.md). */
#define BUILDING_BASE_RECORD "base_record.txt"
#define BUILDING_REL_TOL_MIN 1e-14
#define BUILDING_REL_TOL_MAX 0.1
/* m, m/s, J: the integrator's absolute error per state at most; a micrometre (per second, a
 * microjoule) is already coarse for floors that move millimetres */
#define BUILDING_ABS_TOL_MAX 1e-6
/* Hz: above it the explicit integrator would take more than about a million steps a second of
 * simulated time (no structure a block stands on vibrates that fast: wrong units, most likely) */
#define BUILDING_MAX_FREQUENCY 1e4

/* The variables of the FMU, addressed by value reference through variables.def. */
typedef struct {
    /* parameters (fixed) */
    int nStoreys;
    double mass[BUILDING_MAX_STOREYS];      /* kg */
    double stiffness[BUILDING_MAX_STOREYS]; /* N/m */
    double carriedMass[BUILDING_MAX_STOREYS]; /* kg: inertia only (not in the Rayleigh damping) */
    double dampingRatio;                    /* 1 */
    char file[BUILDING_FILE_CAPACITY];      /* record file, "" = none */
    double scale;                           /* 1 */
    double startTime;                       /* s: the record's time 0 is placed here */
    double relTol, absTol;
    /* calculated parameters */
    double frequency1, frequency2; /* Hz */
    /* inputs */
    double baseA;                        /* m/s2, added to the record */
    double force[BUILDING_MAX_STOREYS];  /* N, +x */
    /* outputs */
    double u[BUILDING_MAX_STOREYS]; /* m, relative to the base */
    double v[BUILDING_MAX_STOREYS]; /* m/s, relative */
    double a[BUILDING_MAX_STOREYS]; /* m/s2, absolute: a_g + u'' */
    double structureForce[BUILDING_MAX_STOREYS]; /* N: -(K u + C u')_i, the storeys' force on floor i */
    double aTotal;                  /* m/s2, a_g */
    double baseShear;               /* N: 1^T (K u + C u'), the force of the building on the base, +x */
    double energy, baseWork, forceWork, dampingLoss; /* J */
} BuildingVars;

typedef struct {
    BuildingVars v;
    /* derived at initialisation */
    int n;
    double omega[2]; /* rad/s, the two lowest natural circular frequencies (omega[1] = omega[0] for N = 1) */
    double a0, a1;   /* Rayleigh coefficients, 1/s and s */
    const Record *rec; /* the record of excitation.file, or NULL */
    /* integration state */
    double t;             /* s */
    double y[BUILDING_NMAX];
    double h;             /* the step size the integrator proposes next (0: not yet known) */
    /* the forces' first derivatives (N/s, fmi2SetRealInputDerivatives) from forceT0 (s): force[i] + dForce[i] (t -
     * forceT0[i]) (building_force) */
    double dForce[BUILDING_MAX_STOREYS];
    double forceT0[BUILDING_MAX_STOREYS];
    long steps;           /* accepted steps, for the log */
} Building;

/* Start values of every variable. */
void building_defaults(BuildingVars *v);

/* 0 when the parameters are valid, else 1 and a one-line reason in msg. */
int building_validate(const BuildingVars *v, char *msg, size_t n);

/* 0 when rec (may be NULL) scaled by excitation.scale is a usable base acceleration, else 1 and
 * a one-line reason. */
int building_validate_record(const BuildingVars *v, const Record *rec, char *msg, size_t n);

/* The two lowest natural circular frequencies of K phi = w^2 M phi (rad/s), by Sturm bisection
 * on the symmetric tridiagonal M^-1/2 K M^-1/2; omega[1] = omega[0] when n = 1. */
void building_frequencies(int n, const double *m, const double *k, double omega[2]);

/* The highest natural circular frequency (rad/s), likewise; inf when a ratio k/m overflows. */
double building_highest_frequency(int n, const double *m, const double *k);

/* Derive frequencies and damping from valid parameters, attach rec (may be NULL), put the
 * building at rest at time t0 and compute the outputs. */
void building_start(Building *B, const Record *rec, double t0);

/* Integrate to target (> B->t) with the inputs held. 0, or 1 and a one-line reason. */
int building_advance(Building *B, double target, char *msg, size_t n);

/* The outputs at B->t from the state and the current inputs. */
void building_outputs(Building *B);

/* Base acceleration a_g at time t (m/s2): the record, linear between its samples and zero
 * outside them, plus the input base.a. */
double building_ground(const Building *B, double t);
/* The first time derivative of the output at p (one of B's storey[i].u, .v, .a, written by building_outputs) into *d:
 * v_i (m/s), u_i'' (m/s2), and a_i' = -(K u' + C u'')_i / m_i (m/s3; the floors' forces are held over a step, so F'
 * = 0). Returns 1 if p is no such output. */
int building_output_derivative(const Building *B, const double *p, double *d);
/* The force on floor i (0-based) at t (s): its value, and its straight line where a derivative was set (N). */
double building_force(const Building *B, int i, double t);

#endif
