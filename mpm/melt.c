/* Steinberg-Cochran-Guinan melt temperature, Tang Eq. 2.9 with the erratum of docs/physics.md: the exponent is
 * 2 (Gamma0 - a - 1/3) (Steinberg's law), not 2 Gamma0 - a - 1/3 as the thesis text reads. */
#include "mpm/material.h"

#include <math.h>

/* Tang Eq. 2.9 (corrected): Tm0 exp(2a (1 - 1/eta)) eta^(2 (Gamma0 - a - 1/3)), eta = rho/rho0.
 * 0 for rho <= 0 (the eta -> 0 limit), so such a point counts as melted. */
double mpm_scg_melt_temperature(const struct mpm_material *m, double rho)
{
    if (!(rho > 0.0))
        return 0.0;
    double eta = rho / m->density;
    double exponent = 2.0 * (m->eos_gamma0 - m->melt_a - 1.0 / 3.0);
    return m->melt_T0 * exp(2.0 * m->melt_a * (1.0 - 1.0 / eta)) * pow(eta, exponent);
}
