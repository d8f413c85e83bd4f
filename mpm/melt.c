/* Steinberg-Cochran-Guinan melt temperature, Tang Eq. 2.9 with the erratum of docs/physics.md: the exponent is
 * 2 (Gamma0 - a - 1/3) (Steinberg's law), not 2 Gamma0 - a - 1/3 as the thesis text reads. */
#include "mpm/material.h"

/* Tang Eq. 2.9 (corrected): Tm0 exp(2a (1 - 1/eta)) eta^(2 (Gamma0 - a - 1/3)), eta = rho/rho0.
 * 0 for rho <= 0 (the eta -> 0 limit), so such a point counts as melted. */
double mpm_scg_melt_temperature(const struct mpm_material *m, double rho)
{
    return scg_melt_temperature(m, rho);
}
