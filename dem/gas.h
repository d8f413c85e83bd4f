/* Module-private (dem/): the carrier gas, Mukherjee & Zohdi Section 2.3, Eqs. (24)-(27) with the
 * DESIGN.md erratum for Eq. (27).
 *
 * Coordinates: nozzle exit centre at the origin, spray axis +z.  The jet's streamwise coordinate is
 * x = z + virtual_origin and its cross-stream coordinate y is r = sqrt(x^2 + y^2) of the spray frame. */
#ifndef SPRAYCOAT_DEM_GAS_H
#define SPRAYCOAT_DEM_GAS_H

enum dem_jet_model { DEM_JET_BICKLEY, DEM_JET_UNIFORM, DEM_JET_NONE };
enum dem_drag_law { DEM_DRAG_HAIDER_LEVENSPIEL, DEM_DRAG_STOKES };

struct dem_gas_field {
    enum dem_jet_model model;
    enum dem_drag_law drag;
    double c1, c2, c3;          /* jet constants of Eqs. (26)-(27), SI (C1: m^(4/3)/s, C2: m^(5/3)/s, C3: m^(-1/3)) */
    double virtual_origin;      /* m, distance of the jet's virtual origin behind the nozzle exit */
    double core_length;         /* m, potential core: for z < core_length the profile of z = core_length
                                   is used without entrainment (no radial velocity) */
    double uniform_velocity;    /* m/s along +z, DEM_JET_UNIFORM */
    double density;             /* rho_f, kg/m3 */
    double kinematic_viscosity; /* nu_f, m2/s */
};

/* Gas velocity u[3] at position x[3] (DEM_JET_NONE: still gas, zero). */
void dem_gas_velocity(const struct dem_gas_field *gas, const double x[3], double u[3]);

/* Haider & Levenspiel sphere drag, Eq. (25). */
double dem_drag_coefficient_haider_levenspiel(double reynolds);

/* Drag force f[3] (N) on a sphere of diameter d moving at v[3] in gas moving at u[3], Eq. (24).
 * DEM_JET_NONE means no gas at all: zero force. */
void dem_gas_drag_force(const struct dem_gas_field *gas, double diameter, const double v[3], const double u[3],
                    double f[3]);

/* Momentum response time m / |dF/dv| (s) of a sphere of diameter d and density rho at slip speed `slip`;
 * the integrator sub-cycles particles whose response time is shorter than its step.  INFINITY for DEM_JET_NONE. */
double dem_gas_response_time(const struct dem_gas_field *gas, double density, double diameter, double slip);

#endif
