/* Elastic constants of a powder or target material (Mukherjee & Zohdi Table 1 lists G and K; Section 2.1
 * needs E and nu for the effective modulus E*). */
#include "dem/material.h"

/* Isotropic elasticity: E = 9KG/(3K+G). */
static double material_youngs_modulus(const struct dem_material *m)
{
    return 9.0 * m->bulk_modulus * m->shear_modulus / (3.0 * m->bulk_modulus + m->shear_modulus);
}

/* Isotropic elasticity: nu = (3K-2G)/(2(3K+G)). */
static double material_poisson_ratio(const struct dem_material *m)
{
    return (3.0 * m->bulk_modulus - 2.0 * m->shear_modulus) / (2.0 * (3.0 * m->bulk_modulus + m->shear_modulus));
}

/* Compliance (1 - nu^2)/E of one body, the term each body adds to 1/E*. */
static double material_contact_compliance(const struct dem_material *m)
{
    double nu = material_poisson_ratio(m);
    return (1.0 - nu * nu) / material_youngs_modulus(m);
}

/* Hertz effective modulus, Mukherjee & Zohdi Section 2.1: 1/E* = (1-nu_a^2)/E_a + (1-nu_b^2)/E_b. */
double dem_material_effective_modulus(const struct dem_material *a, const struct dem_material *b)
{
    return 1.0 / (material_contact_compliance(a) + material_contact_compliance(b));
}
