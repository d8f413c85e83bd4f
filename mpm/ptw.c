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

/* ln(x + exp(v)) for x >= 0, without overflow or underflow of exp(v) (max-shift of the log-sum-exp). */
static double log_sum_exp(double x, double v)
{
    double lx = log(x); /* -inf at x = 0 */
    double top = fmax(lx, v);
    return top + log(exp(lx - top) + exp(v - top));
}

/* The hardening law's value tau and its partial derivatives in eps_p, tau_s and tau_y. */
struct hardening {
    double tau, d_eps, d_tau_s, d_tau_y;
};

/* Tang Eqs. 2.4-2.5 (PTW 2003 Eq. 5), p > 0, tau_s > tau_y:
 *   tau = tau_s + A ln B,  B = 1 - (1 - exp(-a)) exp(-q),
 *   A = (s0 - tau_y)/p,  a = (tau_s - tau_y)/A,  q = theta eps_p / (A expm1(a)).
 * a has the sign of A.  For a >= 0 (s0 > tau_y, the usual case) B = -expm1(-q) + exp(-q)/(1 + expm1(a)) is a sum
 * of two non-negative terms, so ln B is accurate to round-off without the log-sum-exp; for a < 0 (s0 < tau_y,
 * possible in the shock regime) exp(-a) may overflow and ln B is taken as a log-sum-exp.
 * Partial derivatives for the Newton return, with r1 = exp(-a - q)/B, r2 = (1 - B)/B and
 * K = -r1 - r2 q (1 + expm1(a))/expm1(a) (the chain rule through a and q):
 *   d tau/d eps_p = r2 theta / expm1(a)      (theta at eps_p = 0, PTW's initial hardening rate)
 *   d tau/d tau_s = 1 + K
 *   d tau/d tau_y = (-ln B + K (tau_s - s0)/A + r2 q) / p      (0 and 1 at eps_p = 0). */
static void ptw_hardening(const struct mpm_material *m, double eps_p, double tau_s, double tau_y,
                          struct hardening *h)
{
    double A = (m->ptw_s0 - tau_y) / m->ptw_p;
    double a = (tau_s - tau_y) / A;
    double em = expm1(a);
    double q = m->ptw_theta * eps_p / (A * em);
    double log_B, r1, r2;
    if (a >= 0.0) {
        double eq_m1 = expm1(-q), eq = 1.0 + eq_m1;
        double B = -eq_m1 + eq / (1.0 + em);
        log_B = log(B);
        r1 = eq / ((1.0 + em) * B);
        r2 = eq * em / ((1.0 + em) * B);
    } else {
        log_B = log_sum_exp(-expm1(-q), -a - q);
        r1 = exp(-a - q - log_B);
        r2 = expm1(-log_B);
    }
    double K = -r1 - r2 * q * (1.0 + em) / em;
    h->tau = tau_s + A * log_B;
    h->d_eps = r2 * m->ptw_theta / em;
    h->d_tau_s = 1.0 + K;
    h->d_tau_y = (-log_B + K * (tau_s - m->ptw_s0) / A + r2 * q) / m->ptw_p;
}

/* The p -> 0 limit of Eq. 2.4: tau = tau_s - R exp(-z), R = tau_s - tau_y, z = theta eps_p / R. */
static void ptw_hardening_p0(const struct mpm_material *m, double eps_p, double tau_s, double tau_y,
                             struct hardening *h)
{
    double range = tau_s - tau_y, z = m->ptw_theta * eps_p / range, ez = exp(-z);
    h->tau = tau_s - range * ez;
    h->d_eps = m->ptw_theta * ez;
    h->d_tau_y = ez * (1.0 + z);
    h->d_tau_s = 1.0 - h->d_tau_y;
}

/* Eq. 2.4 for any tau_s, tau_y: no hardening range (tau_s <= tau_y) gives tau_s; s0 = tau_y (the law's
 * singular point, A -> 0+) gives tau_y at once. */
static void ptw_tau(const struct mpm_material *m, double eps_p, double tau_s, double tau_y, struct hardening *h)
{
    if (tau_s <= tau_y) {
        *h = (struct hardening){tau_s, 0.0, 1.0, 0.0};
    } else if (fabs(m->ptw_s0 - tau_y) <= PTW_S0_TY_SMALL * m->ptw_s0) {
        *h = (struct hardening){tau_y, 0.0, 0.0, 1.0};
    } else if (m->ptw_p < PTW_P_SMALL) {
        ptw_hardening_p0(m, eps_p, tau_s, tau_y, h);
    } else {
        ptw_hardening(m, eps_p, tau_s, tau_y, h);
    }
}

/* tau_s and tau_y of Tang Eq. 2.7 at L = ln(eps_dot / (gamma xi_dot)), and their derivatives in L. */
struct ptw_rate_terms {
    double tau_s, tau_y, d_tau_s, d_tau_y;
};

/* Eq. 2.7: tau_s = max(s0 - (s0 - s_inf) erf(x), s0 e^(beta L)), tau_y = max(y0 - (y0 - y_inf) erf(x),
 * min(y1 e^(y2 L), s0 e^(beta L))), x = kappa T^ ln(gamma xi_dot / eps_dot) = -kappa T^ L.  Where both shock
 * terms exceed the largest value the erf terms can take (erf >= -1), erf is not evaluated: the max is the same. */
static void ptw_rate_terms(const struct mpm_material *m, double L, double T_hat, struct ptw_rate_terms *r)
{
    double shock_s = m->ptw_s0 * exp(m->ptw_beta * L);
    double medium_y = m->ptw_y1 * exp(m->ptw_y2 * L);
    double shock_y = fmin(medium_y, shock_s), d_shock_y = medium_y < shock_s ? m->ptw_y2 * medium_y
                                                                              : m->ptw_beta * shock_s;
    double s_range = m->ptw_s0 - m->ptw_sinf, y_range = m->ptw_y0 - m->ptw_yinf;
    if (shock_s >= m->ptw_s0 + fabs(s_range) && shock_y >= m->ptw_y0 + fabs(y_range)) {
        *r = (struct ptw_rate_terms){shock_s, shock_y, m->ptw_beta * shock_s, d_shock_y};
        return;
    }
    double x = -m->ptw_kappa * T_hat * L;
    double e = erf(x);
    double minus_de_dL = m->ptw_kappa * T_hat * (2.0 / sqrt(PI)) * exp(-x * x); /* -d erf(x)/dL */
    double s_erf = m->ptw_s0 - s_range * e, y_erf = m->ptw_y0 - y_range * e;
    r->tau_s = fmax(s_erf, shock_s);
    r->d_tau_s = s_erf >= shock_s ? s_range * minus_de_dL : m->ptw_beta * shock_s;
    r->tau_y = fmax(y_erf, shock_y);
    r->d_tau_y = y_erf >= shock_y ? y_range * minus_de_dL : d_shock_y;
}

/* PTW flow stress, Tang Eqs. 2.4-2.7.  The rate is floored at m->rate_floor (and kept > 0): ln(gamma xi/rate)
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
    struct ptw_flow flow;
    ptw_flow_stress_log_rate(m, eps_p, log(rate / (m->ptw_gamma * xi)), that, G, &flow);
    return flow.stress;
}

void ptw_flow_stress_log_rate(const struct mpm_material *m, double eps_p, double log_ratio, double T_hat, double G,
                              struct ptw_flow *flow)
{
    struct ptw_rate_terms r;
    struct hardening h;
    ptw_rate_terms(m, log_ratio, T_hat, &r);
    ptw_tau(m, eps_p, r.tau_s, r.tau_y, &h);
    flow->stress = 2.0 * G * h.tau; /* Tang Eq. 2.4 */
    flow->d_eps = 2.0 * G * h.d_eps;
    flow->d_log_rate = 2.0 * G * (h.d_tau_s * r.d_tau_s + h.d_tau_y * r.d_tau_y);
}
