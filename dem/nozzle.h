/* dem: the de Laval nozzle in front of the spray (docs/physics.md "Nozzle").
 *
 * Quasi-one-dimensional isentropic flow of a calorically perfect gas through a conical convergent-divergent
 * nozzle (Anderson, Modern Compressible Flow, 3rd ed., Ch. 5: the area-Mach relation Eq. 5.20 and the isentropic
 * relations Eqs. 3.28-3.31; the normal shock Eq. 3.57), and each particle's acceleration and heating along its axis:
 * drag with Henderson's (1976) coefficient for continuum and rarefied, subsonic and supersonic flow, convective
 * heating with the Ranz-Marshall (1952) Nusselt number towards the recovery temperature, integrated with CVODE.
 * Coordinates: x along the axis from the convergent inlet (x = 0), the throat at x = convergent_length, the exit
 * at x = convergent_length + divergent_length.  All quantities SI. */
#ifndef SPRAYCOAT_DEM_NOZZLE_H
#define SPRAYCOAT_DEM_NOZZLE_H

#include <stddef.h>

enum dem_nozzle_gas { DEM_NOZZLE_N2, DEM_NOZZLE_HE, DEM_NOZZLE_AIR };

/* A process gas: calorically perfect, Sutherland's viscosity law mu = mu_ref (T/T_ref)^1.5 (T_ref + S)/(T + S),
 * constant Prandtl number (docs/physics.md "Nozzle" cites the values). */
struct dem_nozzle_gas_properties {
    const char *name;
    double gamma;        /* ratio of specific heats */
    double gas_constant; /* J/(kg K) */
    double mu_ref;       /* Pa s at t_ref */
    double t_ref;        /* K */
    double sutherland;   /* S, K */
    double prandtl;      /* - */
};
const struct dem_nozzle_gas_properties *dem_nozzle_gas_properties(enum dem_nozzle_gas gas);
/* Dynamic viscosity (Pa s) of the gas at temperature T (K). */
double dem_nozzle_viscosity(const struct dem_nozzle_gas_properties *gas, double temperature);

/* The gas at one station. */
struct dem_nozzle_station {
    double x;           /* m from the inlet */
    double diameter;    /* m */
    double mach;        /* - */
    double pressure;    /* Pa, static */
    double temperature; /* K, static */
    double density;     /* kg/m3 */
    double velocity;    /* m/s */
};

enum { DEM_NOZZLE_PROFILE_POINTS = 201, DEM_NOZZLE_TABLE_ROWS = 24 };

struct dem_nozzle {
    int enabled; /* 0: no [nozzle] section, none of the rest is set */
    enum dem_nozzle_gas gas;
    struct dem_nozzle_gas_properties properties;
    double stagnation_pressure, stagnation_temperature; /* Pa, K */
    double inlet_diameter, throat_diameter, exit_diameter;
    double convergent_length, divergent_length; /* m */
    double ambient_pressure;                    /* Pa */
    /* the powder as the nozzle sees it */
    double particle_density;       /* kg/m3 */
    double particle_specific_heat; /* J/(kg K) */
    double particle_temperature;   /* K, at the inlet */
    /* results (dem_nozzle_solve) */
    struct dem_nozzle_station exit;
    struct dem_nozzle_station profile[DEM_NOZZLE_PROFILE_POINTS]; /* equally spaced inlet to exit */
    double table_diameter[DEM_NOZZLE_TABLE_ROWS];                 /* m, ascending (logarithmically spaced) */
    double table_velocity[DEM_NOZZLE_TABLE_ROWS];                 /* m/s at the exit */
    double table_temperature[DEM_NOZZLE_TABLE_ROWS];              /* K at the exit */
    double table_time[DEM_NOZZLE_TABLE_ROWS];                     /* s, residence time inlet to exit */
};

/* A/A* of the isentropic flow at Mach number M (Anderson Eq. 5.20). */
double dem_nozzle_area_ratio(double mach, double gamma);
/* The Mach number of area ratio A/A* >= 1 on the subsonic (supersonic = 0) or supersonic branch, to round-off. */
double dem_nozzle_mach(double area_ratio, double gamma, int supersonic);
/* The gas at x (subsonic before the throat, supersonic after it). */
void dem_nozzle_station_at(const struct dem_nozzle *n, double x, struct dem_nozzle_station *out);

/* Henderson (1976), AIAA J. 14:707-708: the drag coefficient of a sphere at Reynolds number Re and Mach number M
 * of the slip, the sphere's temperature over the gas's temperature_ratio = T_p/T_g, the gas's gamma. */
double dem_nozzle_drag_coefficient(double reynolds, double mach, double temperature_ratio, double gamma);

/* The particle's rates along the axis at x: y = (v, T_p, t) (m/s, K, s), dy/dx (v > 0). */
void dem_nozzle_particle_rates(const struct dem_nozzle *n, double diameter, double x, const double y[3],
                               double dydx[3]);

/* Integrate one particle of diameter d from the inlet (at the gas speed there, at particle_temperature) to the
 * exit with CVODE; out = (v, T_p, t) at the exit.  SC_ESIM if the integration fails. */
int dem_nozzle_particle_exit(const struct dem_nozzle *n, double diameter, double out[3]);

/* The exit state, the profile and the particle table over [d_small, d_large]; SC_EINPUT when a normal shock would
 * stand inside the divergent part (the ambient pressure above the pressure behind a normal shock at the exit),
 * with the numbers in the message. */
int dem_nozzle_solve(struct dem_nozzle *n, double d_small, double d_large);

/* The exit velocity and temperature of diameter d, interpolated in ln d in the table (held at its ends). */
void dem_nozzle_lookup(const struct dem_nozzle *n, double diameter, double *velocity, double *temperature);

#endif
