/* Module-private (mpm/): the increments of the bonding parameter D_bond of thesis Chapter 4, inline for the host
 * (mpm/bonding.c) and the device (mpm/cuda/step.cu): one copy of the law; bonding.c has the notes. */
#ifndef SPRAYCOAT_MPM_BONDING_LAW_H
#define SPRAYCOAT_MPM_BONDING_LAW_H

#include <math.h>

#include "core/fastmath.h" /* SC_HD */

/* The rate factor of Eqs. 4.4 and 4.16b, 1 - ln r for the rate ratio r, held at or above `floor`. */
SC_HD static inline double bonding_rate_factor(double r, double floor)
{
    double factor = 1.0 - log(r);
    return factor > floor ? factor : floor; /* r = 0: +inf, dD = 0 */
}

/* Energy model, Eqs. 4.16-4.17: dG_s = sigma_vm d eps_p DCell, G_bond = G_c (1 - ln(dG_s / (dG_c/dt dt))) held at or
 * above floor G_c, dD = dG_s / G_bond. */
SC_HD static inline double bonding_energy_increment(double eps_p_increment, double von_mises, double dt, double cell,
                                                    double Gc, double Gc_rate, double floor)
{
    double dG = von_mises * eps_p_increment * cell;
    if (!(dG > 0.0))
        return 0.0;
    return dG / (Gc * bonding_rate_factor(dG / (Gc_rate * dt), floor));
}

/* Strain model, Eqs. 4.3-4.5: dD = d eps_s / eps_bond, eps_bond = eps_c (1 - ln(eps_s_dot / eps_c_dot)) held at or
 * above floor eps_c. */
SC_HD static inline double bonding_strain_increment(double eps_p_increment, double dt, double eps_c, double eps_rate_c,
                                                    double floor)
{
    if (!(eps_p_increment > 0.0))
        return 0.0;
    return eps_p_increment / (eps_c * bonding_rate_factor(eps_p_increment / dt / eps_rate_c, floor));
}

#endif
