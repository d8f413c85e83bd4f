/* Module-private (mpm/): one point's share of its body's diagnostics (thesis Chapter 5: energies, plastic strain
 * and its energy density, PBCP of Eq. 5.1, v_rest of Section 5.2.1), inline for the host (mpm/diagnostics.c, which
 * adds the points in id order) and the device (mpm/cuda/step.cu, a fixed tree): one copy, as contact_node.h is one
 * copy of the nodal update.  Plain C for both compilers. */
#ifndef SPRAYCOAT_MPM_DIAGNOSTICS_POINT_H
#define SPRAYCOAT_MPM_DIAGNOSTICS_POINT_H

#include <stddef.h>
#include <stdint.h>

#include "core/fastmath.h" /* SC_HD */
#include "mpm/material.h"  /* struct mpm_point_state */

/* A body's sums over its active points (mpm_compute_diagnostics makes the body's diagnostics of them). */
struct point_sums {
    double mass, volume0, kinetic, internal, plastic_work, eps_p_mass, momentum[3];
    double slow_vz;        /* the grid's v_z of the points slower than the v_rest filter */
    double d_bond_surface; /* D_bond over the surface points */
    int64_t slow, surface, contacted, bonded;
};

/* The point arrays the sums read (struct mpm_points, or the device's copies), each point's by its index. */
struct point_fields {
    const double *v, *mass, *volume0, *plastic_work, *d_bond;
    const struct mpm_point_state *state;
    const uint8_t *flags;
    unsigned surface_flag; /* the flags' bit of a surface point (POINT_SURFACE) */
    double vrest_filter;   /* m/s: the points slower than this give v_rest (Section 5.2.1's 60 m/s) */
};

/* Point q's share, with v the grid's velocity at it (diagnostics.c smooth_velocity): the kinetic energy is the
 * points' own (the energy balance's), the momentum and v_rest the grid's (free of the points' FLIP noise). */
SC_HD static inline void point_sums_add(struct point_sums *b, const struct point_fields *f, size_t q, const double v[3])
{
    const double *vp = f->v + 3 * q;
    double m = f->mass[q], d_bond = f->d_bond[q], speed2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
    b->mass += m;
    b->volume0 += f->volume0[q];
    b->kinetic += 0.5 * m * (vp[0] * vp[0] + vp[1] * vp[1] + vp[2] * vp[2]);
    b->internal += f->state[q].energy;
    b->plastic_work += f->plastic_work[q];
    b->eps_p_mass += m * f->state[q].eps_p;
    for (int d = 0; d < 3; d++)
        b->momentum[d] += m * v[d];
    if (speed2 < f->vrest_filter * f->vrest_filter) {
        b->slow_vz += v[2];
        b->slow++;
    }
    if (f->flags[q] & f->surface_flag) {
        b->surface++;
        b->d_bond_surface += d_bond;
    }
    b->contacted += d_bond > 0.0;
    b->bonded += d_bond >= 1.0;
}

/* into += from, member by member (the device's tree). */
SC_HD static inline void point_sums_merge(struct point_sums *into, const struct point_sums *from)
{
    into->mass += from->mass;
    into->volume0 += from->volume0;
    into->kinetic += from->kinetic;
    into->internal += from->internal;
    into->plastic_work += from->plastic_work;
    into->eps_p_mass += from->eps_p_mass;
    for (int d = 0; d < 3; d++)
        into->momentum[d] += from->momentum[d];
    into->slow_vz += from->slow_vz;
    into->d_bond_surface += from->d_bond_surface;
    into->slow += from->slow;
    into->surface += from->surface;
    into->contacted += from->contacted;
    into->bonded += from->bonded;
}

#endif
