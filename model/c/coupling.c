/* Two-way coupling of a support with the contact engine: the support's side (coupling.h). */
#include "coupling.h"
#include "ground.h"
#include "model.h"

int coupling_on(const Model *M) { return M->d.sup.twoWay; }

int coupling_size(const Model *M) { return M->d.sup.twoWay ? COUPLING_N(M->d.sup.ns) : 0; }

void coupling_free(const Model *M, double t, const double *y, double ag, double *r) {
    const SupportModes *sm = &M->d.sup;
    const double *z = y + EN_N(M->d.en.nb);
    /* storey i's force on floor i, k_i (drift + a1 drift rate) (C = a0 M + a1 K); floor i feels F_i - F_(i+1).
     * From the top down, the storey above's force carried in a scalar: an array of them, stored one by one and
     * read two at a time by the vectorised loop, stalled each call on its stores' forwarding. */
    double above = 0.0;
    for (int i = sm->ns - 1; i >= 0; i--) {
        double du = z[2 * i] - (i > 0 ? z[2 * i - 2] : 0.0), dv = z[2 * i + 1] - (i > 0 ? z[2 * i - 1] : 0.0);
        double F = sm->stiff[i] * (du + sm->a1 * dv);
        r[i] = -sm->a0 * z[2 * i + 1] - (F - above) / sm->mass[i] - ag;
        above = F;
    }
    /* the input support.force: the rest of a structure the FMU does not model, acting on the blocks' floor */
    if (model_input_on(M, 2)) r[sm->j] += model_input(M, 2, t) / sm->mass[sm->j];
}

double coupling_floor(const Model *M, const double *r, double T0, double Ta) {
    const SupportModes *sm = &M->d.sup;
    double mj = sm->mass[sm->j];
    return (mj * r[sm->j] - T0) / (mj + Ta);
}

void coupling_rhs(const Model *M, const double *y, const double *r, double uj, double ag, double av, double px,
                  double py, double *dy) {
    const SupportModes *sm = &M->d.sup;
    int nb = M->d.en.nb, ns = sm->ns;
    const double *z = y + EN_N(nb);
    double mv = 0.0, damp = 0.0, mtot = 0.0;
    for (int k = 0; k < nb; k++) mtot += M->d.en.body[k].m;
    for (int i = 0; i < ns; i++) {
        double a = i == sm->j ? uj : r[i];
        dy[COUPLING_U(nb, i)] = z[2 * i + 1];
        dy[COUPLING_V(nb, i)] = a;
        mv += sm->mass[i] * z[2 * i + 1];
        /* u'^T C u' = a0 sum m_i v_i^2 + a1 sum k_i (v_i - v_(i-1))^2 */
        double dv = z[2 * i + 1] - (i > 0 ? z[2 * (i - 1) + 1] : 0.0);
        damp += sm->a0 * sm->mass[i] * z[2 * i + 1] * z[2 * i + 1] + sm->a1 * sm->stiff[i] * dv * dv;
    }
    double U = z[2 * sm->j + 1];
    dy[COUPLING_WORK(nb, ns)] = -ag * (mv + px + mtot * U) - av * py;
    dy[COUPLING_DAMP(nb, ns)] = damp;
}

double coupling_floor_velocity(const Model *M, const double *y) {
    return y[COUPLING_V(M->d.en.nb, M->d.sup.j)];
}

double coupling_floor_mass(const Model *M) { return M->d.sup.mass[M->d.sup.j]; }

double coupling_energy(const Model *M, const double *y) {
    const SupportModes *sm = &M->d.sup;
    const double *z = y + EN_N(M->d.en.nb);
    double E = 0.0;
    for (int i = 0; i < sm->ns; i++) {
        double du = z[2 * i] - (i > 0 ? z[2 * (i - 1)] : 0.0);
        E += 0.5 * sm->mass[i] * z[2 * i + 1] * z[2 * i + 1] + 0.5 * sm->stiff[i] * du * du;
    }
    return E;
}

double coupling_momentum(const EnSystem *s, const double *y, double *mtot) {
    double p = 0.0, m = 0.0;
    for (int k = 0; k < s->nb; k++) {
        p += s->body[k].m * y[EN_VEL(s->nb, k, 0)];
        m += s->body[k].m;
    }
    if (mtot) *mtot = m;
    return p;
}

/* What the floor's velocity U adds to the blocks' kinetic energy in the base's frame: U px + mtot U^2 / 2. */
static double frame_energy(const Model *M, const double *y) {
    double mtot, px = coupling_momentum(&M->d.en, y, &mtot), U = coupling_floor_velocity(M, y);
    return U * px + 0.5 * mtot * U * U;
}

double coupling_block_energy(const Model *M, const double *y) { return engine_energy(&M->d.en, y) + frame_energy(M, y); }

double coupling_total_energy(const Model *M, const double *y) {
    return coupling_block_energy(M, y) + coupling_energy(M, y);
}

double coupling_kinetic(const Model *M, const double *y) {
    const SupportModes *sm = &M->d.sup;
    const double *z = y + EN_N(M->d.en.nb);
    double E = engine_kinetic(&M->d.en, y) + frame_energy(M, y);
    for (int i = 0; i < sm->ns; i++) E += 0.5 * sm->mass[i] * z[2 * i + 1] * z[2 * i + 1];
    return E;
}

void coupling_carry(const Model *M, double *y, double px, double mtot) {
    y[COUPLING_V(M->d.en.nb, M->d.sup.j)] += px / (coupling_floor_mass(M) + mtot);
}
