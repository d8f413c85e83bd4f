/* Stress update of one material point, Tang Appendix A (Eqs. A1-A11) with the energy equation of Section 3.5.2
 * (Eqs. 3.38-3.43), adiabatic heating (Eq. 3.44), the SCG melt (Eq. 2.9) and Zhang's artificial bulk viscosity.
 *
 * Symmetric tensors are stored xx, yy, zz, yz, xz, xy with tensor components; a double contraction a:b counts
 * every off-diagonal pair twice.  Differences from the printed appendix:
 * - The plastic strain increment is not the one-step linearisation of Eq. A6 but the root of the consistency
 *   condition with the rate-dependent PTW flow stress evaluated at the END of the step,
 *       f(d) = sigma* - 3 G d - sigma_y(eps_p + d, max(d/dt, rate_floor)) = 0,
 *   by a safeguarded Newton iteration in u = ln d with the analytic derivative of PTW (ptw.c), inside the
 *   bracket [rate_floor dt, sigma* / (3 G)] (PTW is steep in the rate in the shock regime, notes/mpm.md 2.1).
 * - The yield check uses sigma_y(eps_p, rate_floor): the smallest flow stress the point can have.
 * - The rate floor m->rate_floor stands for the plastic strain rate of an elastic or barely plastic point
 *   (PTW needs ln(gamma xi_dot / rate) finite; DESIGN.md "Impact (Tang)").
 * - Melting (T >= Tm(rho_new)) removes the deviatoric stress for either strength model; MPM_STRENGTH_ELASTIC
 *   never yields and reports yield_stress 0.
 * - The artificial bulk viscosity q is kept apart from the Cauchy stress (state->viscosity) and its work enters
 *   the internal energy after the EOS solve. */
#include "mpm/material.h"

#include <float.h>
#include <math.h>

/* Convergence of the return (Tang Eqs. A6-A8, consistency at the end of the step): |f| <= NEWTON_FTOL sigma* at
 * an evaluated iterate, or a Newton step (or bracket) shorter than NEWTON_XTOL in ln d.  The same tolerances as
 * the regula-falsi return this Newton iteration replaced; a Newton step that short leaves an error of the order
 * of its square. */
#define NEWTON_MAX_ITER 100
#define NEWTON_FTOL     1e-10 /* |f| relative to sigma* */
#define NEWTON_XTOL     1e-13 /* step or bracket width in ln d (relative change of d) */

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
    double eps_p, G, trial, T_hat;
    double log_rate_scale;   /* ln(gamma xi_dot dt): L = ln(eps_dot / (gamma xi_dot)) = ln d - log_rate_scale */
    double log_ratio_floor;  /* L at the rate floor */
};

/* f and df/du at u = ln d, with d and the flow stress there. */
struct consistency {
    double d, f, df_du, yield;
};

/* The consistency condition f(d) = sigma* - 3 G d - sigma_y(eps_p + d, max(d/dt, rate_floor)) (Tang Eqs. A6-A8
 * with the flow stress at the end of the step), decreasing in d, and its derivative in u = ln d:
 *   df/du = -d (3 G + d sigma_y/d eps_p) - d sigma_y/d ln(rate)   (the last term 0 where the rate is floored). */
static void consistency_at(const struct yield_problem *y, double u, struct consistency *c)
{
    double L = u - y->log_rate_scale;
    int floored = !(L > y->log_ratio_floor);
    struct ptw_flow flow;
    c->d = exp(u);
    ptw_flow_stress_log_rate(y->m, y->eps_p + c->d, floored ? y->log_ratio_floor : L, y->T_hat, y->G, &flow);
    c->yield = flow.stress;
    c->f = y->trial - 3.0 * y->G * c->d - flow.stress;
    c->df_du = -c->d * (3.0 * y->G + flow.d_eps) - (floored ? 0.0 : flow.d_log_rate);
}

static int converged(const struct yield_problem *y, double f) { return fabs(f) <= NEWTON_FTOL * y->trial; }

/* A bracket [u_lo, u_hi] of the root in u = ln d: f(u_hi) <= 0, and f(u_lo) > 0 once `plastic` is set (the
 * point is proven plastic: f > 0 somewhere, or the yield check passed). */
struct bracket {
    double u_lo, u_hi;
    int plastic;
};

/* The yield check, Tang Eq. A6's condition sigma* > sigma_y with the smallest flow stress the point can have:
 * sigma_y(eps_p, rate_floor) (PTW grows with strain and rate).  *c becomes the elastic result (d = 0, f and
 * sigma_y there); returns 1 and sets b->plastic when the point yields. */
static int yield_check(const struct yield_problem *y, struct bracket *b, struct consistency *c)
{
    struct ptw_flow flow;
    ptw_flow_stress_log_rate(y->m, y->eps_p, y->log_ratio_floor, y->T_hat, y->G, &flow);
    *c = (struct consistency){0.0, y->trial - flow.stress, 0.0, flow.stress};
    b->plastic = y->trial > flow.stress;
    return b->plastic;
}

/* Safeguarded Newton in u = ln d from u, whose f and df/du are in *c.  A Newton step that leaves the bracket
 * becomes a bisection, after the yield check if it left through u_lo before the point was proven plastic (an
 * elastic point's f has no root above u_lo: then *c is the elastic result).  Stops when |f| <= NEWTON_FTOL
 * sigma* or when the last step (or the bracket) was shorter than NEWTON_XTOL in u, after evaluating the last
 * iterate: *c then holds the returned d and sigma_y there.  sigma_y is flat in the rate at low rates and a power
 * of it above (the shock regime); f is concave in u over most of the range, and from last step's increment
 * Newton converges in 2-3 steps. */
static void newton_return(const struct yield_problem *y, struct bracket *b, double u, struct consistency *c)
{
    for (int iter = 0; iter < NEWTON_MAX_ITER && !converged(y, c->f); iter++) {
        if (c->f > 0.0)
            b->u_lo = u, b->plastic = 1;
        else
            b->u_hi = u;
        double next = u - c->f / c->df_du;
        int last = fabs(next - u) <= NEWTON_XTOL;
        if (!(next > b->u_lo && next < b->u_hi)) {
            if (!b->plastic && !(next > b->u_lo) && !yield_check(y, b, c))
                return;
            next = 0.5 * (b->u_lo + b->u_hi);
            last = b->u_hi - b->u_lo <= NEWTON_XTOL;
        }
        u = next;
        consistency_at(y, u, c);
        if (last)
            return;
    }
}

/* Bounds of ln x for x > 0 within ln 2 from its binary exponent (x = m 2^e, 1/2 <= m < 1): the bracket's ends
 * need only be on the right side of the root, and two logarithms per plastic point are saved. */
static double log_above(double x)
{
    int e;
    frexp(x, &e);
    return (double)e * M_LN2;
}

static double log_below(double x)
{
    int e;
    frexp(x, &e);
    return (double)(e - 1) * M_LN2;
}

/* The plastic increment d of a point whose trial stress exceeds 2 G y_inf, or 0 when it stays elastic; *yield is
 * sigma_y at the end of the step.  d lies in [d_lo, d_hi], d_lo = rate_floor dt (kept below d_hi), d_hi =
 * sigma* / (3 G) where f <= -sigma_y <= 0.  A point plastic in the last step starts from its last increment (the
 * ongoing plastic rate; f > 0 anywhere proves the point plastic, f(0) >= f(d), so the yield check is needed only
 * if Newton heads below d_lo).  Otherwise the yield check comes first, and Newton starts from the
 * rate-independent increment (sigma* - sigma_y(eps_p, floor)) / (3 G), where f <= 0. */
static double plastic_increment(const struct yield_problem *y, double previous, double dt, double *yield)
{
    double d_hi = y->trial / (3.0 * y->G), d_lo = fmax(fmin(y->m->rate_floor * dt, 1e-3 * d_hi), DBL_MIN);
    struct bracket b = {log_below(d_lo), log_above(d_hi), 0};
    struct consistency c;
    double u;
    if (previous > d_lo && previous < d_hi) {
        u = log(previous);
    } else {
        if (!yield_check(y, &b, &c)) {
            *yield = c.yield;
            return 0.0;
        }
        double guess = log((y->trial - c.yield) / (3.0 * y->G));
        u = guess > b.u_lo && guess < b.u_hi ? guess : 0.5 * (b.u_lo + b.u_hi);
    }
    consistency_at(y, u, &c);
    newton_return(y, &b, u, &c);
    *yield = c.yield;
    return c.d;
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
static double bulk_viscosity_pressure(const struct mpm_material_constants *c, const struct bulk_viscosity *q,
                                      double rho_new, double volumetric_rate)
{
    if (!q || !(volumetric_rate < 0.0))
        return 0.0;
    double l = q->length;
    return rho_new * l * l * q->quadratic * volumetric_rate * volumetric_rate -
           q->linear * rho_new * l * c->wave_speed * volumetric_rate;
}

static int all_finite(const struct mpm_point_state *s)
{
    double sum = s->pressure + s->viscosity + s->eps_p + s->T + s->energy + s->rho + s->yield_stress;
    for (int k = 0; k < 6; k++)
        sum += s->stress[k];
    return isfinite(sum);
}

/* ---- the update ---- */

/* G(T) of Eq. 2.6; a point never heated (T exactly T_initial: no plastic work yet) takes the precomputed value. */
static double shear_modulus(const struct mpm_material *m, const struct mpm_material_constants *c, double T)
{
    return T == m->T_initial ? c->G_initial : mts_shear_modulus(m, T);
}

/* Whether T >= Tm(rho_new) (Eq. 2.9); *Tm is the melt temperature when it was computed, else NAN.  Tm grows with
 * the density where c->melt_T_low > 0 (mpm_material_prepare), so a point at least that dense and colder than
 * Tm(melt_eta_low) is below melt without the exp and pow of Eq. 2.9. */
static int at_or_above_melt(const struct mpm_material *m, const struct mpm_material_constants *c, double T,
                            double rho_new, double *Tm)
{
    if (T < c->melt_T_low && rho_new >= c->melt_eta_low * m->density) {
        *Tm = NAN;
        return 0;
    }
    *Tm = scg_melt_temperature(m, rho_new);
    return !(T < *Tm);
}

/* The first guess of the return for a point plastic in the last step (increment d0, flow stress sigma0): one
 * Newton step in ln d on the model f = sigma* - 3 G d - sigma0 (d/d0)^beta, beta the rate exponent of the
 * shock-regime flow stress (Eq. 2.7), limited to a factor e^2 either way.  It costs no PTW evaluation and
 * saves about half a Newton step on the impact benchmark.  0 (no guess) for a point elastic in the last step. */
static double first_guess(const struct mpm_material *m, const struct mpm_point_state *state, double G,
                          double trial)
{
    double d0 = state->plastic_increment, sigma0 = state->yield_stress;
    if (!(d0 > 0.0) || !(sigma0 > 0.0))
        return d0;
    double step = (trial - 3.0 * G * d0 - sigma0) / (3.0 * G * d0 + m->ptw_beta * sigma0);
    return d0 * exp(fmax(-2.0, fmin(2.0, step)));
}

/* Radial return onto the PTW flow stress (Eqs. A5-A8): scales s_new from the trial to sigma_y, returns d. */
static double ptw_return(const struct mpm_material *m, const struct mpm_material_constants *c,
                         const struct mpm_point_state *state, double G, double trial, double dt, double log_dt,
                         double Tm, double rho_new, double s_new[6], double *yield)
{
    if (isnan(Tm))
        Tm = scg_melt_temperature(m, rho_new);
    /* ln(gamma xi_dot), Eq. 2.8: ln(gamma (4 pi / 3 M)^(1/3) / 2) + ln(G^3 / rho) / 6 */
    double log_gamma_xi = c->log_gamma_xi_factor + log(G * G * G / rho_new) / 6.0;
    struct yield_problem y = {m, state->eps_p, G, trial, state->T > 0.0 ? state->T / Tm : 0.0,
                              dt > 0.0 ? log_gamma_xi + log_dt : INFINITY, c->log_rate_floor - log_gamma_xi};
    double d = plastic_increment(&y, first_guess(m, state, G, trial), dt, yield);
    if (d > 0.0)
        for (int k = 0; k < 6; k++)
            s_new[k] *= *yield / trial; /* Eq. A8 */
    return d;
}

/* Deviatoric part of the step (Eqs. A1-A8): new deviatoric stress s_new from the rotated s_rot; returns the
 * plastic increment and sets *yield and *melted. */
static double deviatoric_update(const struct mpm_material *m, const struct mpm_material_constants *c,
                                const struct mpm_point_state *state, const double s_rot[6],
                                const double dev_strain[6], double dt, double log_dt, double rho_new,
                                double s_new[6], double *yield, int *melted)
{
    double Tm;
    *yield = 0.0;
    if ((*melted = at_or_above_melt(m, c, state->T, rho_new, &Tm)) != 0) {
        for (int k = 0; k < 6; k++)
            s_new[k] = 0.0;
        return 0.0;
    }
    double G = shear_modulus(m, c, state->T);
    for (int k = 0; k < 6; k++)
        s_new[k] = s_rot[k] + 2.0 * G * dev_strain[k]; /* Eq. A1.3 */
    double trial = von_mises(s_new);                    /* Eq. A5 */
    if (m->strength == MPM_STRENGTH_ELASTIC)
        return 0.0;
    /* sigma_y >= 2 G y_inf at any rate and strain below melt (tau >= tau_y >= y_inf, Eq. 2.7b): a trial stress
     * below that is elastic without evaluating PTW (most points of a substrate, most steps) */
    if (G > 0.0 && trial <= 2.0 * G * m->ptw_yinf) {
        *yield = state->yield_stress;
        return 0.0;
    }
    if (!(G > 0.0)) { /* no shear stiffness left (G clamped at 0): no deviatoric stress */
        for (int k = 0; k < 6; k++)
            s_new[k] = 0.0;
        return 0.0;
    }
    return ptw_return(m, c, state, G, trial, dt, log_dt, Tm, rho_new, s_new, yield);
}

int mpm_stress_update_prepared(const struct mpm_material *m, const struct mpm_material_constants *c,
                               const struct bulk_viscosity *q, const double strain_increment[6],
                               const double spin_increment[3], double dt, double log_dt, double volume0,
                               double volume_old, double volume_new, struct mpm_point_state *state,
                               struct mpm_update_result *result)
{
    double rho_new = m->density * volume0 / volume_new;
    double sigma_rot[6], s_rot[6], dev_strain[6], s_new[6], mean_rot, volumetric;
    jaumann_rotate(state->stress, spin_increment, sigma_rot); /* Eq. A2 */
    deviator(sigma_rot, s_rot, &mean_rot);                    /* Eq. A3 */
    deviator(strain_increment, dev_strain, &volumetric);      /* Eq. A4 */

    double yield, d;
    int melted;
    d = deviatoric_update(m, c, state, s_rot, dev_strain, dt, log_dt, rho_new, s_new, &yield, &melted);

    double volume_half = 0.5 * (volume_old + volume_new), dV = volume_new - volume_old;
    double s_half[6];
    for (int k = 0; k < 6; k++)
        s_half[k] = 0.5 * (s_rot[k] + s_new[k]);
    double plastic_work = volume_half * yield * d;
    double energy_old = state->energy;
    double p = eos_energy_update(m, rho_new, volume_half * contract(s_half, strain_increment), state->pressure,
                                 volume0, dV, &state->energy);
    double volumetric_rate = dt > 0.0 ? 3.0 * volumetric / dt : 0.0;
    double visc = bulk_viscosity_pressure(c, q, rho_new, volumetric_rate);
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

int mpm_stress_update(const struct mpm_material *m, const struct bulk_viscosity *q, const double strain_increment[6],
                      const double spin_increment[3], double dt, double volume0, double volume_old,
                      double volume_new, struct mpm_point_state *state, struct mpm_update_result *result)
{
    struct mpm_material_constants c;
    mpm_material_prepare(m, &c);
    return mpm_stress_update_prepared(m, &c, q, strain_increment, spin_increment, dt, dt > 0.0 ? log(dt) : 0.0,
                                      volume0, volume_old, volume_new, state, result);
}

/* The melt bound: Tm(eta) = Tm0 exp(2a(1 - 1/eta)) eta^k grows with eta when a >= 0 and k >= 0 (Eq. 2.9). */
#define MELT_ETA_LOW 0.9

void mpm_material_prepare(const struct mpm_material *m, struct mpm_material_constants *c)
{
    c->G_initial = mts_shear_modulus(m, m->T_initial);
    c->wave_speed = mpm_material_wave_speed(m);
    c->log_rate_floor = log(m->rate_floor > DBL_MIN ? m->rate_floor : DBL_MIN);
    c->log_gamma_xi_factor = log(m->ptw_gamma * 0.5 * cbrt(4.0 * M_PI / (3.0 * m->atomic_mass)));
    int monotone = m->melt_a >= 0.0 && m->eos_gamma0 - m->melt_a - 1.0 / 3.0 >= 0.0;
    c->melt_eta_low = MELT_ETA_LOW;
    c->melt_T_low = monotone ? scg_melt_temperature(m, MELT_ETA_LOW * m->density) : 0.0;
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
