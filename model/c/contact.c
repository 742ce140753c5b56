/* Contact reactions from Newton's second law for the centres of mass
 * (docs/contact.md). rot(theta) = [[cos, sin], [-sin, cos]] turns a body
 * vector clockwise; a point at rot(theta) u from a pivot fixed to the ground
 * accelerates, relative to the ground, by rot'(theta) u theta'' - rot(theta) u
 * theta'^2, rot' = [[-sin, cos], [-cos, -sin]]. In the inertial frame add the
 * ground's acceleration (ah, av). */
#include "contact.h"

#include <math.h>

/* Acceleration relative to the ground of the point rot(theta) (ux, uy). */
static void arm_accel(double theta, double omega, double alpha, double ux, double uy, double a[2]) {
    double c = cos(theta), s = sin(theta);
    double w2 = omega * omega;
    a[0] = (-s * ux + c * uy) * alpha - (c * ux + s * uy) * w2;
    a[1] = (-c * ux - s * uy) * alpha - (-s * ux + c * uy) * w2;
}

void contact_one_block(const Model *M, int moving, double theta, double omega, double alphaDD,
                       int side, double ah, double av, double *T, double *N) {
    const Variables *v = &M->v;
    double a[2] = {0.0, 0.0};
    /* centre of mass from the pivot: (-side b, h) in the block's frame */
    if (moving) arm_accel(theta, omega, alphaDD, -side * v->halfWidth, v->halfHeight, a);
    *T = v->mass * (ah + a[0]);
    *N = v->mass * (v->g + av + a[1]);
}

void contact_stack(const Model *M, Mode mode, int s1, int s2, const double y[4], const double acc[2],
                   double ah, double av, double *Tg, double *Ng, double *Ti, double *Ni) {
    const Variables *v = &M->v;
    double c = M->d.c;
    double a1[2] = {0.0, 0.0}, aK[2] = {0.0, 0.0}, a2[2] = {0.0, 0.0};
    int moving = mode == MODE_UPPER || mode == MODE_LOCKED || mode == MODE_BOTH;
    if (moving) {
        /* ground pivot (s1 b1, 0) -> centre of block 1, -> pivot K = (s2 c, 2 h1) of block 2;
         * K -> centre of block 2 in block 2's frame */
        arm_accel(y[0], y[1], acc[0], -s1 * v->halfWidth, v->halfHeight, a1);
        arm_accel(y[0], y[1], acc[0], s2 * c - s1 * v->halfWidth, 2.0 * v->halfHeight, aK);
        arm_accel(y[2], y[3], acc[1], -s2 * c, v->halfHeight2, a2);
    }
    /* block 2: m2 (A + aK + a2) = F + m2 (0, -g) */
    double Fx = v->mass2 * (ah + aK[0] + a2[0]);
    double Fy = v->mass2 * (v->g + av + aK[1] + a2[1]);
    /* block 1: m1 (A + a1) = Q - F + m1 (0, -g) */
    *Tg = v->mass * (ah + a1[0]) + Fx;
    *Ng = v->mass * (v->g + av + a1[1]) + Fy;
    /* F in block 1's axes: tangent rot(theta1) (1, 0), normal rot(theta1) (0, 1) */
    double c1 = moving ? cos(y[0]) : 1.0, n1 = moving ? sin(y[0]) : 0.0;
    *Ti = Fx * c1 - Fy * n1;
    *Ni = Fx * n1 + Fy * c1;
}
