/* Module-private (mpm/): the stress update of one material point, Tang Appendix A, as inline functions for the
 * host and the device (SC_HD, core/fastmath.h): mpm/stress_update.c runs them on the CPU over blocks of points, the
 * plastic returns' Newton iterations in vector lanes (STRESS_LANES of them, MPM_RETURN_LANES); mpm/cuda/step.cu
 * runs them on the GPU, a thread a point (STRESS_LANES 1).  One copy of the physics: stress_update.c says what the
 * update does and how it differs from the printed appendix. */
#ifndef SPRAYCOAT_MPM_STRESS_POINT_H
#define SPRAYCOAT_MPM_STRESS_POINT_H

#include <float.h>
#include <math.h>
#include <stdint.h>

#include "mpm/material.h"
#include "mpm/ptw_lane.h"

/* The lanes of the returns solved together: a block's (CPU), or one (a GPU thread). */
#ifndef STRESS_LANES
#define STRESS_LANES MPM_RETURN_LANES
#endif
#ifdef __cplusplus
#define SC_RESTRICT __restrict__
#else
#define SC_RESTRICT restrict
#endif

/* Convergence of the return (Tang Eqs. A6-A8, consistency at the end of the step): |f| <= NEWTON_FTOL sigma* at
 * an evaluated iterate, or a Newton step (or bracket) shorter than NEWTON_XTOL in ln d.  The same tolerances as
 * the regula-falsi return this Newton iteration replaced; a Newton step that short leaves an error of the order
 * of its square. */
#define NEWTON_MAX_ITER 100
#define NEWTON_FTOL     1e-10 /* |f| relative to sigma* */
#define NEWTON_XTOL     1e-13 /* step or bracket width in ln d (relative change of d) */
/* A Newton step from an iterate with |f| <= NEWTON_NEAR sigma* that followed another Newton step ends the return
 * unevaluated when Newton's quadratic contraction, measured over the last step, predicts |f| at the new iterate
 * below NEWTON_PREDICTED sigma* (newton_finish). */
#define NEWTON_NEAR      1e-6
#define NEWTON_PREDICTED 1e-12 /* a hundredth of NEWTON_FTOL */

/* ---- tensor helpers (xx, yy, zz, yz, xz, xy) ---- */

/* a:b with the off-diagonal components counted twice. */
SC_HD static inline double contract(const double a[6], const double b[6])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + 2.0 * (a[3] * b[3] + a[4] * b[4] + a[5] * b[5]);
}

/* Tang Eq. A5: sqrt(3/2 s:s). */
SC_HD static inline double von_mises(const double s[6])
{
    return sqrt(1.5 * contract(s, s));
}

/* Row a times column b of two 3 x 3 matrices: a0 b0 + a1 b1 + a2 b2, in that order. */
SC_HD static inline double row_col(double a0, double a1, double a2, double b0, double b1, double b2)
{
    return a0 * b0 + a1 * b1 + a2 * b2;
}

/* Tang Eq. A2: sigma_R = sigma + sigma Omega^T + Omega sigma, Omega = W dt skew with W_yz, W_xz, W_xy given.
 * (Omega sigma)_ij is summed over k = 0, 1, 2 with Omega's zero diagonal multiplied as well, so that the bits are
 * those of the matrix product; written out in scalars, since the product through 3 x 3 arrays on the stack
 * stalled on store forwarding (about a third of mpm_stress_begin's samples). */
FM_INLINE void jaumann_rotate(const double sigma[6], const double spin[3], double rotated[6])
{
    double s00 = sigma[0], s11 = sigma[1], s22 = sigma[2], s12 = sigma[3], s02 = sigma[4], s01 = sigma[5];
    double w12 = spin[0], w02 = spin[1], w01 = spin[2], w21 = -spin[0], w20 = -spin[1], w10 = -spin[2];
    /* ws = Omega sigma; sigma Omega^T = -sigma Omega = (Omega sigma)^T since sigma is symmetric and Omega skew */
    double ws00 = row_col(0.0, w01, w02, s00, s01, s02), ws01 = row_col(0.0, w01, w02, s01, s11, s12);
    double ws02 = row_col(0.0, w01, w02, s02, s12, s22);
    double ws10 = row_col(w10, 0.0, w12, s00, s01, s02), ws11 = row_col(w10, 0.0, w12, s01, s11, s12);
    double ws12 = row_col(w10, 0.0, w12, s02, s12, s22);
    double ws20 = row_col(w20, w21, 0.0, s00, s01, s02), ws21 = row_col(w20, w21, 0.0, s01, s11, s12);
    double ws22 = row_col(w20, w21, 0.0, s02, s12, s22);
    rotated[0] = sigma[0] + ws00 + ws00;
    rotated[1] = sigma[1] + ws11 + ws11;
    rotated[2] = sigma[2] + ws22 + ws22;
    rotated[3] = sigma[3] + ws12 + ws21;
    rotated[4] = sigma[4] + ws02 + ws20;
    rotated[5] = sigma[5] + ws01 + ws10;
}

/* ---- the consistent plastic strain increment ---- */

/* The consistency condition f(d) = sigma* - 3 G d - sigma_y(eps_p + d, max(d/dt, rate_floor)) (Tang Eqs. A6-A8
 * with the flow stress at the end of the step), decreasing in d, and its derivative in u = ln d:
 *   df/du = -d (3 G + d sigma_y/d eps_p) - d sigma_y/d ln(rate)   (the last term 0 where the rate is floored).
 * At u = -inf (d = 0, the rate floored) this is the yield check: f = sigma* - sigma_y(eps_p, rate_floor). */
FM_INLINE void consistency_lane(const struct mpm_material *m, int p_small, double u, double eps_p, double G,
                                double trial, double T_hat, double log_rate_scale, double log_ratio_floor, double *d,
                                double *f, double *df_du, double *yield)
{
    double L = u - log_rate_scale;
    int floored = !(L > log_ratio_floor);
    double d_here = fm_exp(u);
    struct ptw_flow flow = ptw_lane_flow(m, p_small, eps_p + d_here, fm_select(floored, log_ratio_floor, L), T_hat, G);
    *d = d_here;
    *yield = flow.stress;
    *f = trial - 3.0 * G * d_here - flow.stress;
    *df_du = -d_here * (3.0 * G + flow.d_eps) - fm_select(floored, 0.0, flow.d_log_rate);
}

/* The lanes of one evaluation round of a block's returns, structure of arrays. */
struct return_lanes {
    double u[STRESS_LANES], eps_p[STRESS_LANES], G[STRESS_LANES], trial[STRESS_LANES];
    double T_hat[STRESS_LANES], log_rate_scale[STRESS_LANES], log_ratio_floor[STRESS_LANES];
    double d[STRESS_LANES], f[STRESS_LANES], df_du[STRESS_LANES], yield[STRESS_LANES];
    uint16_t check[STRESS_LANES]; /* 1: the yield check (u = -inf) */
};

/* Where a return stands between two evaluations (what the next evaluation is for). */
enum return_phase {
    RETURN_YIELD_CHECK, /* the yield check before Newton starts (no usable first guess) */
    RETURN_START,       /* f at Newton's first iterate */
    RETURN_STEP,        /* f at the iterate of a Newton step or bisection */
    RETURN_RECHECK      /* the yield check of a step that left the bracket through u_lo before the point was proven
                           plastic (an elastic point's f has no root above u_lo) */
};

/* The returns being solved, in lanes (structure of arrays): the evaluation's lanes, the Newton iteration's state
 * (the bracket [u_lo, u_hi] with f(u_hi) <= 0, and f(u_lo) > 0 once `plastic` is set; f_prev, the residual of the
 * Newton iterate before u or NAN; `last`: u came from a step or bracket shorter than NEWTON_XTOL), which return
 * of the call each lane is, and what the last advance decided (`outcome`, with the result of an ended return). */
enum lane_outcome { LANE_GOES_ON, LANE_ENDED };

struct newton_lanes {
    struct return_lanes eval;
    double u_lo[STRESS_LANES], u_hi[STRESS_LANES], f_prev[STRESS_LANES];
    int64_t phase[STRESS_LANES], plastic[STRESS_LANES], iter[STRESS_LANES], last[STRESS_LANES];
    int64_t outcome[STRESS_LANES];
    double result_d[STRESS_LANES], result_yield[STRESS_LANES];
    int index[STRESS_LANES];
};

/* a where the flag c (0 or 1) is 1, else b, without a branch (as fm_select for doubles).  The flags of
 * advance_lane are 0 or 1 in 64-bit integers, negated as 1 - c: with _Bool operations in it gcc 12 did not
 * vectorise the loop. */
FM_INLINE int64_t select_int(int64_t c, int64_t a, int64_t b)
{
    return (a & -c) | (b & (c - 1));
}

FM_INLINE int64_t flag(int condition)
{
    return (int64_t)condition;
}

/* Lane i after its evaluation (d, f, df/du and sigma_y at the point its phase asked for), for the phases START,
 * STEP and RECHECK; branch-free, so that the loop over the lanes vectorises, each lane doing the scalar iteration's
 * arithmetic.
 * - RECHECK: a yield check that fails ends the return elastic (d = 0, sigma_y(eps_p, rate_floor)); one that passes
 *   proves the point plastic, and the iteration bisects.
 * - STEP: an iterate whose step (or bracket) was shorter than NEWTON_XTOL in u ends it, once evaluated; otherwise
 *   a Newton step follows, as from START.
 * - Newton in u = ln d stops when |f| <= NEWTON_FTOL sigma* or after NEWTON_MAX_ITER steps; a step that leaves
 *   the bracket becomes a bisection, after the yield check (RECHECK) if it left through u_lo before the point was
 *   proven plastic.
 * - A Newton step predicted to converge ends the return without evaluating f at the new iterate (NEWTON_NEAR,
 *   NEWTON_PREDICTED).  On the impact benchmark f fell from about 1e-4 sigma* at the first guess to 1e-8 - 1e-9
 *   after one step and to round-off after the second: the third evaluation, three tenths of the returns' PTW
 *   evaluations, only confirmed what Newton's contraction had already shown.  With f_k and f_{k-1} the residuals
 *   of two Newton iterates in a row, quadratic convergence (e_{k+1} = C e_k^2) predicts |f_{k+1}| ~ |f_k| (f_k /
 *   f_{k-1})^2; where that is below NEWTON_PREDICTED sigma*, a hundredth of the tolerance, and |f_k| <= NEWTON_NEAR
 *   sigma*, the return ends at next with d = e^next and the flow stress of the consistency condition f = 0 (Eq.
 *   A8), sigma* - 3 G d, which differs from sigma_y(d) by f(next), of the order of round-off there (at most
 *   1.2e-11 sigma* over the 28.8 million such ends of the benchmark, checked by evaluating them).  A bisection or
 *   a recheck resets the history (f_prev NAN): a bracketing step says nothing about the contraction. */
FM_INLINE void advance_lane(struct newton_lanes *SC_RESTRICT l, int i)
{
    const struct return_lanes *e = &l->eval;
    double u = e->u[i], f = e->f[i], trial = e->trial[i], u_lo = l->u_lo[i], u_hi = l->u_hi[i];
    int64_t phase = l->phase[i], iter = l->iter[i], last = l->last[i];
    int64_t recheck = flag(phase == RETURN_RECHECK), checking = flag(phase == RETURN_YIELD_CHECK);
    int64_t held = recheck | checking; /* the bracket, the count and the history stay */
    int64_t step = flag(phase == RETURN_STEP), ends_stepping = step & last;
    /* the Newton step from u (START, or STEP without `last`) */
    int64_t iter_next = iter + step;
    int64_t converged = flag(iter_next >= NEWTON_MAX_ITER) | flag(fabs(f) <= NEWTON_FTOL * trial);
    int64_t above = flag(f > 0.0), plastic = l->plastic[i] | above;
    double lo = fm_select((int)above, u, u_lo), hi = fm_select((int)above, u_hi, u);
    double next = u - f / e->df_du[i];
    int64_t inside = flag(next > lo) & flag(next < hi);
    int64_t to_recheck = (1 - inside) & (1 - plastic) & flag(!(next > lo));
    double f_prev = l->f_prev[i]; /* |f| (f / f_prev)^2 <= P sigma* without a division; false for NAN */
    int64_t predicted = inside & flag(fabs(f) <= NEWTON_NEAR * trial) &
                        flag(fabs(f) * f * f <= NEWTON_PREDICTED * trial * f_prev * f_prev);
    double mid = 0.5 * (lo + hi), d_next = fm_exp(next);
    /* the outcome, and the state of a lane that goes on */
    int64_t recheck_fails = recheck & flag(!(trial > e->yield[i]));
    int64_t ended = select_int(recheck, recheck_fails, ends_stepping | converged);
    int64_t unevaluated = (1 - recheck) & (1 - ended) & predicted;
    l->outcome[i] = select_int(ended | unevaluated, LANE_ENDED, LANE_GOES_ON);
    l->result_d[i] = fm_select((int)unevaluated, d_next, e->d[i]);
    l->result_yield[i] = fm_select((int)unevaluated, trial - 3.0 * e->G[i] * d_next, e->yield[i]); /* Eq. A8 */
    double recheck_mid = 0.5 * (u_lo + u_hi);
    l->u_lo[i] = fm_select((int)held, u_lo, lo);
    l->u_hi[i] = fm_select((int)held, u_hi, hi);
    l->plastic[i] = recheck | plastic;
    l->iter[i] = select_int(held, iter, iter_next);
    l->f_prev[i] = fm_select((int)held, f_prev, fm_select((int)inside, f, NAN));
    l->eval.u[i] =
        fm_select((int)recheck, recheck_mid, fm_select((int)to_recheck, u, fm_select((int)inside, next, mid)));
    l->last[i] =
        select_int(held, select_int(recheck, flag(u_hi - u_lo <= NEWTON_XTOL), last),
                   select_int(inside | to_recheck, flag(fabs(next - u) <= NEWTON_XTOL), flag(hi - lo <= NEWTON_XTOL)));
    int64_t goes_to_recheck = (1 - recheck) & to_recheck;
    l->phase[i] = select_int(checking, phase, /* yield_checks decides */
                             select_int(goes_to_recheck, RETURN_RECHECK, RETURN_STEP));
    l->eval.check[i] = (uint16_t)goes_to_recheck;
}
/* The lanes of the returns' set-up, structure of arrays: inputs, then results. */
struct setup_lanes {
    double eps_p[STRESS_LANES], G[STRESS_LANES], trial[STRESS_LANES], rho[STRESS_LANES];
    double T[STRESS_LANES];
    double Tm[STRESS_LANES], previous[STRESS_LANES], previous_yield[STRESS_LANES];
    double dt[STRESS_LANES], log_dt[STRESS_LANES];
    double T_hat[STRESS_LANES], log_rate_scale[STRESS_LANES], log_ratio_floor[STRESS_LANES];
    double u[STRESS_LANES], u_lo[STRESS_LANES], u_hi[STRESS_LANES];
    uint16_t start[STRESS_LANES]; /* 1: Newton starts at u (a first guess), 0: the yield check first */
};

/* ln x rounded to a multiple of ln 2 from the binary exponent of x > 0 (x = 2^e m, 1 <= m < 2): e ln 2 <= ln x <
 * (e + 1) ln 2.  The bracket's ends need only lie on the right side of the root. */
FM_INLINE double log_below(double x)
{
    double exponent;
    fm_split(x, &exponent);
    return exponent * M_LN2;
}

FM_INLINE double log_above(double x)
{
    double exponent;
    fm_split(x, &exponent);
    return (exponent + 1.0) * M_LN2;
}

/* The start of the return of a point whose trial stress exceeds 2 G y_inf (Tang Eq. 2.8 and the bracket).  d lies
 * in [d_lo, d_hi], d_lo = rate_floor dt (kept below d_hi), d_hi = sigma* / (3 G) where f <= -sigma_y <= 0.  A
 * point plastic in the last step (increment d0, flow stress sigma0) starts Newton from one Newton step in ln d on
 * the model f = sigma* - 3 G d - sigma0 (d/d0)^beta, beta the rate exponent of the shock-regime flow stress
 * (Eq. 2.7), limited to a factor e^2 either way: it costs no PTW evaluation and saves about half a Newton step on
 * the impact benchmark (f > 0 anywhere proves the point plastic, f(0) >= f(d), so the yield check is needed only
 * if Newton heads below d_lo).  Otherwise the yield check comes first, and Newton starts from the
 * rate-independent increment.  sigma_y is flat in the rate at low rates and a power of it above (the shock
 * regime); f is concave in u over most of the range, and from that guess Newton converges in 2-3 steps.  Written
 * for lanes (core/fastmath*.h, selects): the libm calls of this set-up cost a tenth of the step. */
FM_INLINE void setup_lane(const struct mpm_material *m, const struct mpm_material_constants *c, int i,
                          struct setup_lanes *SC_RESTRICT l)
{
    double G = l->G[i], trial = l->trial[i], dt = l->dt[i], T = l->T[i];
    /* ln(gamma xi_dot), Eq. 2.8: ln(gamma (4 pi / 3 M)^(1/3) / 2) + ln(G^3 / rho) / 6 */
    double log_gamma_xi = c->log_gamma_xi_factor + fm_log(G * G * G / l->rho[i]) / 6.0;
    double Tm = l->Tm[i];
    Tm = fm_select(Tm != Tm, scg_lane_melt_temperature(m, l->rho[i]), Tm); /* NAN: not computed yet */
    l->T_hat[i] = fm_select(T > 0.0, T / Tm, 0.0);
    l->log_rate_scale[i] = fm_select(dt > 0.0, log_gamma_xi + l->log_dt[i], INFINITY); /* L = ln d - this */
    l->log_ratio_floor[i] = c->log_rate_floor - log_gamma_xi;                          /* L at the rate floor */
    double d_hi = trial / (3.0 * G), floor_dt = m->rate_floor * dt, hi_part = 1e-3 * d_hi;
    double d_lo = fm_select(floor_dt < hi_part, floor_dt, hi_part);
    d_lo = fm_select(d_lo > DBL_MIN, d_lo, DBL_MIN);
    l->u_lo[i] = log_below(d_lo), l->u_hi[i] = log_above(d_hi);
    double d0 = l->previous[i], sigma0 = l->previous_yield[i];
    double step = (trial - 3.0 * G * d0 - sigma0) / (3.0 * G * d0 + m->ptw_beta * sigma0);
    step = fm_select(step < 2.0, step, 2.0);
    step = fm_select(step > -2.0, step, -2.0);
    double guessed = d0 * fm_exp(step);
    double previous = fm_select((d0 > 0.0) & (sigma0 > 0.0), guessed, d0); /* &, not &&: no branch */
    int start = (previous > d_lo) & (previous < d_hi);
    l->start[i] = (uint16_t)start;
    l->u[i] = fm_select(start, fm_log(fm_select(start, previous, 1.0)), 0.0);
}
/* The yield check of lane i before Newton (phase RETURN_YIELD_CHECK, a point without a first guess; rare), after
 * advance_lane (which took the lane for another phase): one that fails ends the return elastic; one that passes
 * starts Newton at the rate-independent increment (sigma* - sigma_y(eps_p, floor)) / (3 G), where f <= 0. */
SC_HD static inline void yield_check_lane(struct newton_lanes *l, int i)
{
    struct return_lanes *e = &l->eval;
    l->result_d[i] = e->d[i], l->result_yield[i] = e->yield[i];
    if (!(e->trial[i] > e->yield[i])) {
        l->outcome[i] = LANE_ENDED;
        return;
    }
    double guess = log((e->trial[i] - e->yield[i]) / (3.0 * e->G[i]));
    e->u[i] = guess > l->u_lo[i] && guess < l->u_hi[i] ? guess : 0.5 * (l->u_lo[i] + l->u_hi[i]);
    e->check[i] = 0;
    l->plastic[i] = 1, l->phase[i] = RETURN_START, l->outcome[i] = LANE_GOES_ON;
}

/* The set-up return of lane i of s into Newton lane i of l. */
FM_INLINE void start_lane(const struct setup_lanes *SC_RESTRICT s, int i, struct newton_lanes *SC_RESTRICT l)
{
    struct return_lanes *e = &l->eval;
    e->u[i] = s->u[i], e->check[i] = (uint16_t)(1 - s->start[i]), e->eps_p[i] = s->eps_p[i];
    e->G[i] = s->G[i], e->trial[i] = s->trial[i], e->T_hat[i] = s->T_hat[i];
    e->log_rate_scale[i] = s->log_rate_scale[i], e->log_ratio_floor[i] = s->log_ratio_floor[i];
    l->u_lo[i] = s->u_lo[i], l->u_hi[i] = s->u_hi[i], l->f_prev[i] = NAN;
    l->phase[i] = s->start[i] ? RETURN_START : RETURN_YIELD_CHECK;
    l->plastic[i] = 0, l->iter[i] = 0, l->last[i] = 0, l->index[i] = i;
}

#if STRESS_LANES == 1
/* The plastic return of one point (a GPU thread's): mpm_stress_returns of stress_update.c on one lane, the same
 * set-up, evaluations and Newton steps, so the same iterates as the point's lane in a CPU block. */
SC_HD static inline void stress_return_one(const struct mpm_material *m, struct mpm_return *r)
{
    struct setup_lanes setup;
    struct newton_lanes lanes;
    const struct mpm_material_constants *c = r->constants;
    setup.eps_p[0] = r->eps_p, setup.G[0] = r->G, setup.trial[0] = r->trial, setup.rho[0] = r->rho;
    setup.T[0] = r->T, setup.Tm[0] = r->Tm, setup.previous[0] = r->previous;
    setup.previous_yield[0] = r->previous_yield, setup.dt[0] = r->dt, setup.log_dt[0] = r->log_dt;
    setup_lane(m, c, 0, &setup);
    start_lane(&setup, 0, &lanes);
    int p_small = m->ptw_p < PTW_P_SMALL;
    struct return_lanes *e = &lanes.eval;
    for (;;) {
        consistency_lane(m, p_small, fm_select(e->check[0], -INFINITY, e->u[0]), e->eps_p[0], e->G[0], e->trial[0],
                         e->T_hat[0], e->log_rate_scale[0], e->log_ratio_floor[0], &e->d[0], &e->f[0], &e->df_du[0],
                         &e->yield[0]);
        advance_lane(&lanes, 0);
        if (lanes.phase[0] == RETURN_YIELD_CHECK)
            yield_check_lane(&lanes, 0);
        if (lanes.outcome[0] == LANE_ENDED) {
            r->d = lanes.result_d[0], r->yield = lanes.result_yield[0];
            return;
        }
    }
}
#endif

/* ---- energy, pressure, viscosity ---- */

/* Tang Eqs. 3.41-3.43 / A9-A11: returns p^{n+1}, updates *energy from e^n to e^{n+1}. */
FM_INLINE double eos_energy_update(const struct mpm_material *m, double rho_new, double deviatoric_work,
                                   double pressure_old, double volume0, double dV, double *energy)
{
    double e_trial = *energy + deviatoric_work - 0.5 * dV * pressure_old; /* Eq. 3.41 */
    double A, B;
    eos_coefficients(m, rho_new, &A, &B);
    double p = (A + B * e_trial / volume0) / (1.0 + 0.5 * B * dV / volume0); /* Eq. 3.43 */
    *energy = e_trial - 0.5 * dV * p;                                        /* Eq. 3.40 */
    return p;
}

/* Zhang's artificial bulk viscosity: q = rho l^2 c_q epsv_dot^2 - c_l rho l c epsv_dot in compression. */
SC_HD static inline double bulk_viscosity_pressure(const struct mpm_material_constants *c,
                                                   const struct mpm_bulk_viscosity *q, double rho_new,
                                                   double volumetric_rate)
{
    if (!q || !(volumetric_rate < 0.0))
        return 0.0;
    double l = q->length;
    return rho_new * l * l * q->quadratic * volumetric_rate * volumetric_rate -
           q->linear * rho_new * l * c->wave_speed * volumetric_rate;
}

SC_HD static inline int all_finite(const struct mpm_point_state *s)
{
    double sum = s->pressure + s->viscosity + s->eps_p + s->T + s->energy + s->rho + s->yield_stress;
    for (int k = 0; k < 6; k++)
        sum += s->stress[k];
    return isfinite(sum);
}
/* Whether T >= Tm(rho_new) (Eq. 2.9); *Tm is the melt temperature when it was computed, else NAN.  Tm grows with
 * the density where c->melt_T_low > 0 (mpm_material_prepare), so a point at least that dense and colder than
 * Tm(melt_eta_low) is below melt without evaluating Eq. 2.9. */
SC_HD static inline int at_or_above_melt(const struct mpm_material *m, const struct mpm_material_constants *c, double T,
                                         double rho_new, double *Tm)
{
    if (T < c->melt_T_low && rho_new >= c->melt_eta_low * m->density) {
        *Tm = NAN;
        return 0;
    }
    *Tm = scg_melt_temperature(m, rho_new);
    return !(T < *Tm);
}

/* The radial return onto the PTW flow stress (Eqs. A5-A8) set up: the consistency problem of the point, its
 * start left to the first pass of mpm_stress_returns (setup_lane). */
SC_HD static inline void ptw_return_begin(const struct mpm_material_constants *c, const struct mpm_point_state *state,
                                          double G, double trial, double dt, double log_dt, double Tm, double rho_new,
                                          struct mpm_return *r)
{
    r->eps_p = state->eps_p, r->G = G, r->trial = trial;
    r->constants = c, r->rho = rho_new, r->T = state->T, r->Tm = Tm;
    r->previous = state->plastic_increment, r->previous_yield = state->yield_stress;
    r->dt = dt, r->log_dt = log_dt;
    r->d = 0.0, r->yield = 0.0;
}

/* A factor below 1 by far more than the rounding of x < f b b: x < f b b proves sqrt(x) < b, so sqrt(x) <= b,
 * exactly as the square root would decide (sqrt is correctly rounded and monotone, b a double). */
#define BELOW_SQUARE 0.999999

/* Deviatoric part of the step (Eqs. A1-A8) up to the return: w->s_new holds the elastic trial (Eq. A1.3) and is
 * set to 0 when melted or without shear stiffness; returns 1 when the point needs the plastic return (w->ret set
 * up). */
FM_INLINE int deviatoric_begin(const struct mpm_material *m, const struct mpm_material_constants *c,
                               const struct mpm_point_state *state, double G, double dt, double log_dt,
                               struct mpm_stress_work *w)
{
    double Tm;
    w->yield = 0.0;
    w->d = 0.0;
    if ((w->melted = at_or_above_melt(m, c, state->T, w->rho_new, &Tm)) != 0) {
        for (int k = 0; k < 6; k++)
            w->s_new[k] = 0.0;
        return 0;
    }
    double trial_squared = 1.5 * contract(w->s_new, w->s_new); /* Eq. A5: von_mises(s_new) is its root */
    if (m->strength == MPM_STRENGTH_ELASTIC)
        return 0;
    /* sigma_y >= 2 G min(y_inf, s_inf) at any rate and strain below melt (tau >= tau_y >= y_inf where tau_s >
     * tau_y, else tau = tau_s >= s_inf, Eq. 2.7; s_inf < y_inf is a valid material): a trial stress below that is
     * elastic without evaluating PTW (most points of a substrate, most steps); most of those are told by the
     * square, without the square root's latency */
    double bound = 2.0 * G * fmin(m->ptw_yinf, m->ptw_sinf);
    if (G > 0.0 && trial_squared < BELOW_SQUARE * bound * bound) {
        w->yield = state->yield_stress;
        return 0;
    }
    double trial = sqrt(trial_squared);
    if (G > 0.0 && trial <= bound) {
        w->yield = state->yield_stress;
        return 0;
    }
    if (!(G > 0.0)) { /* no shear stiffness left (G clamped at 0): no deviatoric stress */
        for (int k = 0; k < 6; k++)
            w->s_new[k] = 0.0;
        return 0;
    }
    ptw_return_begin(c, state, G, trial, dt, log_dt, Tm, w->rho_new, &w->ret);
    return 1;
}

/* Tang Eqs. A3, A4 and A1.3 into w: s_rot the deviator of the rotated stress, the strain increment and its
 * trace/3, and the elastic trial s_new = s_rot + 2 G dev(strain).  Written out in scalars: as loops over the six
 * components (deviator), gcc vectorised them with the deviators in stack arrays, stored in halves or one by one
 * and loaded whole, which stalled on store forwarding (a fifth of mpm_stress_begin's samples).  The same
 * operations: an off-diagonal deviator component t - 0.0 is t. */
FM_INLINE void elastic_trial(const double sigma_rot[6], const double e[6], double G, struct mpm_stress_work *w)
{
    double mean = (sigma_rot[0] + sigma_rot[1] + sigma_rot[2]) / 3.0;
    double volumetric = (e[0] + e[1] + e[2]) / 3.0, two_G = 2.0 * G;
    double s0 = sigma_rot[0] - mean, s1 = sigma_rot[1] - mean, s2 = sigma_rot[2] - mean;
    double s3 = sigma_rot[3], s4 = sigma_rot[4], s5 = sigma_rot[5];
    w->volumetric = volumetric;
    w->s_rot[0] = s0, w->s_rot[1] = s1, w->s_rot[2] = s2, w->s_rot[3] = s3, w->s_rot[4] = s4, w->s_rot[5] = s5;
    w->s_new[0] = s0 + two_G * (e[0] - volumetric);
    w->s_new[1] = s1 + two_G * (e[1] - volumetric);
    w->s_new[2] = s2 + two_G * (e[2] - volumetric);
    w->s_new[3] = s3 + two_G * e[3];
    w->s_new[4] = s4 + two_G * e[4];
    w->s_new[5] = s5 + two_G * e[5];
    w->strain[0] = e[0], w->strain[1] = e[1], w->strain[2] = e[2];
    w->strain[3] = e[3], w->strain[4] = e[4], w->strain[5] = e[5];
}

/* mpm_stress_begin, inlined into it and into the block's loop (mpm_stress_begin_block). */
FM_INLINE int stress_begin(const struct mpm_material *m, const struct mpm_material_constants *c,
                           const double strain_increment[6], const double spin_increment[3], double G, double dt,
                           double log_dt, double volume0, double volume_new, const struct mpm_point_state *state,
                           struct mpm_stress_work *w)
{
    double sigma_rot[6];
    w->rho_new = m->density * volume0 / volume_new;
    jaumann_rotate(state->stress, spin_increment, sigma_rot); /* Eq. A2 */
    elastic_trial(sigma_rot, strain_increment, G, w);         /* Eqs. A3, A4, A1.3 */
    w->returning = deviatoric_begin(m, c, state, G, dt, log_dt, w);
    return w->returning;
}

/* mpm_stress_finish, inlined into it and into the block's loop (mpm_stress_finish_block). */
FM_INLINE int stress_finish(const struct mpm_material *m, const struct mpm_material_constants *c,
                            const struct mpm_bulk_viscosity *q, double dt, double volume0, double volume_old,
                            double volume_new, struct mpm_stress_work *w, struct mpm_point_state *state,
                            struct mpm_update_result *result)
{
    double rho_new = w->rho_new, *s_new = w->s_new;
    double yield = w->returning ? w->ret.yield : w->yield, d = w->returning ? w->ret.d : w->d;
    if (w->returning && d > 0.0)
        for (int k = 0; k < 6; k++)
            s_new[k] *= yield / w->ret.trial; /* Eq. A8 */

    double volume_half = 0.5 * (volume_old + volume_new), dV = volume_new - volume_old;
    double s_half[6];
    for (int k = 0; k < 6; k++)
        s_half[k] = 0.5 * (w->s_rot[k] + s_new[k]);
    double plastic_work = volume_half * yield * d;
    double energy_old = state->energy;
    double p = eos_energy_update(m, rho_new, volume_half * contract(s_half, w->strain), state->pressure, volume0, dV,
                                 &state->energy);
    double volumetric_rate = dt > 0.0 ? 3.0 * w->volumetric / dt : 0.0;
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
    state->melted = w->melted ? 1.0 : 0.0;
    result->eps_p_increment = d;
    result->von_mises = von_mises(s_new);
    result->plastic_work = plastic_work;
    result->energy_increment = state->energy - energy_old;
    return all_finite(state) && isfinite(result->von_mises) && isfinite(plastic_work) ? 0 : -1;
}

#endif
