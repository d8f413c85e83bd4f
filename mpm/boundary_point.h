/* Module-private (mpm/): a point's boundary forces and the grid's interior test, inline for the host
 * (mpm/mpm_impl.h) and the device (mpm/cuda/step.cu): one copy, as contact_node.h is one copy of the nodal update. */
#ifndef SPRAYCOAT_MPM_BOUNDARY_POINT_H
#define SPRAYCOAT_MPM_BOUNDARY_POINT_H

#include <stddef.h>

#include "core/fastmath.h" /* SC_HD */

/* A force -c u per boundary face of a point, added to f, for u the point's velocity (the absorbing boundary's
 * dashpots, Eq. 3.46 with a = b = 1: c = rho Vp A on the normal part, rho Vs A on the tangential) or its
 * displacement (the viscous-spring boundary's springs, Deeks & Randolph 1994): on the bottom face c_bottom[0] on u's
 * z part and c_bottom[1] on its x and y parts; on a side face, of outward normal n (read only there), c_side[0] on
 * u's part along n and c_side[1] on the rest.  bottom and side: nonzero for a point on that face. */
SC_HD static inline void boundary_face_force(int bottom, int side, const double *n, const double u[3],
                                             const double c_bottom[2], const double c_side[2], double f[3])
{
    if (bottom) {
        f[0] -= c_bottom[1] * u[0];
        f[1] -= c_bottom[1] * u[1];
        f[2] -= c_bottom[0] * u[2];
    }
    if (side) {
        double un = u[0] * n[0] + u[1] * n[1] + u[2] * n[2];
        for (int d = 0; d < 3; d++)
            f[d] -= c_side[0] * un * n[d] + c_side[1] * (u[d] - un * n[d]);
    }
}

/* Whether a point at x has its whole stencil inside the grid: 1 < (x - origin) / h < n - 2 in every direction,
 * decided without the divisions, by the least offsets x - origin that pass and fail ([from, to), mpm_grid_create):
 * the same answer for every x. */
SC_HD static inline int grid_interior(const double origin[3], const double from[3], const double to[3],
                                      const double x[3])
{
    for (int d = 0; d < 3; d++) {
        double offset = x[d] - origin[d];
        if (!(offset >= from[d] && offset < to[d]))
            return 0;
    }
    return 1;
}

#endif
