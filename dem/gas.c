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

/* The free jet's station (x = z + virtual_origin) whose profile holds at z: the core's end inside the core. */
static double jet_station(const struct dem_gas_field *gas, double z)
{
    double x = z + gas->virtual_origin;
    return z < gas->core_length || !(x > 0.0) ? gas->core_length + gas->virtual_origin : x;
}

/* sech^2(xi) = 1/2 at xi = acosh(sqrt 2) = 0.88137: the half-width b = 0.88137 x^(2/3) / C3. */
#define HALF_WIDTH_XI 0.88137358701954302523

void dem_gas_set_wall(struct dem_gas_field *gas, double wall_z)
{
    gas->wall_z = wall_z;
    gas->stagnation_height = gas->wall_axis_speed = gas->wall_inverse_width = 0.0;
    gas->inverse_stagnation_height = gas->wall_outflow_scale = 0.0;
    if (gas->model != DEM_JET_BICKLEY || !(gas->stagnation_factor > 0.0))
        return;
    double half_width = HALF_WIDTH_XI * pow(jet_station(gas, wall_z), 2.0 / 3.0) / gas->c3;
    gas->stagnation_height = fmin(gas->stagnation_factor * half_width, wall_z);
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
