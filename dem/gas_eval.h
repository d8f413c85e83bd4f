/* Module-private (dem/): the jet velocity (Eqs. 26-27) and the drag force (Eqs. 24-25) of one particle as
 * inline arithmetic: selects instead of branches on the particle, core/fastmath.h instead of libm (sqrt is
 * correctly rounded, the same in a vector lane), so that the integrator's loops over particles vectorise and
 * every lane gives the bits of the scalar code.
 * dem/gas.c wraps them as dem_gas_velocity and dem_gas_drag_force; dem/integrate.c inlines them. */
#ifndef SPRAYCOAT_DEM_GAS_EVAL_H
#define SPRAYCOAT_DEM_GAS_EVAL_H

#include <math.h>

#include "core/fastmath.h"
#include "dem/drag_henderson.h"
#include "dem/gas.h"

#define GAS_PI 3.14159265358979323846

/* Haider & Levenspiel (1989) sphere constants, Eq. (25). */
#define HL_STOKES_CORRECTION  0.1806
#define HL_STOKES_EXPONENT    0.6459
#define HL_NEWTON_COEFFICIENT 0.4251
#define HL_NEWTON_REYNOLDS    6880.95

/* sech^2(xi) and tanh(xi) from q = exp(-2|xi|) <= 1, which cannot overflow (cosh(xi) does for
 * |xi| > ~710): sech^2 = 4q/(1+q)^2, tanh = sign(xi) (1-q)/(1+q). */
FM_INLINE void gas_eval_sech2_tanh(double xi, double *sech2, double *tanh_xi, double *q_out)
{
    double q = fm_exp(-2.0 * fabs(xi));
    double inverse_one_plus_q = 1.0 / (1.0 + q);
    *sech2 = 4.0 * q * inverse_one_plus_q * inverse_one_plus_q;
    *tanh_xi = copysign((1.0 - q) * inverse_one_plus_q, xi);
    *q_out = q;
}

/* The self-similar jet in the spray frame.  Downstream of the potential core: Eq. (26)
 * u = C1 / x^(1/3) sech^2(xi) and Eq. (27) with the erratum, v = C2 / x^(2/3) (2 xi sech^2 xi - tanh xi),
 * xi = C3 r / x^(2/3), at x = z + virtual_origin.  Inside the core (z < core_length), and anywhere behind the
 * virtual origin, the profile of z = core_length without entrainment (no radial part).  If even that station
 * lies at or behind the virtual origin the profile is singular: still gas there (the parameter layer refuses
 * such a jet).  Every branch is a select, so that loops over particles vectorise. */
FM_INLINE void gas_eval_bickley(const struct dem_gas_field *gas, const double pos[3], double u[3], double *xi_out,
                                double *tanh_out, double *q_out)
{
    /* every operation is done whatever the selects: a conditional floating-point operation could trap, so
     * the compiler would keep the branches and not vectorise */
    double r = sqrt(pos[0] * pos[0] + pos[1] * pos[1]);
    double x_here = pos[2] + gas->virtual_origin, x_core = gas->core_length + gas->virtual_origin;
    int in_core = (pos[2] < gas->core_length) | !(x_here > 0.0);
    double x = fm_select(in_core, x_core, x_here);
    int defined = x > 0.0;
    double inverse_cube_root = fm_inverse_cbrt(fm_select(defined, x, 1.0));
    double inverse_two_thirds = inverse_cube_root * inverse_cube_root;
    double xi = gas->c3 * r * inverse_two_thirds;
    double sech2, tanh_xi;
    gas_eval_sech2_tanh(xi, &sech2, &tanh_xi, q_out);
    *xi_out = xi;
    *tanh_out = tanh_xi;
    double axial = gas->c1 * inverse_cube_root * sech2;
    double entrained = gas->c2 * inverse_two_thirds * (2.0 * xi * sech2 - tanh_xi);
    double radial = fm_select(in_core, 0.0, entrained);
    double safe_r = fm_select(r > 0.0, r, 1.0);
    double radial_x = radial * pos[0] / safe_r, radial_y = radial * pos[1] / safe_r;
    /* radial unit vector (x, y)/r; none on the axis */
    int radial_direction = defined & (r > 0.0);
    u[0] = fm_select(radial_direction, radial_x, 0.0);
    u[1] = fm_select(radial_direction, radial_y, 0.0);
    u[2] = fm_select(defined, axial, 0.0);
}

/* rho tanh(rho) - ln cosh(rho) for rho >= 0 (given tanh rho and q = exp(-2 rho), which the jet's profile computed):
 * 2 pi/a^2 times it is the volume flux of the profile sech^2(a r') through the disc r' < rho/a.
 * ln cosh rho = rho - ln 2 + ln(1 + q) (no overflow); below rho = 1e-3 the series rho^2/2 - rho^4/4 (the
 * difference of two nearly equal terms would lose its digits). */
FM_INLINE double gas_eval_disc_flux(double rho, double tanh_rho, double q)
{
    double log_cosh = rho - 0.69314718055994530942 + fm_log(1.0 + q);
    double rho2 = rho * rho;
    return fm_select(rho < 1e-3, 0.5 * rho2 - 0.25 * rho2 * rho2, rho * tanh_rho - log_cosh);
}

/* The jet impinging on the wall z = wall_z (docs/physics.md "The jet at the wall").  Above the wall region
 * (s = wall_z - z >= H) the free jet.  In it (0 <= s < H, eta = s/H, g = eta (2 - eta)), with W(r) and V(r) the
 * free jet's axial and radial velocity at the region's top z_H = wall_z - H:
 *     u_z = g(eta) W(r)                                     (stagnation: 0 at the wall, dg/deta = 0 at the top)
 *     u_r = g(eta) V(r) + g'(eta) U_H F(a_H r) / (a_H^2 H r)  (F = gas_eval_disc_flux)
 * The second term of u_r carries away, radially, the axial flux that g' W / H removes from the jet: it makes
 * div u = 0 but for the free jet's own part g (V/r + dV/dr + dW/dz) (Eq. 27 is the planar jet's entrainment), so
 * the volume flux into a cylinder r < R of the wall region through its top leaves through its side to within
 * the free jet's entrainment there.  At the wall u_r = 2 U_H F / (a_H^2 H r): a stagnation-point flow U_H r/H near
 * the axis, a radial wall jet beyond, at most 0.77/k U_H (k = H/b; the most of F(rho)/rho is 0.340 at
 * rho = 1.30), decaying as 1/r, as the Glauert wall jet's r^-1.1 (Poreh, Tsuei & Cermak 1967).  The free jet
 * below the wall (z > wall_z) is never asked for: every branch is a select. */
FM_INLINE void gas_eval_wall(const struct dem_gas_field *gas, const double pos[3], double u[3])
{
    double height = gas->stagnation_height, top = gas->wall_z - height;
    int in_region = (pos[2] > top) & (height > 0.0);
    double at[3] = {pos[0], pos[1], fm_select(in_region, top, pos[2])};
    double jet[3], xi, tanh_xi, q;
    gas_eval_bickley(gas, at, jet, &xi, &tanh_xi, &q); /* in the region xi = a_H r, the station being z_H's */
    /* multiplications by 1/H and 1/r^2, set once, in place of divisions: this runs in the integrator's loops */
    double eta = (gas->wall_z - pos[2]) * gas->inverse_stagnation_height;
    eta = fm_select(eta > 0.0, eta, 0.0);
    double g = eta * (2.0 - eta), slope = 2.0 * (1.0 - eta);
    double r2 = pos[0] * pos[0] + pos[1] * pos[1];
    double inverse_r2 = 1.0 / fm_select(r2 > 0.0, r2, 1.0);
    /* u_r / r: on the axis (r = 0) the outflow vanishes */
    double outflow_over_r = slope * gas->wall_outflow_scale * gas_eval_disc_flux(xi, tanh_xi, q) * inverse_r2;
    outflow_over_r = fm_select(r2 > 0.0, outflow_over_r, 0.0);
    double ux = g * jet[0] + outflow_over_r * pos[0], uy = g * jet[1] + outflow_over_r * pos[1];
    /* below a bow shock (whose standoff is then H) the layer's velocities are u2/u1 times these: the mass flux
     * rho u of the subsonic region, carried at the compressed density rho2 = rho1 u1/u2 (a factor 1: the same bits) */
    double layer = fm_select(gas->shock_standoff > 0.0, gas->shock_velocity_ratio, 1.0);
    u[0] = fm_select(in_region, layer * ux, jet[0]);
    u[1] = fm_select(in_region, layer * uy, jet[1]);
    u[2] = fm_select(in_region, layer * (g * jet[2]), jet[2]);
}

/* The gas's density, kinematic viscosity and static temperature (over the free jet's) at a point. */
struct gas_local {
    double density;             /* kg/m3 */
    double kinematic_viscosity; /* m2/s */
    double temperature_ratio;   /* T / gas_temperature: 1 in the free jet, T2/T1 below a bow shock */
};

/* The free jet's: [jet] gas_density and gas_viscosity. */
FM_INLINE struct gas_local gas_eval_free(const struct dem_gas_field *gas)
{
    struct gas_local local = {gas->density, gas->kinematic_viscosity, 1.0};
    return local;
}

/* At pos: in the layer below a bow shock (the wall region, whose top is the shock) the density rho2 =
 * shock_density_ratio rho1 and the dynamic viscosity mu2 = shock_viscosity_ratio mu1 (Sutherland's at T2), so nu2 =
 * nu1 mu2/mu1 / (rho2/rho1); elsewhere the free jet's (the same bits). */
FM_INLINE struct gas_local gas_eval_local(const struct dem_gas_field *gas, const double pos[3])
{
    int in_layer = (pos[2] > gas->wall_z - gas->stagnation_height) & (gas->shock_standoff > 0.0);
    double compression = fm_select(in_layer, gas->shock_density_ratio, 1.0);
    double viscosity = fm_select(in_layer, gas->shock_viscosity_ratio, 1.0);
    struct gas_local local = {compression * gas->density, gas->kinematic_viscosity * viscosity / compression,
                              fm_select(in_layer, gas->shock_temperature_ratio, 1.0)};
    return local;
}

/* Gas velocity u[3] at pos[3] for DEM_JET_BICKLEY (with its wall region) and DEM_JET_UNIFORM (DEM_JET_NONE:
 * zero). */
FM_INLINE void gas_eval_velocity(const struct dem_gas_field *gas, const double pos[3], double u[3])
{
    double jet[3];
    /* in the jet's frame: its axis is at the nozzle's (x, y), which a [path] moves */
    const double local[3] = {pos[0] - gas->axis_x, pos[1] - gas->axis_y, pos[2]};
    gas_eval_wall(gas, local, jet);
    int bickley = gas->model == DEM_JET_BICKLEY, uniform = gas->model == DEM_JET_UNIFORM;
    u[0] = fm_select(bickley, jet[0], 0.0);
    u[1] = fm_select(bickley, jet[1], 0.0);
    u[2] = fm_select(bickley, jet[2], fm_select(uniform, gas->uniform_velocity, 0.0));
}

/* Re^0.6459 of Eq. (25) at Reynolds number `reynolds`; shared by the drag and its slope. */
FM_INLINE double gas_eval_reynolds_power(double reynolds)
{
    return fm_pow(reynolds, HL_STOKES_EXPONENT);
}

/* Henderson's C_D (dem/drag_henderson.h) times the slip s, at the slip's Mach number against the local speed of
 * sound sqrt(gamma R T), T the free jet's gas_temperature times the layer's T2/T1, with the sphere at the gas's
 * temperature (Tw/T = 1: the drag does not carry the particles' own temperature; at the slip Mach numbers of a
 * cold-spray jet, 0.8-1.2, Tw/T from 0.5 to 3 moves C_D by at most 1.8 %, docs/physics.md "Drag in the jet").
 * s below 1e-9 m/s counts as 1e-9 m/s: C_D s keeps its finite limit as s -> 0 (24 nu/d over one plus the
 * rarefied term), where the drag itself vanishes. */
FM_INLINE double gas_eval_henderson_times_slip(const struct dem_gas_field *gas, struct gas_local local, double diameter,
                                               double slip)
{
    double s = fmax(slip, 1e-9);
    double sound = sqrt(gas->gas_gamma * gas->gas_constant * gas->gas_temperature * local.temperature_ratio);
    double reynolds = diameter * s / local.kinematic_viscosity;
    return henderson_drag_coefficient(reynolds, s / sound, 1.0, gas->gas_gamma) * s;
}

/* C_D * slip (m/s) for slip > 0, given Re and Re^0.6459: 24 nu / d in place of 24 / Re * slip, so that the
 * Stokes part needs no division by the slip.  Henderson's law branches once on the law (a loop-invariant test:
 * the loops of the other laws keep their selects). */
FM_INLINE double gas_eval_drag_coefficient_times_slip_in(const struct dem_gas_field *gas, struct gas_local local,
                                                         double diameter, double slip, double reynolds,
                                                         double reynolds_power)
{
    if (gas->drag == DEM_DRAG_HENDERSON)
        return gas_eval_henderson_times_slip(gas, local, diameter, slip);
    double stokes_part = 24.0 * local.kinematic_viscosity / diameter;
    double haider_levenspiel = stokes_part * (1.0 + HL_STOKES_CORRECTION * reynolds_power) +
                               HL_NEWTON_COEFFICIENT * slip * reynolds / (reynolds + HL_NEWTON_REYNOLDS);
    return fm_select(gas->drag == DEM_DRAG_STOKES, stokes_part, haider_levenspiel);
}

FM_INLINE double gas_eval_drag_coefficient_times_slip(const struct dem_gas_field *gas, double diameter, double slip,
                                                      double reynolds, double reynolds_power)
{
    return gas_eval_drag_coefficient_times_slip_in(gas, gas_eval_free(gas), diameter, slip, reynolds, reynolds_power);
}

FM_INLINE double gas_eval_reynolds_in(struct gas_local local, double diameter, double slip)
{
    return diameter * slip / local.kinematic_viscosity;
}

FM_INLINE double gas_eval_reynolds(const struct dem_gas_field *gas, double diameter, double slip)
{
    return gas_eval_reynolds_in(gas_eval_free(gas), diameter, slip);
}

/* Eq. (24): F = 1/2 rho_f (pi R^2) C_D(Re) |u - v| (u - v), Re = d |u - v| / nu_f, with the slip and Re^0.6459
 * already known, in the gas state `local`.  No slip: no drag (and no 0/0 in Re). */
FM_INLINE void gas_eval_drag_from_slip_in(const struct dem_gas_field *gas, struct gas_local local, double diameter,
                                          const double relative[3], double slip, double reynolds_power, double f[3])
{
    double frontal_area = 0.25 * GAS_PI * diameter * diameter;
    double reynolds = gas_eval_reynolds_in(local, diameter, slip);
    double factor = 0.5 * local.density * frontal_area *
                    gas_eval_drag_coefficient_times_slip_in(gas, local, diameter, slip, reynolds, reynolds_power);
    factor = fm_select((slip > 0.0) & (gas->model != DEM_JET_NONE), factor, 0.0);
    for (int k = 0; k < 3; k++)
        f[k] = factor * relative[k];
}

/* The same in the free jet's gas. */
FM_INLINE void gas_eval_drag_from_slip(const struct dem_gas_field *gas, double diameter, const double relative[3],
                                       double slip, double reynolds_power, double f[3])
{
    gas_eval_drag_from_slip_in(gas, gas_eval_free(gas), diameter, relative, slip, reynolds_power, f);
}

FM_INLINE double gas_eval_slip(const double v[3], const double u[3], double relative[3])
{
    for (int k = 0; k < 3; k++)
        relative[k] = u[k] - v[k];
    return sqrt(relative[0] * relative[0] + relative[1] * relative[1] + relative[2] * relative[2]);
}

/* Drag force f[3] on a sphere of diameter d at v[3] in gas at u[3] in the gas state `local` (Eq. 24). */
FM_INLINE void gas_eval_drag_in(const struct dem_gas_field *gas, struct gas_local local, double diameter,
                                const double v[3], const double u[3], double f[3])
{
    double relative[3];
    double slip = gas_eval_slip(v, u, relative);
    double power = gas_eval_reynolds_power(gas_eval_reynolds_in(local, diameter, slip));
    gas_eval_drag_from_slip_in(gas, local, diameter, relative, slip, power, f);
}

/* The same in the free jet's gas. */
FM_INLINE void gas_eval_drag(const struct dem_gas_field *gas, double diameter, const double v[3], const double u[3],
                             double f[3])
{
    gas_eval_drag_in(gas, gas_eval_free(gas), diameter, v, u, f);
}

/* dF/ds of the drag magnitude F(s) = 1/2 rho_f A C_D(Re(s)) s^2, A = pi d^2/4, Re = d s / nu.
 * Since dRe/ds = Re/s, dF/ds = (F/s) (2 + dlnC_D/dlnRe) = 1/2 rho_f A s (2 C_D + Re C_D').
 * Haider-Levenspiel, C_D = 24/Re + 24 a Re^(b-1) + c Re/(Re + k):
 *   2 C_D + Re C_D' = 24/Re + 24 a (1 + b) Re^(b-1) + c Re (2 Re + 3 k)/(Re + k)^2,
 * and multiplying by s (= Re nu / d) removes the 1/Re: every term stays finite as s -> 0, where
 * dF/ds -> 1/2 rho_f A 24 nu / d = 3 pi mu d, the Stokes value.  Stokes alone: dF/ds = 3 pi mu d.
 * reynolds_power is Re^b at this slip (any value when slip is 0). */
FM_INLINE double gas_eval_drag_slope_in(const struct dem_gas_field *gas, struct gas_local local, double diameter,
                                        double slip, double reynolds_power)
{
    double frontal_area = 0.25 * GAS_PI * diameter * diameter;
    if (gas->drag == DEM_DRAG_HENDERSON) { /* a forward difference of (C_D s) s: only the response time uses it */
        double step = 1e-6 * fmax(slip, 1.0), ahead = slip + step;
        double change = gas_eval_henderson_times_slip(gas, local, diameter, ahead) * ahead -
                        gas_eval_henderson_times_slip(gas, local, diameter, slip) * slip;
        return 0.5 * local.density * frontal_area * change / step;
    }
    double stokes_part = 24.0 * local.kinematic_viscosity / diameter; /* 24/Re * s */
    double reynolds = gas_eval_reynolds_in(local, diameter, slip);
    double newton_denominator = reynolds + HL_NEWTON_REYNOLDS;
    double haider_levenspiel =
        stokes_part + (stokes_part * HL_STOKES_CORRECTION * (1.0 + HL_STOKES_EXPONENT) * reynolds_power +
                       HL_NEWTON_COEFFICIENT * slip * reynolds * (2.0 * reynolds + 3.0 * HL_NEWTON_REYNOLDS) /
                           (newton_denominator * newton_denominator));
    int haider_levenspiel_law = (gas->drag == DEM_DRAG_HAIDER_LEVENSPIEL) & (slip > 0.0);
    double bracket_times_slip = fm_select(haider_levenspiel_law, haider_levenspiel, stokes_part);
    return 0.5 * local.density * frontal_area * bracket_times_slip;
}

FM_INLINE double gas_eval_drag_slope(const struct dem_gas_field *gas, double diameter, double slip,
                                     double reynolds_power)
{
    return gas_eval_drag_slope_in(gas, gas_eval_free(gas), diameter, slip, reynolds_power);
}

/* m / |dF/dv| (s) in the gas state `local`, INFINITY for DEM_JET_NONE or no gas density: see
 * dem_gas_response_time. */
FM_INLINE double gas_eval_response_time_in(const struct dem_gas_field *gas, struct gas_local local, double density,
                                           double diameter, double slip, double reynolds_power)
{
    double slope = gas_eval_drag_slope_in(gas, local, diameter, slip, reynolds_power);
    double mass = density * GAS_PI * diameter * diameter * diameter / 6.0;
    int no_drag = (gas->model == DEM_JET_NONE) | !(slope > 0.0); /* bitwise: no branch, so loops vectorise */
    double response_time = mass / slope;
    return fm_select(no_drag, INFINITY, response_time);
}

/* The same in the free jet's gas. */
FM_INLINE double gas_eval_response_time(const struct dem_gas_field *gas, double density, double diameter, double slip,
                                        double reynolds_power)
{
    return gas_eval_response_time_in(gas, gas_eval_free(gas), density, diameter, slip, reynolds_power);
}

#endif
