/* The Dormand-Prince integrator of model/c/integrator.c compiled for ShearBuilding: with NMAX
 * large enough for ten storeys (building.h defines it before integrator.h is first included),
 * so that this copy and building.c agree on the size of the dense-output arrays. */
#include "building.h"
#include "integrator.c"
