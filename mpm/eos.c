/* Mie-Grueneisen equation of state in the form linear in the energy, p = A(mu) + B(mu) E (Tang Eq. 3.42; the
 * coefficients are Zhang et al. Eq. 6.180, as in MPM3D-F90 `eos2`): mu = rho/rho0 - 1, E the internal energy
 * per INITIAL volume (J/m3), and with C1 = rho0 c0^2, C2 = C1 (2s - 1), C3 = C1 (s - 1)(3s - 1):
 *   compression (mu > 0):  A = (C1 mu + C2 mu^2 + C3 mu^3)(1 - Gamma0 mu / (2 (1 + mu))),  B = Gamma0
 *   tension     (mu <= 0): A = C1 mu,                                                    B = Gamma0
 * Decision: MPM3D-F90 sets B = 0 in tension.  We keep B = Gamma0 there so that p is continuous at mu = 0 when
 * E != 0 (a point heated by plastic work and then unloaded would otherwise see its pressure jump by
 * Gamma0 E).  dA/dmu = C1 on both sides, so dp/dmu is continuous as well.  eos_coefficients is in material.h
 * (inline: the stress update calls it for every point and step). */
#include "mpm/material.h"

/* Tang Eq. 3.42: p = A + B E. */
double mpm_eos_pressure(const struct mpm_material *m, double rho, double energy_per_initial_volume)
{
    double A, B;
    eos_coefficients(m, rho, &A, &B);
    return A + B * energy_per_initial_volume;
}
