/* Preston-Tonks-Wallace flow stress (Tang Section 2.4.2, Eqs. 2.4-2.8, in the form of Preston, Tonks & Wallace
 * 2003) and the MTS shear modulus G(T) (Eq. 2.6).
 *
 * Tang prints the hardening constant as d and the high-rate exponent as s1; they are ptw_p and ptw_beta here.
 * The overdriven-shock terms of Eq. 2.7 enter through max/min at every strain rate, as in PTW 2003 and LANL
 * impala (Uintah applies them only above 1e3 /s; notes/mpm.md 2.1, pitfall 1).  The flow stress is the von
 * Mises stress 2 G tau (Eq. 2.4) with G the current G(T). */
#include "mpm/material.h"

#include <float.h>
#include <math.h>

#define PI 3.14159265358979323846

/* Below this p the hardening law is replaced by its p -> 0 limit. */
#define PTW_P_SMALL 1e-12
/* |s0 - tau_y| below this fraction of s0 is treated as s0 = tau_y (the law's singular point). */
#define PTW_S0_TY_SMALL 1e-13

/* MTS shear modulus, Tang Eq. 2.6: G0 - D / (exp(T0/T) - 1), clamped at 0; G0 at T <= 0 (the 0 K limit). */
double mts_shear_modulus(const struct mpm_material *m, double T)
{
    if (!(T > 0.0))
        return m->G0;
    double G = m->G0 - m->D / expm1(m->T0 / T);
    return G > 0.0 ? G : 0.0;
}

/* Tang Eq. 2.8 in SI: xi_dot = 1/2 (4 pi rho / (3 M))^(1/3) sqrt(G / rho), M the atomic mass in kg. */
double ptw_xi_dot(const struct mpm_material *m, double rho, double G)
{
    if (!(rho > 0.0) || !(G > 0.0))
        return 0.0;
    return 0.5 * cbrt(4.0 * PI * rho / (3.0 * m->atomic_mass)) * sqrt(G / rho);
}

/* ln(x + exp(u)) for x >= 0, without overflow or underflow of exp(u) (max-shift of the log-sum-exp). */
static double log_sum_exp(double x, double u)
{
    double lx = log(x); /* -inf at x = 0 */
    double top = fmax(lx, u);
    return top + log(exp(lx - top) + exp(u - top));
}

/* Tang Eq. 2.4-2.5 (PTW 2003 Eq. 5), p > 0:
 *   tau = tau_s + A ln[1 - (1 - exp(-a)) exp(-theta eps_p / (A (exp(a) - 1)))],
 *   A = (s0 - tau_y)/p, a = (tau_s - tau_y)/A.
 * The bracket is written as -expm1(-q) + exp(-a - q), q = theta eps_p / (A expm1(a)), which stays accurate and
 * positive for either sign of s0 - tau_y (s0 < tau_y happens in the shock regime). */
static double ptw_hardening(const struct mpm_material *m, double eps_p, double tau_s, double tau_y)
{
    double s0_minus_ty = m->ptw_s0 - tau_y;
    if (fabs(s0_minus_ty) <= PTW_S0_TY_SMALL * m->ptw_s0)
        return tau_y; /* the A -> 0+ limit: hardening stops at once */
    double A = s0_minus_ty / m->ptw_p;
    double a = (tau_s - tau_y) / A;
    double q = m->ptw_theta * eps_p / (A * expm1(a));
    return tau_s + A * log_sum_exp(-expm1(-q), -a - q);
}

/* The p -> 0 limit of Eq. 2.4: tau = tau_s - (tau_s - tau_y) exp(-theta eps_p / (tau_s - tau_y)). */
static double ptw_hardening_p0(const struct mpm_material *m, double eps_p, double tau_s, double tau_y)
{
    double range = tau_s - tau_y;
    return tau_s - range * exp(-m->ptw_theta * eps_p / range);
}

/* PTW flow stress, Tang Eqs. 2.4-2.7.  The rate is floored at m->rate_floor (and kept > 0): ln(gamma xi / rate)
 * is infinite at rate 0, and elastic or barely plastic points have no meaningful plastic rate. */
double ptw_flow_stress(const struct mpm_material *m, double eps_p, double rate, double T, double Tm, double rho,
                       double G)
{
    if (!(G > 0.0) || !(Tm > 0.0) || !(T < Tm))
        return 0.0;
    return ptw_flow_stress_at(m, eps_p, rate, T > 0.0 ? T / Tm : 0.0, ptw_xi_dot(m, rho, G), G);
}

double ptw_flow_stress_at(const struct mpm_material *m, double eps_p, double rate, double that, double xi, double G)
{
    if (rate < m->rate_floor)
        rate = m->rate_floor;
    if (!(rate > 0.0))
        rate = DBL_MIN;
    double log_ratio = log(rate / (m->ptw_gamma * xi));         /* ln(eps_dot / (gamma xi_dot)) */
    double e = erf(-m->ptw_kappa * that * log_ratio);           /* erf[kappa T^ ln(gamma xi_dot / eps_dot)] */
    double shock_s = m->ptw_s0 * exp(m->ptw_beta * log_ratio);  /* s0 (eps_dot / gamma xi_dot)^beta */
    double shock_y = fmin(m->ptw_y1 * exp(m->ptw_y2 * log_ratio), shock_s);
    double tau_s = fmax(m->ptw_s0 - (m->ptw_s0 - m->ptw_sinf) * e, shock_s); /* Tang Eq. 2.7a */
    double tau_y = fmax(m->ptw_y0 - (m->ptw_y0 - m->ptw_yinf) * e, shock_y); /* Tang Eq. 2.7b */
    if (tau_s <= tau_y)
        return 2.0 * G * tau_s;
    double tau = m->ptw_p < PTW_P_SMALL ? ptw_hardening_p0(m, eps_p, tau_s, tau_y)
                                        : ptw_hardening(m, eps_p, tau_s, tau_y);
    return 2.0 * G * tau; /* Tang Eq. 2.4 */
}
