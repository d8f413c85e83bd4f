/* Stress update of one material point, Tang Appendix A (Eqs. A1-A11) with the energy equation of Section 3.5.2
 * (Eqs. 3.38-3.43), adiabatic heating (Eq. 3.44), the SCG melt (Eq. 2.9) and Zhang's artificial bulk viscosity.
 *
 * Symmetric tensors are stored xx, yy, zz, yz, xz, xy with tensor components; a double contraction a:b counts
 * every off-diagonal pair twice.  Differences from the printed appendix:
 * - The plastic strain increment is not the one-step linearisation of Eq. A6 but the root of the consistency
 *   condition with the rate-dependent PTW flow stress evaluated at the END of the step,
 *       f(d) = sigma* - 3 G d - sigma_y(eps_p + d, max(d/dt, rate_floor)) = 0,
 *   by a bracketed Newton iteration (PTW is steep in the rate in the shock regime, notes/mpm.md 2.1).
 * - The yield check uses sigma_y(eps_p, rate_floor): the smallest flow stress the point can have.
 * - The rate floor m->rate_floor stands for the plastic strain rate of an elastic or barely plastic point
 *   (PTW needs ln(gamma xi_dot / rate) finite; DESIGN.md "Impact (Tang)").
 * - Melting (T >= Tm(rho_new)) removes the deviatoric stress for either strength model; MPM_STRENGTH_ELASTIC
 *   never yields and reports yield_stress 0.
 * - The artificial bulk viscosity q is kept apart from the Cauchy stress (state->viscosity) and its work enters
 *   the internal energy after the EOS solve. */
#include "mpm/material.h"

#include <math.h>

#define NEWTON_MAX_ITER 100
#define NEWTON_FTOL     1e-10 /* |f| relative to sigma* */
#define NEWTON_XTOL     1e-13 /* bracket width in ln d (relative width of d) */

/* ---- tensor helpers (xx, yy, zz, yz, xz, xy) ---- */

/* a:b with the off-diagonal components counted twice. */
static double contract(const double a[6], const double b[6])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + 2.0 * (a[3] * b[3] + a[4] * b[4] + a[5] * b[5]);
}

/* Tang Eq. A5: sqrt(3/2 s:s). */
static double von_mises(const double s[6]) { return sqrt(1.5 * contract(s, s)); }

static void unpack(const double v[6], double t[3][3])
{
    t[0][0] = v[0], t[1][1] = v[1], t[2][2] = v[2];
    t[1][2] = t[2][1] = v[3];
    t[0][2] = t[2][0] = v[4];
    t[0][1] = t[1][0] = v[5];
}

/* Tang Eq. A2: sigma_R = sigma + sigma Omega^T + Omega sigma, Omega = W dt skew with W_yz, W_xz, W_xy given. */
static void jaumann_rotate(const double sigma[6], const double spin[3], double rotated[6])
{
    double s[3][3], w[3][3] = {{0.0}}, ws[3][3];
    unpack(sigma, s);
    w[1][2] = spin[0], w[2][1] = -spin[0];
    w[0][2] = spin[1], w[2][0] = -spin[1];
    w[0][1] = spin[2], w[1][0] = -spin[2];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            ws[i][j] = w[i][0] * s[0][j] + w[i][1] * s[1][j] + w[i][2] * s[2][j];
    /* sigma Omega^T = -sigma Omega = (Omega sigma)^T since sigma is symmetric and Omega skew */
    static const int row[6] = {0, 1, 2, 1, 0, 0}, col[6] = {0, 1, 2, 2, 2, 1};
    for (int k = 0; k < 6; k++)
        rotated[k] = sigma[k] + ws[row[k]][col[k]] + ws[col[k]][row[k]];
}

/* Tang Eq. A3: deviatoric part, trace/3 returned in *mean. */
static void deviator(const double t[6], double dev[6], double *mean)
{
    *mean = (t[0] + t[1] + t[2]) / 3.0;
    for (int k = 0; k < 6; k++)
        dev[k] = t[k] - (k < 3 ? *mean : 0.0);
}

/* ---- the consistent plastic strain increment ---- */

struct yield_problem {
    const struct mpm_material *m;
    double eps_p, dt, T, Tm, rho, G, trial;
    double previous_increment;   /* delta eps_p of the last step: the first guess */
    double T_hat, xi_dot;        /* T/Tm and Eq. 2.8, fixed during the return */
};

/* sigma_y at the end of the step for the increment d; the plastic rate is d/dt, floored inside PTW. */
static double yield_at(const struct yield_problem *y, double d)
{
    double rate = y->dt > 0.0 ? d / y->dt : 0.0;
    return ptw_flow_stress_at(y->m, y->eps_p + d, rate, y->T_hat, y->xi_dot, y->G);
}

/* f(d) = sigma* - 3 G d - sigma_y(eps_p + d, d/dt): decreasing in d. */
static double consistency(const struct yield_problem *y, double d)
{
    return y->trial - 3.0 * y->G * d - yield_at(y, d);
}

/* Root of f on [d_lo, d_hi] with f(d_lo) > 0 >= f(d_hi), d_lo = rate_floor dt (the floored rate: f there is
 * f0) and d_hi = sigma* / (3 G).  sigma_y grows like a power of the rate, flat at low rates and steep above
 * them, so the search runs in u = ln d.  The last step's increment (the ongoing plastic rate) is the first
 * guess; a Newton step with the shock-regime slope df/du = -(3 G d + beta sigma_y) and steps of growing
 * length find a tight bracket, and regula falsi with the Illinois rule closes it. */
/* A bracket [u_lo, u_hi] of the root in u = ln d with f(u_lo) > 0 >= f(u_hi); f_hi NAN until known. */
struct bracket {
    double u_lo, f_lo, u_hi, f_hi;
};

static void bracket_narrow(struct bracket *b, double u, double f)
{
    if (f > 0.0)
        b->u_lo = u, b->f_lo = f;
    else
        b->u_hi = u, b->f_hi = f;
}

static int converged(const struct yield_problem *y, double f) { return fabs(f) <= NEWTON_FTOL * y->trial; }

/* From the first guess u, steps of growing length towards the root until f changes sign: a tight bracket.
 * Returns 1 when it met the root itself (then *u is it). */
static int walk_to_bracket(const struct yield_problem *y, double *u, struct bracket *b)
{
    double f = consistency(y, exp(*u));
    double d = exp(*u), slope = 3.0 * y->G * d + y->m->ptw_beta * (y->trial - 3.0 * y->G * d - f);
    for (double step = slope > 0.0 ? fmin(2.0, fabs(f) / slope) : 0.05;; step *= 2.0) {
        if (converged(y, f))
            return 1;
        bracket_narrow(b, *u, f);
        double next = f > 0.0 ? *u + step : *u - step;
        if (!(next > b->u_lo && next < b->u_hi))
            return 0;
        double f_next = consistency(y, exp(next));
        int crossed = (f_next > 0.0) != (f > 0.0);
        *u = next, f = f_next;
        if (crossed) {
            if (converged(y, f))
                return 1;
            bracket_narrow(b, *u, f);
            return 0;
        }
    }
}

/* Regula falsi with the Illinois rule on the bracket. */
static double close_bracket(const struct yield_problem *y, struct bracket *b)
{
    double u = b->u_lo;
    int side = 0;
    for (int iter = 0; iter < NEWTON_MAX_ITER; iter++) {
        if (b->u_hi - b->u_lo <= NEWTON_XTOL)
            return exp(0.5 * (b->u_lo + b->u_hi));
        double next = b->u_lo + (b->u_hi - b->u_lo) * b->f_lo / (b->f_lo - b->f_hi);
        u = (next > b->u_lo && next < b->u_hi) ? next : 0.5 * (b->u_lo + b->u_hi);
        double f = consistency(y, exp(u));
        if (converged(y, f))
            return exp(u);
        bracket_narrow(b, u, f);
        if (f > 0.0 && side == 1)
            b->f_hi *= 0.5;
        if (f <= 0.0 && side == -1)
            b->f_lo *= 0.5;
        side = f > 0.0 ? 1 : -1;
    }
    return exp(u);
}

static double plastic_increment(const struct yield_problem *y, double f0)
{
    double d_hi = y->trial / (3.0 * y->G), d_lo = fmin(y->m->rate_floor * y->dt, 1e-3 * d_hi);
    struct bracket b = {log(d_lo), f0, log(d_hi), NAN};
    double guess = y->previous_increment;
    double u = (guess > d_lo && guess < d_hi) ? log(guess) : 0.5 * (b.u_lo + b.u_hi);
    if (walk_to_bracket(y, &u, &b))
        return exp(u);
    if (isnan(b.f_hi))   /* no evaluation below the root yet: the bracket's end itself */
        b.f_hi = -yield_at(y, d_hi);
    return close_bracket(y, &b);
}

/* ---- energy, pressure, viscosity ---- */

/* Tang Eqs. 3.41-3.43 / A9-A11: returns p^{n+1}, updates *energy from e^n to e^{n+1}. */
static double eos_energy_update(const struct mpm_material *m, double rho_new, double deviatoric_work,
                                double pressure_old, double volume0, double dV, double *energy)
{
    double e_trial = *energy + deviatoric_work - 0.5 * dV * pressure_old; /* Eq. 3.41 */
    double A, B;
    eos_coefficients(m, rho_new, &A, &B);
    double p = (A + B * e_trial / volume0) / (1.0 + 0.5 * B * dV / volume0); /* Eq. 3.43 */
    *energy = e_trial - 0.5 * dV * p;                                         /* Eq. 3.40 */
    return p;
}

/* Zhang's artificial bulk viscosity: q = rho l^2 c_q epsv_dot^2 - c_l rho l c epsv_dot in compression. */
static double bulk_viscosity_pressure(const struct mpm_material *m, const struct bulk_viscosity *q,
                                      double rho_new, double volumetric_rate)
{
    if (!q || !(volumetric_rate < 0.0))
        return 0.0;
    double l = q->length;
    return rho_new * l * l * q->quadratic * volumetric_rate * volumetric_rate -
           q->linear * rho_new * l * mpm_material_wave_speed(m) * volumetric_rate;
}

static int all_finite(const struct mpm_point_state *s)
{
    double sum = s->pressure + s->viscosity + s->eps_p + s->T + s->energy + s->rho + s->yield_stress;
    for (int k = 0; k < 6; k++)
        sum += s->stress[k];
    return isfinite(sum);
}

/* ---- the update ---- */

/* Deviatoric part of the step (Eqs. A1-A8): new deviatoric stress s_new from the rotated s_rot; returns the
 * plastic increment and sets *yield. */
static double deviatoric_update(const struct mpm_material *m, const struct mpm_point_state *state,
                                const double s_rot[6], const double dev_strain[6], double dt, double Tm,
                                double rho_new, double s_new[6], double *yield)
{
    double G = mts_shear_modulus(m, state->T);
    struct yield_problem y = {m, state->eps_p, dt, state->T, Tm, rho_new, G, 0.0, state->plastic_increment,
                             state->T > 0.0 ? state->T / Tm : 0.0, ptw_xi_dot(m, rho_new, G)};
    for (int k = 0; k < 6; k++)
        s_new[k] = s_rot[k] + 2.0 * G * dev_strain[k]; /* Eq. A1.3 */
    y.trial = von_mises(s_new);                         /* Eq. A5 */
    if (m->strength == MPM_STRENGTH_ELASTIC) {
        *yield = 0.0;
        return 0.0;
    }
    /* sigma_y >= 2 G y_inf at any rate and strain below melt (tau >= tau_y >= y_inf, Eq. 2.7b): a trial stress
     * below that is elastic without evaluating PTW (most points of a substrate, most steps) */
    if (G > 0.0 && y.trial <= 2.0 * G * m->ptw_yinf) {
        *yield = state->yield_stress;
        return 0.0;
    }
    if (!(G > 0.0)) { /* no shear stiffness left (G clamped at 0): no deviatoric stress */
        for (int k = 0; k < 6; k++)
            s_new[k] = 0.0;
        *yield = 0.0;
        return 0.0;
    }
    *yield = yield_at(&y, 0.0);
    if (!(y.trial > *yield))
        return 0.0;
    double d = plastic_increment(&y, y.trial - *yield);
    *yield = yield_at(&y, d);
    for (int k = 0; k < 6; k++)
        s_new[k] *= *yield / y.trial; /* Eq. A8 */
    return d;
}

int mpm_stress_update(const struct mpm_material *m, const struct bulk_viscosity *q, const double strain_increment[6],
                      const double spin_increment[3], double dt, double volume0, double volume_old,
                      double volume_new, struct mpm_point_state *state, struct mpm_update_result *result)
{
    double rho_new = m->density * volume0 / volume_new;
    double sigma_rot[6], s_rot[6], dev_strain[6], s_new[6], mean_rot, volumetric;
    jaumann_rotate(state->stress, spin_increment, sigma_rot); /* Eq. A2 */
    deviator(sigma_rot, s_rot, &mean_rot);                    /* Eq. A3 */
    deviator(strain_increment, dev_strain, &volumetric);      /* Eq. A4 */

    double Tm = scg_melt_temperature(m, rho_new);
    double yield = 0.0, d = 0.0;
    int melted = !(state->T < Tm);
    if (melted) {
        for (int k = 0; k < 6; k++)
            s_new[k] = 0.0;
    } else {
        d = deviatoric_update(m, state, s_rot, dev_strain, dt, Tm, rho_new, s_new, &yield);
    }

    double volume_half = 0.5 * (volume_old + volume_new), dV = volume_new - volume_old;
    double s_half[6];
    for (int k = 0; k < 6; k++)
        s_half[k] = 0.5 * (s_rot[k] + s_new[k]);
    double plastic_work = volume_half * yield * d;
    double energy_old = state->energy;
    double p = eos_energy_update(m, rho_new, volume_half * contract(s_half, strain_increment), state->pressure,
                                 volume0, dV, &state->energy);
    double volumetric_rate = dt > 0.0 ? 3.0 * volumetric / dt : 0.0;
    double visc = bulk_viscosity_pressure(m, q, rho_new, volumetric_rate);
    state->energy -= visc * dV; /* work of q */

    for (int k = 0; k < 6; k++)
        state->stress[k] = s_new[k] - (k < 3 ? p : 0.0);
    state->pressure = p;
    state->viscosity = visc;
    state->rho = rho_new;
    state->T += m->taylor_quinney * yield * d / (rho_new * m->specific_heat); /* Eq. 3.44 */
    state->eps_p += d;
    state->plastic_increment = d;
    state->yield_stress = yield;
    state->melted = melted ? 1.0 : 0.0;
    result->eps_p_increment = d;
    result->von_mises = von_mises(s_new);
    result->plastic_work = plastic_work;
    result->energy_increment = state->energy - energy_old;
    return all_finite(state) && isfinite(result->von_mises) && isfinite(plastic_work) ? 0 : -1;
}

void mpm_point_state_init(const struct mpm_material *m, struct mpm_point_state *state)
{
    for (int k = 0; k < 6; k++)
        state->stress[k] = 0.0;
    state->pressure = 0.0;
    state->viscosity = 0.0;
    state->eps_p = 0.0;
    state->T = m->T_initial;
    state->energy = 0.0;
    state->rho = m->density;
    double Tm = scg_melt_temperature(m, m->density);
    state->melted = m->T_initial < Tm ? 0.0 : 1.0;
    state->yield_stress = m->strength == MPM_STRENGTH_PTW
                              ? ptw_flow_stress(m, 0.0, m->rate_floor, m->T_initial, Tm, m->density,
                                                mts_shear_modulus(m, m->T_initial))
                              : 0.0;
}

/* sqrt((K + 4/3 G(T_initial)) / rho0). */
double mpm_material_wave_speed(const struct mpm_material *m)
{
    return sqrt((m->bulk_modulus + 4.0 / 3.0 * mts_shear_modulus(m, m->T_initial)) / m->density);
}
