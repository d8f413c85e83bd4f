/* The carrier gas, Mukherjee & Zohdi Section 2.3: drag Eq. (24) with the Haider-Levenspiel coefficient
 * Eq. (25) (or Stokes), and the self-similar jet Eqs. (26)-(27) with the erratum for Eq. (27) (docs/physics.md).
 * One-way coupling: the gas velocity is a prescribed field. */
#include "dem/gas.h"

#include <math.h>

#include "dem/gas_eval.h"

/* Eq. (25): C_D = 24/Re (1 + 0.1806 Re^0.6459) + 0.4251 / (1 + 6880.95/Re), with libm's pow (the reference
 * value of the tables; the integrator's force uses core/fastmath.h, within a few ulp of it). */
double dem_drag_coefficient_haider_levenspiel(double reynolds)
{
    return 24.0 / reynolds * (1.0 + HL_STOKES_CORRECTION * pow(reynolds, HL_STOKES_EXPONENT)) +
           HL_NEWTON_COEFFICIENT / (1.0 + HL_NEWTON_REYNOLDS / reynolds);
}

void dem_gas_drag_force(const struct dem_gas_field *gas, double diameter, const double v[3], const double u[3],
                        double f[3])
{
    gas_eval_drag(gas, diameter, v, u, f);
}

void dem_gas_drag_force_at(const struct dem_gas_field *gas, double diameter, const double x[3], const double v[3],
                           const double u[3], double f[3])
{
    gas_eval_drag_in(gas, gas_eval_local(gas, x), diameter, v, u, f);
}

/* The Rankine-Hugoniot relations of a normal shock in a perfect gas (NACA Report 1135, 1953):
 *   rho2/rho1 = (g+1) M^2 / ((g-1) M^2 + 2) = u1/u2,   p2/p1 = 1 + 2g/(g+1) (M^2 - 1),
 *   T2/T1 = (p2/p1) / (rho2/rho1),   M2^2 = ((g-1) M^2 + 2) / (2g M^2 - (g-1)). */
struct dem_normal_shock dem_normal_shock(double gamma, double mach)
{
    double m2 = mach * mach;
    struct dem_normal_shock shock;
    shock.density_ratio = (gamma + 1.0) * m2 / ((gamma - 1.0) * m2 + 2.0);
    shock.velocity_ratio = 1.0 / shock.density_ratio;
    shock.pressure_ratio = 1.0 + 2.0 * gamma / (gamma + 1.0) * (m2 - 1.0);
    shock.temperature_ratio = shock.pressure_ratio / shock.density_ratio;
    shock.mach_after = sqrt(((gamma - 1.0) * m2 + 2.0) / (2.0 * gamma * m2 - (gamma - 1.0)));
    return shock;
}

/* mu(T2)/mu(T1) of Sutherland's law mu ~ T^1.5 / (T + S) (dem_nozzle_viscosity's), T2 = ratio T1. */
static double sutherland_ratio(double ratio, double t1, double s)
{
    return ratio * sqrt(ratio) * (t1 + s) / (ratio * t1 + s);
}

/* The free jet's station (x = z + virtual_origin) whose profile holds at z: the core's end inside the core. */
static double jet_station(const struct dem_gas_field *gas, double z)
{
    double x = z + gas->virtual_origin;
    return z < gas->core_length || !(x > 0.0) ? gas->core_length + gas->virtual_origin : x;
}

/* sech^2(xi) = 1/2 at xi = acosh(sqrt 2) = 0.88137: the half-width b = 0.88137 x^(2/3) / C3. */
#define HALF_WIDTH_XI 0.88137358701954302523

/* Lobb (1964): a sphere's shock stands Delta = 0.41 D rho1/rho2 = 0.82 R rho1/rho2 ahead of it; the jet's
 * half-width at the wall plays R (docs/physics.md "The bow shock at the target"). */
#define LOBB_STANDOFF_PER_RADIUS 0.82

/* The bow shock in front of the wall at z = wall_z for a jet of half-width b there: the free jet's axial Mach
 * number M1 = U/a on the axis at the shock, a = sqrt(gamma R T) at the jet's static temperature, and the standoff
 * Delta = 0.82 b rho1/rho2(M1) (at most wall_z) solved together: M1 is taken at z = wall_z - Delta, where U is
 * higher the farther the shock stands, and rho1/rho2 falls with M1, so the iteration alternates and contracts
 * (U ~ x^(-1/3)).  Standoff 0: the jet arrives subsonic (M1 <= 1), bow_shock none, or no gas state given. */
static void place_bow_shock(struct dem_gas_field *gas, double wall_z, double half_width)
{
    gas->shock_mach = gas->shock_standoff = 0.0;
    gas->shock_velocity_ratio = gas->shock_density_ratio = gas->shock_temperature_ratio = 1.0;
    gas->shock_viscosity_ratio = 1.0;
    double sound_speed = sqrt(gas->gas_gamma * gas->gas_constant * gas->gas_temperature);
    if (gas->bow_shock != DEM_BOW_SHOCK_AUTO || !(sound_speed > 0.0) || !(gas->gas_gamma > 1.0))
        return;
    double standoff = 0.0, mach = 0.0;
    for (int iteration = 0; iteration < 200; iteration++) {
        mach = gas->c1 / cbrt(jet_station(gas, wall_z - standoff)) / sound_speed;
        double ratio = mach > 1.0 ? dem_normal_shock(gas->gas_gamma, mach).velocity_ratio : 1.0;
        double next = fmin(LOBB_STANDOFF_PER_RADIUS * half_width * ratio, wall_z);
        int settled = fabs(next - standoff) <= 1e-14 * half_width;
        standoff = next;
        if (settled)
            break;
    }
    mach = gas->c1 / cbrt(jet_station(gas, wall_z - standoff)) / sound_speed;
    if (!(mach > 1.0))
        return;
    struct dem_normal_shock shock = dem_normal_shock(gas->gas_gamma, mach);
    gas->shock_mach = mach;
    gas->shock_standoff = standoff;
    gas->shock_velocity_ratio = shock.velocity_ratio;
    gas->shock_density_ratio = shock.density_ratio;
    gas->shock_temperature_ratio = shock.temperature_ratio;
    gas->shock_viscosity_ratio = sutherland_ratio(shock.temperature_ratio, gas->gas_temperature, gas->gas_sutherland);
}

void dem_gas_set_wall(struct dem_gas_field *gas, double wall_z)
{
    gas->wall_z = wall_z;
    gas->stagnation_height = gas->wall_axis_speed = gas->wall_inverse_width = 0.0;
    gas->inverse_stagnation_height = gas->wall_outflow_scale = 0.0;
    gas->shock_mach = gas->shock_standoff = 0.0;
    gas->shock_velocity_ratio = gas->shock_density_ratio = gas->shock_temperature_ratio = 1.0;
    gas->shock_viscosity_ratio = 1.0;
    if (gas->model != DEM_JET_BICKLEY || !(gas->stagnation_factor > 0.0))
        return;
    double half_width = HALF_WIDTH_XI * pow(jet_station(gas, wall_z), 2.0 / 3.0) / gas->c3;
    gas->stagnation_height = fmin(gas->stagnation_factor * half_width, wall_z);
    /* a supersonic jet cannot feel the wall ahead of its shock: the wall region is then the layer below it */
    place_bow_shock(gas, wall_z, half_width);
    if (gas->shock_standoff > 0.0)
        gas->stagnation_height = gas->shock_standoff;
    double x_top = jet_station(gas, wall_z - gas->stagnation_height);
    gas->wall_axis_speed = gas->c1 / cbrt(x_top);
    gas->wall_inverse_width = gas->c3 / pow(x_top, 2.0 / 3.0);
    gas->inverse_stagnation_height = 1.0 / gas->stagnation_height;
    gas->wall_outflow_scale =
        gas->wall_axis_speed / (gas->wall_inverse_width * gas->wall_inverse_width * gas->stagnation_height);
}

void dem_gas_velocity(const struct dem_gas_field *gas, const double x[3], double u[3])
{
    gas_eval_velocity(gas, x, u);
}

/* For a drag along the slip, dF/dv has eigenvalues -dF/ds (along the slip) and -F/s (across it); dF/ds >= F/s
 * for C_D falling no faster than 1/Re, so dF/ds sets the stiffest time.  Stokes: tau = rho d^2 / (18 mu). */
double dem_gas_response_time(const struct dem_gas_field *gas, double density, double diameter, double slip)
{
    slip = fabs(slip);
    double reynolds = gas_eval_reynolds(gas, diameter, slip);
    return gas_eval_response_time(gas, density, diameter, slip, gas_eval_reynolds_power(reynolds));
}
