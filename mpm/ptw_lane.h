/* Module-private (mpm/): the PTW flow stress of ptw.c for one material point, written for vector lanes: selects
 * instead of branches, core/fastmath*.h instead of libm, so that a loop over the points of a block vectorises
 * (stress_update.c) and each lane gives the bits of the scalar call (ptw_flow_stress_log_rate is this function
 * on one point).  Tang Eqs. 2.4-2.7 in the form of Preston, Tonks & Wallace 2003; ptw.c has the notes on the
 * model (shock terms at every rate, Tang's names of the constants). */
#ifndef SPRAYCOAT_MPM_PTW_LANE_H
#define SPRAYCOAT_MPM_PTW_LANE_H

#include <float.h>
#include <math.h>

#include "core/fastmath_special.h"
#include "mpm/material.h"

#define PTW_TWO_OVER_SQRT_PI 1.12837916709551257390
/* Below this p the hardening law is replaced by its p -> 0 limit. */
#define PTW_P_SMALL 1e-12
/* |s0 - tau_y| below this fraction of s0 is treated as s0 = tau_y (the law's singular point). */
#define PTW_S0_TY_SMALL 1e-13

/* The hardening law's value tau and its partial derivatives in eps_p, tau_s and tau_y. */
struct ptw_hardening {
    double tau, d_eps, d_tau_s, d_tau_y;
};

/* Tang Eqs. 2.4-2.5 (PTW 2003 Eq. 5), p > 0, tau_s > tau_y:
 *   tau = tau_s + A ln B,  B = 1 - (1 - e^-a) e^-q,  A = (s0 - tau_y)/p,  a = (tau_s - tau_y)/A,
 *   q = theta eps_p / (A expm1(a)).
 * B = x + e^v with x = -expm1(-q) in [0, 1) and v = -a - q: a sum of two non-negative terms for either sign of a,
 * so ln B is accurate to round-off without cancellation.  e^v overflows where a << 0 (s0 just below tau_y, the
 * shock regime), so ln B = max(v, 0) + ln(x e^-v + 1) for v > 0 and ln(x + e^v) for v <= 0, both from
 * e1 = e^-|v|.  Partial derivatives for the Newton return, with r1 = e^v / B, r2 = (1 - B)/B and
 * K = -r1 - r2 q (1 + expm1(a))/expm1(a) (the chain rule through a and q):
 *   d tau/d eps_p = r2 theta / expm1(a)      (theta at eps_p = 0, PTW's initial hardening rate)
 *   d tau/d tau_s = 1 + K
 *   d tau/d tau_y = (-ln B + K (tau_s - s0)/A + r2 q) / p      (0 and 1 at eps_p = 0).
 * 1 - B = e^-q (1 - e^-a) is taken as e^-q expm1(a)/(1 + expm1(a)) for a >= 0 (no cancellation near a = 0) and as
 * e^-q - e^v for a < 0; where B > e (v > 1) r2 = 1/B - 1 does not cancel and stays right when e^v overflows. */
FM_INLINE struct ptw_hardening ptw_lane_hardening(const struct mpm_material *m, double eps_p, double tau_s,
                                                  double tau_y)
{
    double A = (m->ptw_s0 - tau_y) / m->ptw_p;
    double a = (tau_s - tau_y) / A;
    double em = fm_expm1(a);
    double q = m->ptw_theta * eps_p / (A * em);
    double x = -fm_expm1(-q), eq = 1.0 - x;
    double v = -a - q;
    int above_one = v > 0.0;
    double e1 = fm_exp(-fabs(v));
    double arg = fm_select(above_one, x * e1 + 1.0, x + e1);
    arg = fm_select(arg > DBL_MIN, arg, DBL_MIN); /* e^v underflowing at eps_p = 0: ln B ~ -708, not ln 0 */
    double log_B = fm_select(above_one, v, 0.0) + fm_log(arg);
    double inv_B = fm_select(above_one, e1, 1.0) / arg;
    double r1 = fm_select(above_one, 1.0, e1) / arg;
    double ev = fm_select(above_one, 1.0 / e1, e1);
    double one_minus_B = fm_select(a >= 0.0, eq * (em / (1.0 + em)), eq - ev);
    double r2 = fm_select(v > 1.0, inv_B - 1.0, one_minus_B * inv_B);
    double K = -r1 - r2 * q * (1.0 + em) / em;
    return (struct ptw_hardening){tau_s + A * log_B, r2 * m->ptw_theta / em, 1.0 + K,
                                  (-log_B + K * (tau_s - m->ptw_s0) / A + r2 * q) / m->ptw_p};
}

/* The p -> 0 limit of Eq. 2.4: tau = tau_s - R exp(-z), R = tau_s - tau_y, z = theta eps_p / R. */
FM_INLINE struct ptw_hardening ptw_lane_hardening_p0(const struct mpm_material *m, double eps_p, double tau_s,
                                                     double tau_y)
{
    double range = tau_s - tau_y, z = m->ptw_theta * eps_p / range, ez = fm_exp(-z);
    double d_tau_y = ez * (1.0 + z);
    return (struct ptw_hardening){tau_s - range * ez, m->ptw_theta * ez, 1.0 - d_tau_y, d_tau_y};
}

/* Eq. 2.4 for any tau_s, tau_y: no hardening range (tau_s <= tau_y) gives tau_s; s0 = tau_y (the law's singular
 * point, A -> 0+) gives tau_y.  p_small (the material's p below PTW_P_SMALL) is the same for every lane. */
FM_INLINE struct ptw_hardening ptw_lane_tau(const struct mpm_material *m, int p_small, double eps_p, double tau_s,
                                            double tau_y)
{
    struct ptw_hardening h =
        p_small ? ptw_lane_hardening_p0(m, eps_p, tau_s, tau_y) : ptw_lane_hardening(m, eps_p, tau_s, tau_y);
    int singular = fabs(m->ptw_s0 - tau_y) <= PTW_S0_TY_SMALL * m->ptw_s0;
    int no_range = tau_s <= tau_y;
    h.tau = fm_select(no_range, tau_s, fm_select(singular, tau_y, h.tau));
    h.d_eps = fm_select(no_range | singular, 0.0, h.d_eps);
    h.d_tau_s = fm_select(no_range, 1.0, fm_select(singular, 0.0, h.d_tau_s));
    h.d_tau_y = fm_select(no_range, 0.0, fm_select(singular, 1.0, h.d_tau_y));
    return h;
}

/* MTS shear modulus, Tang Eq. 2.6, G0 - D / (exp(T0/T) - 1) clamped at 0, G0 at T <= 0: mpm_mts_shear_modulus of
 * ptw.c with fm_expm1 for libm's expm1 (within 2 ulp of it), for the per-point path of stress_update.c. */
FM_INLINE double mts_lane_shear_modulus(const struct mpm_material *m, double T)
{
    int positive = T > 0.0;
    double G = m->G0 - m->D / fm_expm1(m->T0 / fm_select(positive, T, 1.0));
    return fm_select(positive, fm_select(G > 0.0, G, 0.0), m->G0);
}

/* SCG melt temperature, Tang Eq. 2.9 with the erratum of docs/physics.md (mpm_scg_melt_temperature of melt.c), as one
 * exponential: Tm0 exp(2a (1 - 1/eta) + 2 (Gamma0 - a - 1/3) ln eta), eta = rho/rho0; 0 for rho <= 0. */
FM_INLINE double scg_lane_melt_temperature(const struct mpm_material *m, double rho)
{
    int positive = rho > 0.0;
    double eta = fm_select(positive, rho, m->density) / m->density;
    double exponent = 2.0 * (m->eos_gamma0 - m->melt_a - 1.0 / 3.0);
    double log_eta = fm_log(fm_select(eta > 1e-300, eta, 1e-300));
    double Tm = m->melt_T0 * fm_exp(2.0 * m->melt_a * (1.0 - 1.0 / eta) + exponent * log_eta);
    return fm_select(positive, Tm, 0.0);
}

/* tau_s and tau_y of Tang Eq. 2.7 at L = ln(eps_dot / (gamma xi_dot)), and their derivatives in L. */
struct ptw_rate_terms {
    double tau_s, tau_y, d_tau_s, d_tau_y;
};

/* Eq. 2.7: tau_s = max(s0 - (s0 - s_inf) erf(x), s0 e^(beta L)), tau_y = max(y0 - (y0 - y_inf) erf(x),
 * min(y1 e^(y2 L), s0 e^(beta L))), x = kappa T^ ln(gamma xi_dot / eps_dot) = -kappa T^ L. */
FM_INLINE struct ptw_rate_terms ptw_lane_rate_terms(const struct mpm_material *m, double L, double T_hat)
{
    double shock_s = m->ptw_s0 * fm_exp(m->ptw_beta * L);
    double medium_y = m->ptw_y1 * fm_exp(m->ptw_y2 * L);
    int medium_below = medium_y < shock_s;
    double shock_y = fm_select(medium_below, medium_y, shock_s);
    double d_shock_y = fm_select(medium_below, m->ptw_y2 * medium_y, m->ptw_beta * shock_s);
    double s_range = m->ptw_s0 - m->ptw_sinf, y_range = m->ptw_y0 - m->ptw_yinf;
    double x = -m->ptw_kappa * T_hat * L;
    double gauss = fm_exp(-(x * x));
    double e = fm_erf_from_gauss(x, gauss);
    double minus_de_dL = m->ptw_kappa * T_hat * PTW_TWO_OVER_SQRT_PI * gauss; /* -d erf(x)/dL */
    double s_erf = m->ptw_s0 - s_range * e, y_erf = m->ptw_y0 - y_range * e;
    int s_erf_max = s_erf >= shock_s, y_erf_max = y_erf >= shock_y;
    return (struct ptw_rate_terms){fm_select(s_erf_max, s_erf, shock_s), fm_select(y_erf_max, y_erf, shock_y),
                                   fm_select(s_erf_max, s_range * minus_de_dL, m->ptw_beta * shock_s),
                                   fm_select(y_erf_max, y_range * minus_de_dL, d_shock_y)};
}

/* PTW at eps_p and log_ratio = ln(rate / (gamma xi_dot)) (the rate already floored), T^ = T/Tm (< 1), shear
 * modulus G: sigma_y = 2 G tau (Tang Eq. 2.4) and its derivatives in eps_p and ln(rate). */
FM_INLINE struct ptw_flow ptw_lane_flow(const struct mpm_material *m, int p_small, double eps_p, double log_ratio,
                                        double T_hat, double G)
{
    struct ptw_rate_terms r = ptw_lane_rate_terms(m, log_ratio, T_hat);
    struct ptw_hardening h = ptw_lane_tau(m, p_small, eps_p, r.tau_s, r.tau_y);
    return (struct ptw_flow){2.0 * G * h.tau, 2.0 * G * h.d_eps,
                             2.0 * G * (h.d_tau_s * r.d_tau_s + h.d_tau_y * r.d_tau_y)};
}

#endif
