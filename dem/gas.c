/* The carrier gas, Mukherjee & Zohdi Section 2.3: drag Eq. (24) with the Haider-Levenspiel coefficient
 * Eq. (25) (or Stokes), and the self-similar jet Eqs. (26)-(27) with the DESIGN.md erratum for Eq. (27).
 * One-way coupling: the gas velocity is a prescribed field. */
#include "dem/gas.h"

#include <math.h>

/* M_PI is not declared in strict C17 with _POSIX_C_SOURCE. */
#define PI 3.14159265358979323846

/* Haider & Levenspiel (1989) sphere constants, Eq. (25). */
#define HL_STOKES_CORRECTION 0.1806
#define HL_STOKES_EXPONENT 0.6459
#define HL_NEWTON_COEFFICIENT 0.4251
#define HL_NEWTON_REYNOLDS 6880.95

/* Eq. (25): C_D = 24/Re (1 + 0.1806 Re^0.6459) + 0.4251 / (1 + 6880.95/Re). */
double drag_coefficient_haider_levenspiel(double reynolds)
{
    return 24.0 / reynolds * (1.0 + HL_STOKES_CORRECTION * pow(reynolds, HL_STOKES_EXPONENT)) +
           HL_NEWTON_COEFFICIENT / (1.0 + HL_NEWTON_REYNOLDS / reynolds);
}

/* C_D * slip (m/s) for slip > 0.  Written with 24 nu / d in place of 24 / Re * slip so that the Stokes
 * part needs no division by the slip. */
static double drag_coefficient_times_slip(const struct gas_field *gas, double diameter, double slip)
{
    double stokes_part = 24.0 * gas->kinematic_viscosity / diameter;
    if (gas->drag == DRAG_STOKES)
        return stokes_part;
    double reynolds = diameter * slip / gas->kinematic_viscosity;
    return stokes_part * (1.0 + HL_STOKES_CORRECTION * pow(reynolds, HL_STOKES_EXPONENT)) +
           HL_NEWTON_COEFFICIENT * slip * reynolds / (reynolds + HL_NEWTON_REYNOLDS);
}

/* Eq. (24): F = 1/2 rho_f (pi R^2) C_D(Re) |u - v| (u - v), Re = d |u - v| / nu_f. */
void gas_drag_force(const struct gas_field *gas, double diameter, const double v[3], const double u[3],
                    double f[3])
{
    double relative[3] = {u[0] - v[0], u[1] - v[1], u[2] - v[2]};
    double slip = sqrt(relative[0] * relative[0] + relative[1] * relative[1] + relative[2] * relative[2]);
    f[0] = f[1] = f[2] = 0.0;
    if (gas->model == JET_NONE || !(slip > 0.0))
        return; /* no gas, or no slip: no drag (and no 0/0 in Re) */
    double frontal_area = 0.25 * PI * diameter * diameter;
    double factor = 0.5 * gas->density * frontal_area * drag_coefficient_times_slip(gas, diameter, slip);
    for (int k = 0; k < 3; k++)
        f[k] = factor * relative[k];
}

/* sech^2(xi) and tanh(xi) from q = exp(-2|xi|) <= 1, which cannot overflow (cosh(xi) does for
 * |xi| > ~710): sech^2 = 4q/(1+q)^2, tanh = sign(xi) (1-q)/(1+q). */
static void sech2_tanh(double xi, double *sech2, double *tanh_xi)
{
    double q = exp(-2.0 * fabs(xi));
    double inverse_one_plus_q = 1.0 / (1.0 + q);
    *sech2 = 4.0 * q * inverse_one_plus_q * inverse_one_plus_q;
    *tanh_xi = copysign((1.0 - q) * inverse_one_plus_q, xi);
}

/* Self-similar jet at streamwise distance x > 0 from the virtual origin and radius r: Eq. (26)
 * u = C1 / x^(1/3) sech^2(xi), and Eq. (27) with the erratum, v = C2 / x^(2/3) (2 xi sech^2 xi - tanh xi),
 * xi = C3 r / x^(2/3).  With entrain = 0 (potential core) the radial part is left out. */
static void bickley_profile(const struct gas_field *gas, double x, double r, int entrain, double *axial,
                            double *radial)
{
    double cube_root = cbrt(x);
    double x_two_thirds = cube_root * cube_root;
    double xi = gas->c3 * r / x_two_thirds;
    double sech2, tanh_xi;
    sech2_tanh(xi, &sech2, &tanh_xi);
    *axial = gas->c1 / cube_root * sech2;
    *radial = entrain ? gas->c2 / x_two_thirds * (2.0 * xi * sech2 - tanh_xi) : 0.0;
}

/* The jet in the spray frame.  Downstream of the potential core the profile of Eqs. (26)-(27) applies at
 * x = z + virtual_origin.  Inside the core (z < core_length), and anywhere behind the virtual origin, the
 * profile of z = core_length is used without entrainment.  If even that station lies at or behind the
 * virtual origin (virtual_origin + core_length <= 0) the profile is singular: the gas is taken as still
 * there (the parameter layer is expected to refuse such a jet). */
static void bickley_velocity(const struct gas_field *gas, const double pos[3], double u[3])
{
    double r = sqrt(pos[0] * pos[0] + pos[1] * pos[1]);
    double x = pos[2] + gas->virtual_origin;
    int entrain = 1;
    if (pos[2] < gas->core_length || !(x > 0.0)) {
        x = gas->core_length + gas->virtual_origin;
        entrain = 0;
    }
    u[0] = u[1] = u[2] = 0.0;
    if (!(x > 0.0))
        return;
    double axial, radial;
    bickley_profile(gas, x, r, entrain, &axial, &radial);
    u[2] = axial;
    if (r > 0.0) {
        u[0] = radial * pos[0] / r; /* radial unit vector (x, y)/r; none on the axis */
        u[1] = radial * pos[1] / r;
    }
}

void gas_velocity(const struct gas_field *gas, const double x[3], double u[3])
{
    switch (gas->model) {
    case JET_BICKLEY:
        bickley_velocity(gas, x, u);
        return;
    case JET_UNIFORM:
        u[0] = 0.0;
        u[1] = 0.0;
        u[2] = gas->uniform_velocity;
        return;
    case JET_NONE:
    default:
        u[0] = u[1] = u[2] = 0.0;
        return;
    }
}

/* dF/ds of the drag magnitude F(s) = 1/2 rho_f A C_D(Re(s)) s^2, A = pi d^2/4, Re = d s / nu.
 * Since dRe/ds = Re/s, dF/ds = (F/s) (2 + dlnC_D/dlnRe) = 1/2 rho_f A s (2 C_D + Re C_D').
 * Haider-Levenspiel, C_D = 24/Re + 24 a Re^(b-1) + c Re/(Re + k):
 *   2 C_D + Re C_D' = 24/Re + 24 a (1 + b) Re^(b-1) + c Re (2 Re + 3 k)/(Re + k)^2,
 * and multiplying by s (= Re nu / d) removes the 1/Re: every term stays finite as s -> 0, where
 * dF/ds -> 1/2 rho_f A 24 nu / d = 3 pi mu d, the Stokes value.  Stokes alone: dF/ds = 3 pi mu d. */
static double drag_magnitude_slope(const struct gas_field *gas, double diameter, double slip)
{
    double frontal_area = 0.25 * PI * diameter * diameter;
    double stokes_part = 24.0 * gas->kinematic_viscosity / diameter; /* 24/Re * s */
    double bracket_times_slip = stokes_part;
    if (gas->drag == DRAG_HAIDER_LEVENSPIEL && slip > 0.0) {
        double reynolds = diameter * slip / gas->kinematic_viscosity;
        double newton_denominator = reynolds + HL_NEWTON_REYNOLDS;
        bracket_times_slip +=
            stokes_part * HL_STOKES_CORRECTION * (1.0 + HL_STOKES_EXPONENT) * pow(reynolds, HL_STOKES_EXPONENT) +
            HL_NEWTON_COEFFICIENT * slip * reynolds * (2.0 * reynolds + 3.0 * HL_NEWTON_REYNOLDS) /
                (newton_denominator * newton_denominator);
    }
    return 0.5 * gas->density * frontal_area * bracket_times_slip;
}

/* m / |dF/dv|: for a drag along the slip, dF/dv has eigenvalues -dF/ds (along the slip) and -F/s (across
 * it); dF/ds >= F/s for C_D falling no faster than 1/Re, so dF/ds sets the stiffest time.  Stokes:
 * tau = rho d^2 / (18 mu). */
double gas_response_time(const struct gas_field *gas, double density, double diameter, double slip)
{
    if (gas->model == JET_NONE)
        return INFINITY;
    double slope = drag_magnitude_slope(gas, diameter, fabs(slip));
    if (!(slope > 0.0))
        return INFINITY; /* no gas density: no drag */
    double mass = density * PI * diameter * diameter * diameter / 6.0;
    return mass / slope;
}
