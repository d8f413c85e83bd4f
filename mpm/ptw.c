/* Preston-Tonks-Wallace flow stress (Tang Section 2.4.2, Eqs. 2.4-2.8, in the form of Preston, Tonks & Wallace
 * 2003) and the MTS shear modulus G(T) (Eq. 2.6).
 *
 * Tang prints the hardening constant as d and the high-rate exponent as s1; they are ptw_p and ptw_beta here.
 * The overdriven-shock terms of Eq. 2.7 enter through max/min at every strain rate, as in PTW 2003 and LANL
 * impala (Uintah applies them only above 1e3 /s; docs/references.md "PTW").  The flow stress is the von
 * Mises stress 2 G tau (Eq. 2.4) with G the current G(T).  The law itself is in mpm/ptw_lane.h, written for
 * vector lanes (no libm calls, no branches). */
#include "mpm/material.h"
#include "mpm/ptw_lane.h"

#include <float.h>
#include <math.h>

#define PI 3.14159265358979323846

/* The flow stress with T^ = T/Tm (< 1) and xi_dot precomputed, and at log_ratio = ln(rate / (gamma xi_dot)) (the
 * rate already floored). */
static double ptw_flow_stress_at(const struct mpm_material *m, double eps_p, double rate, double that, double xi,
                                 double G);
static void ptw_flow_stress_log_rate(const struct mpm_material *m, double eps_p, double log_ratio, double T_hat,
                                     double G, struct ptw_flow *flow);

/* MTS shear modulus, Tang Eq. 2.6: G0 - D / (exp(T0/T) - 1), clamped at 0; G0 at T <= 0 (the 0 K limit). */
double mpm_mts_shear_modulus(const struct mpm_material *m, double T)
{
    if (!(T > 0.0))
        return m->G0;
    double G = m->G0 - m->D / expm1(m->T0 / T);
    return G > 0.0 ? G : 0.0;
}

/* G0 - D / (exp(T0/T) - 1) > 0  <=>  exp(T0/T) > 1 + D/G0  <=>  T < T0 / ln(1 + D/G0); with D = 0 at every T. */
double mpm_mts_positive_below(const struct mpm_material *m)
{
    if (!(m->D > 0.0))
        return INFINITY;
    return m->T0 / log1p(m->D / m->G0);
}

/* Tang Eq. 2.8 in SI: xi_dot = 1/2 (4 pi rho / (3 M))^(1/3) sqrt(G / rho), M the atomic mass in kg. */
double mpm_ptw_xi_dot(const struct mpm_material *m, double rho, double G)
{
    if (!(rho > 0.0) || !(G > 0.0))
        return 0.0;
    return 0.5 * cbrt(4.0 * PI * rho / (3.0 * m->atomic_mass)) * sqrt(G / rho);
}

/* PTW flow stress, Tang Eqs. 2.4-2.7.  The rate is floored at m->rate_floor (and kept > 0): ln(gamma xi/rate)
 * is infinite at rate 0, and elastic or barely plastic points have no meaningful plastic rate. */
double mpm_ptw_flow_stress(const struct mpm_material *m, double eps_p, double rate, double T, double Tm, double rho,
                           double G)
{
    if (!(G > 0.0) || !(Tm > 0.0) || !(T < Tm))
        return 0.0;
    return ptw_flow_stress_at(m, eps_p, rate, T > 0.0 ? T / Tm : 0.0, mpm_ptw_xi_dot(m, rho, G), G);
}

static double ptw_flow_stress_at(const struct mpm_material *m, double eps_p, double rate, double that, double xi,
                                 double G)
{
    if (rate < m->rate_floor)
        rate = m->rate_floor;
    if (!(rate > 0.0))
        rate = DBL_MIN;
    struct ptw_flow flow;
    ptw_flow_stress_log_rate(m, eps_p, log(rate / (m->ptw_gamma * xi)), that, G, &flow);
    return flow.stress;
}

/* The lane form of mpm/ptw_lane.h on one point: the bits of every lane of stress_update.c's blocks. */
static void ptw_flow_stress_log_rate(const struct mpm_material *m, double eps_p, double log_ratio, double T_hat,
                                     double G, struct ptw_flow *flow)
{
    *flow = ptw_lane_flow(m, m->ptw_p < PTW_P_SMALL, eps_p, log_ratio, T_hat, G);
}
