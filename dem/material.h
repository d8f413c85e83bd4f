/* Module-private (dem/): elastic-plastic constants of a powder or target material, Mukherjee & Zohdi
 * Table 1.  E and nu follow from the shear and bulk moduli. */
#ifndef SPRAYCOAT_DEM_MATERIAL_H
#define SPRAYCOAT_DEM_MATERIAL_H

struct dem_material {
    double density;        /* kg/m3 (particles; unused for the target) */
    double shear_modulus;  /* G, Pa */
    double bulk_modulus;   /* K, Pa */
    double yield_stress;   /* Y, Pa */
    double surface_energy; /* gamma, J/m2 */
    double friction;       /* Coulomb coefficient mu, - */
};

/* E = 9KG/(3K+G) */
double material_youngs_modulus(const struct dem_material *m);
/* nu = (3K-2G)/(2(3K+G)) */
double material_poisson_ratio(const struct dem_material *m);
/* 1/E* = (1-nu_a^2)/E_a + (1-nu_b^2)/E_b  (Section 2.1) */
double dem_material_effective_modulus(const struct dem_material *a, const struct dem_material *b);

#endif
