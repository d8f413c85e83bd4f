/* Module-private (dem/): the carrier gas, Mukherjee & Zohdi Section 2.3, Eqs. (24)-(27) with the
 * erratum for Eq. (27) in docs/physics.md.
 *
 * Coordinates: nozzle exit centre at the origin, spray axis +z.  The jet's streamwise coordinate is
 * x = z + virtual_origin and its cross-stream coordinate y is r = sqrt(x^2 + y^2) of the spray frame. */
#ifndef SPRAYCOAT_DEM_GAS_H
#define SPRAYCOAT_DEM_GAS_H

#include "dem/dem.h" /* struct dem_gas_field, dem_gas_velocity and dem_gas_drag_force are public */

/* Haider & Levenspiel sphere drag, Eq. (25). */
double dem_drag_coefficient_haider_levenspiel(double reynolds);

/* A normal shock at upstream Mach number M1 > 1 in a perfect gas of heat-capacity ratio gamma: the downstream
 * Mach number and the ratios downstream/upstream of pressure, density, temperature and velocity. */
struct dem_normal_shock {
    double mach_after, pressure_ratio, density_ratio, temperature_ratio, velocity_ratio;
};
struct dem_normal_shock dem_normal_shock(double gamma, double mach);

/* Momentum response time m / |dF/dv| (s) of a sphere of diameter d and density rho at slip speed `slip`;
 * the integrator sub-cycles particles whose response time is shorter than its step.  INFINITY for DEM_JET_NONE. */
double dem_gas_response_time(const struct dem_gas_field *gas, double density, double diameter, double slip);

#endif
