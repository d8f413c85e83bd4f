/* Stress update of one material point, Tang Appendix A (Eqs. A1-A11) with the energy equation of Section 3.5.2
 * (Eqs. 3.38-3.43), adiabatic heating (Eq. 3.44), the SCG melt (Eq. 2.9) and Zhang's artificial bulk viscosity.
 *
 * Symmetric tensors are stored xx, yy, zz, yz, xz, xy with tensor components; a double contraction a:b counts
 * every off-diagonal pair twice.  Differences from the printed appendix:
 * - The plastic strain increment is not the one-step linearisation of Eq. A6 but the root of the consistency
 *   condition with the rate-dependent PTW flow stress evaluated at the END of the step,
 *       f(d) = sigma* - 3 G d - sigma_y(eps_p + d, max(d/dt, rate_floor)) = 0,
 *   by a safeguarded Newton iteration in u = ln d with the analytic derivative of PTW (ptw.c), inside the
 *   bracket [rate_floor dt, sigma* / (3 G)] (PTW is steep in the rate in the shock regime, docs/references.md "PTW").
 * - The yield check uses sigma_y(eps_p, rate_floor): the smallest flow stress the point can have.
 * - The rate floor m->rate_floor stands for the plastic strain rate of an elastic or barely plastic point
 *   (PTW needs ln(gamma xi_dot / rate) finite; docs/physics.md errata).
 * - Melting (T >= Tm(rho_new)) removes the deviatoric stress for either strength model; MPM_STRENGTH_ELASTIC
 *   never yields and reports yield_stress 0.
 * - The artificial bulk viscosity q is kept apart from the Cauchy stress (state->viscosity) and its work enters
 *   the internal energy after the EOS solve.
 * mpm_stress_update, one point through the three phases (mpm_stress_begin, mpm_stress_returns,
 * mpm_stress_finish), is the reference; the solver runs the phases over blocks of points, the returns' Newton
 * iterations packed into vector lanes (PTW from mpm/ptw_lane.h), and a lane's arithmetic is that of the point
 * alone: tests/test_mpm_stress_update.c (11) checks that a block gives each point the bits of its update alone. */

#include "mpm/material.h"
#include "mpm/ptw_lane.h"
#include "mpm/stress_point.h"

#include <float.h>
#include <math.h>
#include <stdint.h>

/* f, df/du, d and sigma_y of lanes 0..n-1 (n a multiple of 16).  The loops have no branches and no calls, and
 * vectorise at -O3 (the #pragma at the top); the material is copied so that the stores cannot alias it. */
static void consistency_lanes(const struct mpm_material *material, int n, struct return_lanes *restrict l)
{
    const struct mpm_material m = *material;
    if (m.ptw_p < PTW_P_SMALL) {
        for (int i = 0; i < n; i++)
            consistency_lane(&m, 1, fm_select(l->check[i], -INFINITY, l->u[i]), l->eps_p[i], l->G[i], l->trial[i],
                             l->T_hat[i], l->log_rate_scale[i], l->log_ratio_floor[i], &l->d[i], &l->f[i], &l->df_du[i],
                             &l->yield[i]);
    } else {
        for (int i = 0; i < n; i++)
            consistency_lane(&m, 0, fm_select(l->check[i], -INFINITY, l->u[i]), l->eps_p[i], l->G[i], l->trial[i],
                             l->T_hat[i], l->log_rate_scale[i], l->log_ratio_floor[i], &l->d[i], &l->f[i], &l->df_du[i],
                             &l->yield[i]);
    }
}

static void advance_lanes(struct newton_lanes *restrict l, int n)
{
    for (int i = 0; i < n; i++)
        advance_lane(l, i);
}

/* The yield check before Newton (YIELD_CHECK, a point without a first guess; rare), one lane at a time, after
 * advance_lanes (which took the lane for another phase): one that fails ends the return elastic; one that passes
 * starts Newton at the rate-independent increment (sigma* - sigma_y(eps_p, floor)) / (3 G), where f <= 0. */
static void yield_checks(struct newton_lanes *l, int n)
{
    for (int i = 0; i < n; i++)
        if (l->phase[i] == RETURN_YIELD_CHECK)
            yield_check_lane(l, i);
}

/* Lane `to` takes lane `from`'s return: its inputs and its iteration's state. */
static void lane_move(struct newton_lanes *l, int to, int from)
{
    struct return_lanes *e = &l->eval;
    e->u[to] = e->u[from], e->check[to] = e->check[from], e->eps_p[to] = e->eps_p[from], e->G[to] = e->G[from];
    e->trial[to] = e->trial[from], e->T_hat[to] = e->T_hat[from];
    e->log_rate_scale[to] = e->log_rate_scale[from], e->log_ratio_floor[to] = e->log_ratio_floor[from];
    l->u_lo[to] = l->u_lo[from], l->u_hi[to] = l->u_hi[from], l->f_prev[to] = l->f_prev[from];
    l->phase[to] = l->phase[from], l->plastic[to] = l->plastic[from], l->iter[to] = l->iter[from];
    l->last[to] = l->last[from], l->index[to] = l->index[from];
}

/* The returns that ended get their results (d, sigma_y); the lanes that go on close up in order, padded with copies
 * of the last to a multiple of 16 lanes (padding to 8 instead made consistency_lanes half again as costly on
 * AVX-512: perf, 4 ns impact).  Returns the lanes that go on.  Scalar copies: gcc's vector loops over such
 * index lists were AVX-512 gathers and scatters, slow on AMD Zen. */
__attribute__((optimize("no-tree-vectorize"))) static int close_up_lanes(struct newton_lanes *l, int n,
                                                                         struct mpm_return *const *returns)
{
    int kept = 0;
    for (int i = 0; i < n; i++) {
        if (l->outcome[i] == LANE_ENDED) {
            struct mpm_return *r = returns[l->index[i]];
            r->d = l->result_d[i], r->yield = l->result_yield[i];
            continue;
        }
        if (kept != i)
            lane_move(l, kept, i);
        kept++;
    }
    for (int i = kept; i < ((kept + 15) & ~15); i++)
        lane_move(l, i, kept - 1);
    return kept;
}

/* The returns' inputs into the set-up lanes.  Not vectorised, as close_up_lanes: gcc's vector loops were AVX-512
 * gathers. */
__attribute__((optimize("no-tree-vectorize"))) static void setup_load(struct mpm_return *const *returns, int n,
                                                                      struct setup_lanes *l)
{
    for (int i = 0; i < n; i++) {
        const struct mpm_return *r = returns[i];
        l->eps_p[i] = r->eps_p, l->G[i] = r->G, l->trial[i] = r->trial, l->rho[i] = r->rho, l->T[i] = r->T;
        l->Tm[i] = r->Tm, l->previous[i] = r->previous, l->previous_yield[i] = r->previous_yield;
        l->dt[i] = r->dt, l->log_dt[i] = r->log_dt;
    }
}

/* The set-up returns into the Newton lanes 0 .. n - 1, lane i return i, padded as close_up_lanes pads: lane to
 * lane, so that the loop vectorises. */
static void start_lanes(const struct setup_lanes *restrict s, int n, struct newton_lanes *restrict l)
{
    for (int i = 0; i < n; i++)
        start_lane(s, i, l);
    for (int i = n; i < ((n + 15) & ~15); i++)
        lane_move(l, i, n - 1);
}

void mpm_stress_returns(const struct mpm_material *material, struct mpm_return *const *returns, int n)
{
    struct setup_lanes setup __attribute__((aligned(64)));
    struct newton_lanes lanes __attribute__((aligned(64)));
    if (n <= 0)
        return;
    const struct mpm_material m = *material;
    const struct mpm_material_constants c = *returns[0]->constants;
    setup_load(returns, n, &setup);
    for (int i = 0; i < n; i++)
        setup_lane(&m, &c, i, &setup);
    start_lanes(&setup, n, &lanes);
    int n_active = n;
    while (n_active > 0) {
        consistency_lanes(&m, (n_active + 15) & ~15, &lanes.eval);
        advance_lanes(&lanes, n_active);
        yield_checks(&lanes, n_active);
        n_active = close_up_lanes(&lanes, n_active, returns);
    }
}

/* ---- the update ---- */

/* G(T) of Eq. 2.6 for n points, in lanes (libm's expm1 for each heated point cost 3 % of the step); a point never
 * heated (T exactly T_initial: no plastic work yet) takes the precomputed value. */
void mpm_shear_moduli(const struct mpm_material *material, const struct mpm_material_constants *c, int n,
                      const double *restrict T, double *restrict G)
{
    const struct mpm_material m = *material; /* copied: the stores to G cannot alias it */
    double G_initial = c->G_initial;
    for (int i = 0; i < n; i++)
        G[i] = fm_select(T[i] == m.T_initial, G_initial, mts_lane_shear_modulus(&m, T[i]));
}

int mpm_stress_begin(const struct mpm_material *m, const struct mpm_material_constants *c,
                     const double strain_increment[6], const double spin_increment[3], double G, double dt,
                     double log_dt, double volume0, double volume_new, const struct mpm_point_state *state,
                     struct mpm_stress_work *w)
{
    return stress_begin(m, c, strain_increment, spin_increment, G, dt, log_dt, volume0, volume_new, state, w);
}

int mpm_stress_finish(const struct mpm_material *m, const struct mpm_material_constants *c,
                      const struct mpm_bulk_viscosity *q, double dt, double volume0, double volume_old,
                      double volume_new, struct mpm_stress_work *w, struct mpm_point_state *state,
                      struct mpm_update_result *result)
{
    return stress_finish(m, c, q, dt, volume0, volume_old, volume_new, w, state, result);
}

/* The block's points one after another in one loop: the same operations as mpm_stress_begin point by point.  The
 * block is copied into a local, whose fields the stores through its pointers cannot alias: they stay in
 * registers instead of being loaded again for every point. */
void mpm_stress_begin_block(const struct mpm_stress_block *block)
{
    const struct mpm_stress_block b = *block;
    for (int k = 0; k < b.n; k++)
        if (b.updating[k])
            stress_begin(&b.materials[b.material[k]], &b.constants[b.material[k]], b.strain[k], b.spin[k], b.G[k], b.dt,
                         b.log_dt, b.volume0[k], b.volume_new[k], &b.state[k], &b.work[k]);
}

/* The same for mpm_stress_finish; failed[k] is 1 where it returned -1. */
void mpm_stress_finish_block(const struct mpm_stress_block *block)
{
    const struct mpm_stress_block b = *block;
    for (int k = 0; k < b.n; k++)
        if (b.updating[k])
            b.failed[k] =
                stress_finish(&b.materials[b.material[k]], &b.constants[b.material[k]], b.viscosity, b.dt, b.volume0[k],
                              b.volume_old[k], b.volume_new[k], &b.work[k], &b.state[k], &b.result[k]) != 0;
}

int mpm_stress_update_prepared(const struct mpm_material *m, const struct mpm_material_constants *c,
                               const struct mpm_bulk_viscosity *q, const double strain_increment[6],
                               const double spin_increment[3], double dt, double log_dt, double volume0,
                               double volume_old, double volume_new, struct mpm_point_state *state,
                               struct mpm_update_result *result)
{
    struct mpm_stress_work w;
    double G;
    mpm_shear_moduli(m, c, 1, &state->T, &G);
    if (mpm_stress_begin(m, c, strain_increment, spin_increment, G, dt, log_dt, volume0, volume_new, state, &w)) {
        struct mpm_return *r = &w.ret;
        mpm_stress_returns(m, &r, 1);
    }
    return mpm_stress_finish(m, c, q, dt, volume0, volume_old, volume_new, &w, state, result);
}

int mpm_stress_update(const struct mpm_material *m, const struct mpm_bulk_viscosity *q,
                      const double strain_increment[6], const double spin_increment[3], double dt, double volume0,
                      double volume_old, double volume_new, struct mpm_point_state *state,
                      struct mpm_update_result *result)
{
    struct mpm_material_constants c;
    mpm_material_prepare(m, &c);
    return mpm_stress_update_prepared(m, &c, q, strain_increment, spin_increment, dt, dt > 0.0 ? log(dt) : 0.0, volume0,
                                      volume_old, volume_new, state, result);
}

/* The melt bound: Tm(eta) = Tm0 exp(2a(1 - 1/eta)) eta^k grows with eta when a >= 0 and k >= 0 (Eq. 2.9). */
#define MELT_ETA_LOW 0.9

void mpm_material_prepare(const struct mpm_material *m, struct mpm_material_constants *c)
{
    c->G_initial = mpm_mts_shear_modulus(m, m->T_initial);
    c->wave_speed = mpm_material_wave_speed(m);
    c->log_rate_floor = log(m->rate_floor > DBL_MIN ? m->rate_floor : DBL_MIN);
    c->log_gamma_xi_factor = log(m->ptw_gamma * 0.5 * cbrt(4.0 * M_PI / (3.0 * m->atomic_mass)));
    int monotone = m->melt_a >= 0.0 && m->eos_gamma0 - m->melt_a - 1.0 / 3.0 >= 0.0;
    c->melt_eta_low = MELT_ETA_LOW;
    c->melt_T_low = monotone ? scg_lane_melt_temperature(m, MELT_ETA_LOW * m->density) : 0.0;
}

void mpm_point_state_init(const struct mpm_material *m, struct mpm_point_state *state)
{
    mpm_point_state_init_at(m, m->T_initial, state);
}

void mpm_point_state_init_at(const struct mpm_material *m, double T, struct mpm_point_state *state)
{
    for (int k = 0; k < 6; k++)
        state->stress[k] = 0.0;
    state->pressure = 0.0;
    state->viscosity = 0.0;
    state->eps_p = 0.0;
    state->T = T;
    state->energy = 0.0;
    state->rho = m->density;
    double Tm = mpm_scg_melt_temperature(m, m->density);
    state->melted = T < Tm ? 0.0 : 1.0;
    state->plastic_increment = 0.0; /* no return yet: no first guess from one */
    state->yield_stress = m->strength == MPM_STRENGTH_PTW ? mpm_ptw_flow_stress(m, 0.0, m->rate_floor, T, Tm,
                                                                                m->density, mpm_mts_shear_modulus(m, T))
                                                          : 0.0;
}

/* sqrt((K + 4/3 G(T_initial)) / rho0). */
double mpm_material_wave_speed(const struct mpm_material *m)
{
    return sqrt((m->bulk_modulus + 4.0 / 3.0 * mpm_mts_shear_modulus(m, m->T_initial)) / m->density);
}
