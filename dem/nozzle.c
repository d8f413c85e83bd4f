/* The de Laval nozzle (its API in dem/dem.h, docs/physics.md "Nozzle"): quasi-1-D isentropic flow, the shock check at
 * the exit, and the particles' acceleration and heating along the axis integrated with CVODE (BDF, Newton, dense). */
#include "dem/dem.h"

#include <cvode/cvode.h>
#include <math.h>
#include <nvector/nvector_serial.h>
#include <stdlib.h>
#include <string.h>
#include <sundials/sundials_context.h>
#include <sunlinsol/sunlinsol_dense.h>
#include <sunmatrix/sunmatrix_dense.h>

#include "core/error.h"
#include "core/log.h"
#include "dem/drag_henderson.h"

/* ---------------------------------------------------------------- gases */

/* gamma and R = R_u / M (R_u = 8.314462618 J/(mol K), CODATA 2018; molar masses IUPAC); Sutherland constants of
 * N2 and air from White, Viscous Fluid Flow (3rd ed.), Table 1-2; of helium mu(273.15 K) = 18.7 uPa s (NIST
 * Chemistry WebBook) with S = 79.4 K, the value of the usual tables of Sutherland constants (attributed to Crane
 * Co., Flow of Fluids, Technical Paper 410; the original not checked here); Prandtl numbers at room temperature
 * (Incropera, Table A.4).  tests/test_nozzle.c holds the viscosities at 300 K within 1 % of the reference
 * correlations'.  Sutherland's law underestimates helium's viscosity far below room temperature (about 20 % at a helium
 * nozzle's 74 K exit, a review with a T^0.68 fit; 0.2 % on the exit speed). */
static const struct dem_nozzle_gas_properties gases[] = {
    [DEM_NOZZLE_N2] = {"n2", 1.4, 296.80, 1.663e-5, 273.0, 107.0, 0.72},
    [DEM_NOZZLE_HE] = {"he", 5.0 / 3.0, 2077.3, 1.870e-5, 273.15, 79.4, 0.68},
    [DEM_NOZZLE_AIR] = {"air", 1.4, 287.05, 1.716e-5, 273.0, 111.0, 0.71},
};

const struct dem_nozzle_gas_properties *dem_nozzle_gas_properties(enum dem_nozzle_gas gas)
{
    return &gases[gas];
}

double dem_nozzle_viscosity(const struct dem_nozzle_gas_properties *gas, double temperature)
{
    double ratio = temperature / gas->t_ref;
    return gas->mu_ref * ratio * sqrt(ratio) * (gas->t_ref + gas->sutherland) / (temperature + gas->sutherland);
}

/* ---------------------------------------------------------------- isentropic flow */

/* 1 + (gamma - 1)/2 M^2: T0/T (Anderson Eq. 3.28) */
static double stagnation_ratio(double mach, double gamma)
{
    return 1.0 + 0.5 * (gamma - 1.0) * mach * mach;
}

double dem_nozzle_area_ratio(double mach, double gamma)
{
    double exponent = 0.5 * (gamma + 1.0) / (gamma - 1.0);
    return pow(2.0 / (gamma + 1.0) * stagnation_ratio(mach, gamma), exponent) / mach;
}

/* Newton's method on ln(A/A*) - ln(ratio), kept inside the bracket of the branch (bisection when a step leaves it):
 * d ln(A/A*)/dM = (M^2 - 1) / (M (1 + (gamma-1)/2 M^2)). */
double dem_nozzle_mach(double area_ratio, double gamma, int supersonic)
{
    if (!(area_ratio > 1.0))
        return 1.0;
    double target = log(area_ratio);
    double low = supersonic ? 1.0 : 0.0, high = 1.0;
    while (supersonic && log(dem_nozzle_area_ratio(high, gamma)) < target)
        high *= 2.0;
    double mach = supersonic ? 0.5 * (low + high) : 0.5;
    for (int iteration = 0; iteration < 200; iteration++) {
        double residual = log(dem_nozzle_area_ratio(mach, gamma)) - target;
        /* ln(A/A*) falls with M below 1 and rises above it */
        int above = supersonic ? residual > 0.0 : residual < 0.0;
        if (above)
            high = mach;
        else
            low = mach;
        double slope = (mach * mach - 1.0) / (mach * stagnation_ratio(mach, gamma));
        double next = mach - residual / slope;
        if (!(next > low && next < high))
            next = 0.5 * (low + high);
        if (fabs(next - mach) <= 1e-15 * mach) {
            mach = next;
            break;
        }
        mach = next;
    }
    return mach;
}

static double throat_x(const struct dem_nozzle *n)
{
    return n->convergent_length;
}

/* Conical parts: the diameter linear in x on each. */
static double diameter_at(const struct dem_nozzle *n, double x)
{
    double xt = throat_x(n);
    if (x <= xt)
        return n->inlet_diameter + (n->throat_diameter - n->inlet_diameter) * (x / n->convergent_length);
    double s = fmin((x - xt) / n->divergent_length, 1.0);
    return n->throat_diameter + (n->exit_diameter - n->throat_diameter) * s;
}

/* The static state of Mach number M from the stagnation state (Anderson Eqs. 3.28-3.31, p = rho R T). */
static void station_of_mach(const struct dem_nozzle *n, double mach, struct dem_nozzle_station *out)
{
    const struct dem_nozzle_gas_properties *gas = &n->properties;
    double ratio = stagnation_ratio(mach, gas->gamma);
    out->mach = mach;
    out->temperature = n->stagnation_temperature / ratio;
    out->pressure = n->stagnation_pressure * pow(ratio, -gas->gamma / (gas->gamma - 1.0));
    out->density = out->pressure / (gas->gas_constant * out->temperature);
    out->velocity = mach * sqrt(gas->gamma * gas->gas_constant * out->temperature);
}

void dem_nozzle_station_at(const struct dem_nozzle *n, double x, struct dem_nozzle_station *out)
{
    double d = diameter_at(n, x), ratio = d / n->throat_diameter;
    station_of_mach(n, dem_nozzle_mach(ratio * ratio, n->properties.gamma, x > throat_x(n)), out);
    out->x = x;
    out->diameter = d;
}

/* ---------------------------------------------------------------- particle drag and heating */

/* Henderson (1976): dem/drag_henderson.h. */
double dem_nozzle_drag_coefficient(double reynolds, double mach, double temperature_ratio, double gamma)
{
    return henderson_drag_coefficient(reynolds, mach, temperature_ratio, gamma);
}

/* dv/dx = F / (m v), dT_p/dx = Q / (m c_p v), dt/dx = 1 / v with the drag F = rho C_D (pi d^2/8) |u - v| (u - v)
 * and the convective heat flow Q = Nu k pi d (T_r - T_p): Ranz & Marshall (1952) Nu = 2 + 0.6 Re^(1/2) Pr^(1/3),
 * k = mu c_p,gas / Pr, towards the recovery temperature T_r = T + r (u - v)^2 / (2 c_p,gas) with r = Pr^(1/3)
 * (turbulent recovery factor; White, Viscous Fluid Flow, Sec. 7-4). */
void dem_nozzle_particle_rates(const struct dem_nozzle *n, double diameter, double x, const double y[3], double dydx[3])
{
    const struct dem_nozzle_gas_properties *gas = &n->properties;
    struct dem_nozzle_station here;
    dem_nozzle_station_at(n, x, &here);
    double v = y[0], temperature = y[1], slip = here.velocity - v, speed = fabs(slip);
    double mu = dem_nozzle_viscosity(gas, here.temperature);
    double sound = sqrt(gas->gamma * gas->gas_constant * here.temperature);
    double mass = n->particle_density * M_PI * diameter * diameter * diameter / 6.0;
    double force = 0.0, reynolds = here.density * speed * diameter / mu;
    if (speed > 0.0) {
        double cd = dem_nozzle_drag_coefficient(reynolds, speed / sound, temperature / here.temperature, gas->gamma);
        force = 0.125 * M_PI * diameter * diameter * here.density * cd * speed * slip;
    }
    double cp_gas = gas->gamma * gas->gas_constant / (gas->gamma - 1.0);
    double conductivity = mu * cp_gas / gas->prandtl, pr_third = cbrt(gas->prandtl);
    double nusselt = 2.0 + 0.6 * sqrt(reynolds) * pr_third;
    double recovery = here.temperature + pr_third * slip * slip / (2.0 * cp_gas);
    double heat = nusselt * conductivity * M_PI * diameter * (recovery - temperature);
    dydx[0] = force / (mass * v);
    dydx[1] = heat / (mass * n->particle_specific_heat * v);
    dydx[2] = 1.0 / v;
}

/* ---------------------------------------------------------------- CVODE along the axis */

struct particle_problem {
    const struct dem_nozzle *nozzle;
    double diameter;
};

static int particle_rhs(sunrealtype x, N_Vector y, N_Vector ydot, void *data)
{
    const struct particle_problem *p = data;
    const double *state = N_VGetArrayPointer(y);
    if (!(state[0] > 0.0))
        return 1; /* a recoverable failure: CVODE retries with a smaller step */
    dem_nozzle_particle_rates(p->nozzle, p->diameter, x, state, N_VGetArrayPointer(ydot));
    return 0;
}

struct integrator {
    SUNContext context;
    N_Vector state;
    SUNMatrix matrix;
    SUNLinearSolver linear;
    void *cvode;
};

static void integrator_free(struct integrator *it)
{
    CVodeFree(&it->cvode);
    SUNLinSolFree(it->linear);
    SUNMatDestroy(it->matrix);
    N_VDestroy(it->state);
    SUNContext_Free(&it->context);
}

/* Relative tolerance 1e-10, absolute 1e-8 m/s, 1e-8 K and 1e-14 s: the exit state to about 1e-8 (tests/test_nozzle.c
 * compares it with a fine RK4 integration). */
static int integrator_init(struct integrator *it, struct particle_problem *problem, const double y0[3])
{
    memset(it, 0, sizeof *it);
    if (SUNContext_Create(NULL, &it->context) != 0)
        return CV_MEM_FAIL; /* an allocation failed (-1 is CV_TOO_MUCH_WORK's flag) */
    it->state = N_VNew_Serial(3, it->context);
    it->matrix = SUNDenseMatrix(3, 3, it->context);
    it->cvode = CVodeCreate(CV_BDF, it->context);
    if (!it->state || !it->matrix || !it->cvode)
        return CV_MEM_FAIL;
    it->linear = SUNLinSol_Dense(it->state, it->matrix, it->context);
    if (!it->linear)
        return CV_MEM_FAIL;
    memcpy(N_VGetArrayPointer(it->state), y0, 3 * sizeof *y0);
    N_Vector abstol = N_VClone(it->state);
    if (!abstol)
        return CV_MEM_FAIL;
    double *a = N_VGetArrayPointer(abstol);
    a[0] = 1e-8, a[1] = 1e-8, a[2] = 1e-14;
    int flag = CVodeInit(it->cvode, particle_rhs, 0.0, it->state);
    if (flag == CV_SUCCESS)
        flag = CVodeSVtolerances(it->cvode, 1e-10, abstol);
    N_VDestroy(abstol);
    if (flag == CV_SUCCESS)
        flag = CVodeSetLinearSolver(it->cvode, it->linear, it->matrix);
    if (flag == CV_SUCCESS)
        flag = CVodeSetMaxNumSteps(it->cvode, 500000);
    if (flag == CV_SUCCESS)
        flag = CVodeSetErrFile(it->cvode, NULL);
    if (flag == CV_SUCCESS)
        flag = CVodeSetUserData(it->cvode, problem);
    return flag;
}

/* Integrate to x_end, stopping exactly there (the gas's slope has a kink at the throat: each part on its own). */
static int integrate_to(struct integrator *it, double x_end)
{
    int flag = CVodeSetStopTime(it->cvode, x_end);
    sunrealtype reached = 0.0;
    if (flag == CV_SUCCESS)
        flag = CVode(it->cvode, x_end, it->state, &reached, CV_NORMAL);
    return flag == CV_TSTOP_RETURN ? CV_SUCCESS : flag;
}

int dem_nozzle_particle_exit(const struct dem_nozzle *n, double diameter, double out[3])
{
    struct particle_problem problem = {n, diameter};
    struct dem_nozzle_station inlet;
    dem_nozzle_station_at(n, 0.0, &inlet);
    const double y0[3] = {inlet.velocity, n->particle_temperature, 0.0};
    struct integrator it;
    int flag = integrator_init(&it, &problem, y0);
    if (flag == CV_SUCCESS)
        flag = integrate_to(&it, throat_x(n));
    if (flag == CV_SUCCESS)
        flag = CVodeReInit(it.cvode, throat_x(n), it.state);
    if (flag == CV_SUCCESS)
        flag = integrate_to(&it, n->convergent_length + n->divergent_length);
    if (flag == CV_SUCCESS)
        memcpy(out, N_VGetArrayPointer(it.state), 3 * sizeof *out);
    integrator_free(&it);
    if (flag != CV_SUCCESS)
        SC_FAIL(SC_ESIM, "nozzle: CVODE failed for the particle of diameter %g m (flag %d: %s)", diameter, flag,
                CVodeGetReturnFlagName(flag));
    return SC_OK;
}

/* ---------------------------------------------------------------- the whole nozzle */

/* A normal shock standing at the exit raises the pressure to p_e (1 + 2 gamma/(gamma+1) (M_e^2 - 1)) (Anderson
 * Eq. 3.57); an ambient pressure above that pushes the shock into the divergent part, where the quasi-1-D
 * isentropic solution no longer holds. */
static int check_exit_pressure(const struct dem_nozzle *n)
{
    double gamma = n->properties.gamma, mach = n->exit.mach;
    double behind_shock = n->exit.pressure * (1.0 + 2.0 * gamma / (gamma + 1.0) * (mach * mach - 1.0));
    if (n->ambient_pressure > behind_shock)
        SC_FAIL(SC_EINPUT,
                "a normal shock would stand inside the divergent part: the ambient pressure %g Pa is above "
                "%g Pa, the pressure behind a normal shock at the exit (exit Mach %.3f, exit pressure %g Pa, "
                "stagnation pressure %g Pa); raise stagnation_pressure or lower exit_diameter",
                n->ambient_pressure, behind_shock, mach, n->exit.pressure, n->stagnation_pressure);
    return SC_OK;
}

/* Summerfield's criterion (Summerfield, Foster & Swan 1954): an over-expanded nozzle's boundary layer separates from
 * the divergent wall where the wall pressure falls to about 0.4 of the ambient (0.25-0.4 in later tests).  Short of
 * the shock check above, so the solution is kept, with a warning. */
int dem_nozzle_may_separate(const struct dem_nozzle *n)
{
    return n->exit.pressure < 0.4 * n->ambient_pressure;
}

int dem_nozzle_solve(struct dem_nozzle *n, double d_small, double d_large)
{
    double length = n->convergent_length + n->divergent_length;
    dem_nozzle_station_at(n, length, &n->exit);
    SC_TRY(check_exit_pressure(n));
    if (dem_nozzle_may_separate(n))
        log_warn("nozzle: exit pressure %.3g Pa is %.2f of the ambient %.3g Pa, below Summerfield's 0.4: the flow may "
                 "separate from the divergent wall before the exit, which the quasi-1-D model does not capture (its "
                 "exit state is that of an attached flow); raise stagnation_pressure or lower exit_diameter",
                 n->exit.pressure, n->exit.pressure / n->ambient_pressure, n->ambient_pressure);
    for (int k = 0; k < DEM_NOZZLE_PROFILE_POINTS; k++)
        dem_nozzle_station_at(n, length * k / (DEM_NOZZLE_PROFILE_POINTS - 1), &n->profile[k]);
    double ratio = d_large > d_small ? d_large / d_small : 1.0;
    for (int k = 0; k < DEM_NOZZLE_TABLE_ROWS; k++) {
        double d = d_small * pow(ratio, (double)k / (DEM_NOZZLE_TABLE_ROWS - 1)), out[3];
        SC_TRY(dem_nozzle_particle_exit(n, d, out));
        n->table_diameter[k] = d;
        n->table_velocity[k] = out[0];
        n->table_temperature[k] = out[1];
        n->table_time[k] = out[2];
    }
    return SC_OK;
}

void dem_nozzle_lookup(const struct dem_nozzle *n, double diameter, double *velocity, double *temperature)
{
    const double *d = n->table_diameter;
    int last = DEM_NOZZLE_TABLE_ROWS - 1;
    if (!(diameter > d[0]) || !(d[last] > d[0])) {
        *velocity = n->table_velocity[0], *temperature = n->table_temperature[0];
        return;
    }
    if (diameter >= d[last]) {
        *velocity = n->table_velocity[last], *temperature = n->table_temperature[last];
        return;
    }
    int k = 0;
    while (k + 1 < last && d[k + 1] < diameter)
        k++;
    double w = log(diameter / d[k]) / log(d[k + 1] / d[k]);
    *velocity = n->table_velocity[k] + w * (n->table_velocity[k + 1] - n->table_velocity[k]);
    *temperature = n->table_temperature[k] + w * (n->table_temperature[k + 1] - n->table_temperature[k]);
}
