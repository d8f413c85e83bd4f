/* Module-private (dem/): elastic-plastic constants of a powder or target material, Mukherjee & Zohdi
 * Table 1.  E and nu follow from the shear and bulk moduli. */
#ifndef SPRAYCOAT_DEM_MATERIAL_H
#define SPRAYCOAT_DEM_MATERIAL_H

#include "dem/dem.h" /* struct dem_material */

/* 1/E* = (1-nu_a^2)/E_a + (1-nu_b^2)/E_b  (Section 2.1) */
double dem_material_effective_modulus(const struct dem_material *a, const struct dem_material *b);

#endif
