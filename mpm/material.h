/* mpm material models (module-private): Tang (2021) Sections 2.4.2, 3.5 and Appendix A.
 *
 *   ptw.c            Preston-Tonks-Wallace flow stress (Eqs. 2.4-2.8), MTS shear modulus G(T) (Eq. 2.6)
 *   melt.c           Steinberg-Cochran-Guinan melt temperature (Eq. 2.9, docs/physics.md erratum on the exponent)
 *   eos.c            Mie-Grueneisen pressure, linear in the energy (Eqs. 3.39-3.43; Zhang et al. Eq. 6.180)
 *   stress_update.c  one material point's stress update (Appendix A): Jaumann rotation, elastic trial, radial
 *                    return with the rate-dependent PTW yield solved consistently, EOS energy update,
 *                    adiabatic heating (Eq. 3.44), melt, artificial bulk viscosity
 *
 * Conventions: SI units.  Symmetric tensors in the order xx, yy, zz, yz, xz, xy, tensor (not engineering)
 * components for stresses and strains alike.  Stress is positive in tension; pressure positive in compression. */
#ifndef SPRAYCOAT_MPM_MATERIAL_H
#define SPRAYCOAT_MPM_MATERIAL_H

#include <math.h>

#include "core/fastmath.h" /* SC_HD: the inline functions below run on the GPU too (mpm/cuda/) */
#include "mpm/mpm.h"       /* struct mpm_bulk_viscosity */

enum mpm_strength { MPM_STRENGTH_PTW, MPM_STRENGTH_ELASTIC };

struct mpm_material {
    char name[64];
    enum mpm_strength strength; /* PTW, or elastic (no yield: for verification) */
    double density;             /* rho0, kg/m3 */
    /* PTW, Tang Table 2.1 (dimensionless unless noted) */
    double ptw_theta, ptw_p, ptw_s0, ptw_sinf, ptw_kappa, ptw_gamma;
    double ptw_y0, ptw_yinf, ptw_y1, ptw_y2, ptw_beta;
    double atomic_mass; /* kg per atom */
    double rate_floor;  /* 1/s: smallest plastic strain rate given to PTW (ln(gamma xi/rate) at rate 0) */
    /* MTS shear modulus G(T) = G0 - D / (exp(T0/T) - 1), Eq. 2.6 */
    double G0, D, T0; /* Pa, Pa, K */
    /* Mie-Grueneisen: bulk sound speed c0 (m/s), Hugoniot slope s, Grueneisen gamma0 */
    double eos_c0, eos_s, eos_gamma0;
    /* SCG melt: melt_T0 (K) at rho0, melt_a the first-order volume correction of gamma */
    double melt_T0, melt_a;
    double specific_heat;  /* J/(kg K) */
    double conductivity;   /* W/(m K), [impact] conduction = on */
    double taylor_quinney; /* fraction of plastic work turned into heat */
    double T_initial;      /* K */
    double bulk_modulus;   /* Pa, for wave speeds (time step, absorbing boundaries): rho0 c0^2 by default */
};

/* ---- ptw.c ---- */
/* MTS shear modulus at temperature T (Eq. 2.6), never below 0. */
double mpm_mts_shear_modulus(const struct mpm_material *m, double T);
/* The temperature (K) below which that shear modulus is positive: T0 / ln(1 + D/G0) (infinite for D = 0). */
double mpm_mts_positive_below(const struct mpm_material *m);
/* xi_dot of Eq. 2.8 (1/s) at density rho and shear modulus G. */
double mpm_ptw_xi_dot(const struct mpm_material *m, double rho, double G);
/* PTW von Mises flow stress (Pa), Eqs. 2.4-2.7, at plastic strain eps_p, plastic strain rate rate (1/s, floored
 * at m->rate_floor), temperature T, melt temperature Tm, density rho and shear modulus G.  0 at or above melt.
 * When tau_s <= tau_y there is no hardening range and the flow stress is 2 G tau_s. */
double mpm_ptw_flow_stress(const struct mpm_material *m, double eps_p, double rate, double T, double Tm, double rho,
                           double G);

/* The flow stress and its partial derivatives, for the Newton return of stress_update.c (mpm/ptw_lane.h). */
struct ptw_flow {
    double stress;     /* sigma_y = 2 G tau, Pa (Eq. 2.4) */
    double d_eps;      /* d sigma_y / d eps_p */
    double d_log_rate; /* d sigma_y / d ln(rate) */
};

/* ---- melt.c ---- */
/* SCG melt temperature (K) at density rho: Tm0 exp(2a(1 - 1/eta)) eta^(2(gamma0 - a - 1/3)), eta = rho/rho0. */
double mpm_scg_melt_temperature(const struct mpm_material *m, double rho);
/* Its body (melt.c has the notes), inline for the stress update on the host and the device. */
SC_HD static inline double scg_melt_temperature(const struct mpm_material *m, double rho)
{
    if (!(rho > 0.0))
        return 0.0;
    double eta = rho / m->density;
    double exponent = 2.0 * (m->eos_gamma0 - m->melt_a - 1.0 / 3.0);
    return m->melt_T0 * exp(2.0 * m->melt_a * (1.0 - 1.0 / eta)) * pow(eta, exponent);
}

/* ---- eos.c ---- */
/* The linear-in-energy form p = A(mu) + B(mu) E, E the internal energy per initial volume (J/m3),
 * mu = rho/rho0 - 1.  Compression and tension branches continuous in p and dp/dmu at mu = 0.  A and B (the
 * coefficients of mpm/eos.c) inline: the stress update evaluates them for every point and step. */
SC_HD static inline void eos_coefficients(const struct mpm_material *m, double rho, double *A, double *B)
{
    double mu = rho / m->density - 1.0;
    double c1 = m->density * m->eos_c0 * m->eos_c0;
    *B = m->eos_gamma0;
    if (!(mu > 0.0)) {
        *A = c1 * mu;
        return;
    }
    double c2 = c1 * (2.0 * m->eos_s - 1.0);
    double c3 = c1 * (m->eos_s - 1.0) * (3.0 * m->eos_s - 1.0);
    double hugoniot = mu * (c1 + mu * (c2 + mu * c3));
    *A = hugoniot * (1.0 - m->eos_gamma0 * mu / (2.0 * (1.0 + mu)));
}
double mpm_eos_pressure(const struct mpm_material *m, double rho, double energy_per_initial_volume);

/* ---- stress_update.c ---- */
struct mpm_point_state {
    double stress[6];         /* Cauchy stress without the bulk viscosity: s - p I */
    double pressure;          /* EOS pressure p (Pa) */
    double viscosity;         /* artificial bulk viscosity q (Pa); the force uses stress - q I */
    double eps_p;             /* effective plastic strain */
    double T;                 /* temperature, K */
    double energy;            /* internal energy of the point, J (Eq. 3.39: e, not per volume) */
    double rho;               /* density at the start of the step, kg/m3 (updated to rho_new) */
    double yield_stress;      /* current flow stress, Pa */
    double melted;            /* 1 once T >= Tm at the last update, else 0 */
    double plastic_increment; /* delta eps_p of the last update: the first guess of the next return */
};

/* What the update did, for diagnostics and bonding. */
struct mpm_update_result {
    double eps_p_increment;  /* delta eps_p >= 0 */
    double von_mises;        /* von Mises stress after the update (Pa) */
    double plastic_work;     /* J dissipated plastically this step: V sigma_y delta eps_p */
    double energy_increment; /* J: e^{n+1} - e^n */
};

/* Update one material point over a step dt (Appendix A, Eqs. A1-A11).
 *   strain_increment[6]: Delta eps = sym(grad v) dt (tensor components)
 *   spin_increment[3]:   Omega dt = skew(grad v) dt, components W_yz, W_xz, W_xy (W_ij = (dv_i/dx_j - dv_j/dx_i)/2)
 *   volume0, volume_old, volume_new: V0, V^n, V^{n+1} (m3); rho_new = rho0 V0 / volume_new
 * Returns 0, or -1 when the state became non-finite (the caller reports step and point). */
int mpm_stress_update(const struct mpm_material *m, const struct mpm_bulk_viscosity *q,
                      const double strain_increment[6], const double spin_increment[3], double dt, double volume0,
                      double volume_old, double volume_new, struct mpm_point_state *state,
                      struct mpm_update_result *result);

/* Quantities of a material that are constant during a run, computed once per material (mpm_material_prepare)
 * and passed to mpm_stress_update_prepared instead of being recomputed for every point. */
struct mpm_material_constants {
    double G_initial;           /* G(T_initial), Eq. 2.6 */
    double wave_speed;          /* mpm_material_wave_speed, for the bulk viscosity */
    double log_rate_floor;      /* ln(rate_floor) */
    double log_gamma_xi_factor; /* ln(gamma (4 pi / (3 M))^(1/3) / 2): ln(gamma xi_dot) less ln(G^3/rho)/6 */
    double melt_eta_low;        /* rho/rho0 above which Tm(rho) >= melt_T_low */
    double melt_T_low;          /* a lower bound of Tm above melt_eta_low (0: none, Eq. 2.9 not monotone) */
};
void mpm_material_prepare(const struct mpm_material *m, struct mpm_material_constants *c);

/* mpm_stress_update with the material's constants precomputed and log_dt = ln(dt) computed once per step (the
 * solver's point loop; used only when dt > 0); results identical. */
int mpm_stress_update_prepared(const struct mpm_material *m, const struct mpm_material_constants *c,
                               const struct mpm_bulk_viscosity *q, const double strain_increment[6],
                               const double spin_increment[3], double dt, double log_dt, double volume0,
                               double volume_old, double volume_new, struct mpm_point_state *state,
                               struct mpm_update_result *result);

/* The update of one point in three phases, so that the solver can run the plastic returns of a block of points
 * together in vector lanes (mpm_stress_update_prepared is the three on one point; a point's result does not
 * depend on which points share its block):
 *   mpm_stress_begin   rotation, elastic trial and yield bounds (Eqs. A1-A5); 1 when the point needs the return
 *   mpm_stress_returns the returns of up to MPM_RETURN_LANES points of one material (Eqs. A6-A8) in lock-step,
 *                      their set-up (Eq. 2.8, the bracket, the first iterate) in lanes as well
 *   mpm_stress_finish  radial scaling, EOS energy update, viscosity, heating (Eqs. A8-A11, 3.38-3.44). */
/* 256 rather than 64: the returns still iterating are padded to 16 lanes every round, and the more returns a block
 * holds, the fewer of its lanes are padding (perf, 4 ns impact: consistency_lanes 14.0 % -> 10.2 % of the
 * samples; 512 did no better).  A block's update holds about 160 kB on the stack. */
#define MPM_RETURN_LANES 256

/* The plastic return of one point: the consistency problem f(d) = 0 of stress_update.c, set up by
 * mpm_stress_begin, and its result, from mpm_stress_returns (whose Newton iteration lives in lanes). */
struct mpm_return {
    double eps_p, G, trial;
    /* what the set-up (the first pass of mpm_stress_returns, in lanes) starts from: the material's constants,
     * rho_new, T, Tm (NAN: not computed yet), the last step's increment and flow stress, dt and ln dt */
    const struct mpm_material_constants *constants;
    double rho, T, Tm, previous, previous_yield, dt, log_dt;
    double d, yield; /* the result */
};

/* What passes from mpm_stress_begin to mpm_stress_finish. */
struct mpm_stress_work {
    double strain[6], s_rot[6], s_new[6]; /* strain increment, rotated and new deviatoric stress */
    double volumetric, rho_new;           /* trace/3 of the strain increment, density at the end of the step */
    double yield, d;                      /* flow stress and plastic increment of a point without return */
    int melted, returning;
    struct mpm_return ret;
};

/* G(T) (Eq. 2.6) of n points of material m at temperatures T, for mpm_stress_begin. */
void mpm_shear_moduli(const struct mpm_material *m, const struct mpm_material_constants *c, int n, const double *T,
                      double *G);
int mpm_stress_begin(const struct mpm_material *m, const struct mpm_material_constants *c,
                     const double strain_increment[6], const double spin_increment[3], double G, double dt,
                     double log_dt, double volume0, double volume_new, const struct mpm_point_state *state,
                     struct mpm_stress_work *w);
/* returns[0 .. n - 1], all of material m and fresh from mpm_stress_begin, solved: d and yield set. */
void mpm_stress_returns(const struct mpm_material *m, struct mpm_return *const *returns, int n);
int mpm_stress_finish(const struct mpm_material *m, const struct mpm_material_constants *c,
                      const struct mpm_bulk_viscosity *q, double dt, double volume0, double volume_old,
                      double volume_new, struct mpm_stress_work *w, struct mpm_point_state *state,
                      struct mpm_update_result *result);

/* The first and last phases for the points of a block, without a call per point (a call's prologue and epilogue
 * were ~40 instructions): point k < n, skipped unless updating[k], is of material materials[material[k]] (its
 * constants constants[material[k]]), with strain[k], spin[k], G[k], volume0[k], volume_old[k] (finish only),
 * volume_new[k], state[k] and work[k] as the arguments of mpm_stress_begin and mpm_stress_finish; finish writes
 * result[k], and failed[k] = 1 where mpm_stress_finish would return -1. */
struct mpm_stress_block {
    int n;
    const int *material, *updating;
    const struct mpm_material *materials;
    const struct mpm_material_constants *constants;
    const struct mpm_bulk_viscosity *viscosity;
    double dt, log_dt;
    const double (*strain)[6], (*spin)[3];
    const double *G, *volume0, *volume_old, *volume_new;
    struct mpm_point_state *state;
    struct mpm_stress_work *work;
    struct mpm_update_result *result;
    int *failed;
};
void mpm_stress_begin_block(const struct mpm_stress_block *b);
void mpm_stress_finish_block(const struct mpm_stress_block *b);

/* Initial state of a point of material m at rest (stress 0, T = T_initial, rho = rho0). */
void mpm_point_state_init(const struct mpm_material *m, struct mpm_point_state *state);
/* The same at temperature T (K): a particle that arrives from the spray at its own temperature. */
void mpm_point_state_init_at(const struct mpm_material *m, double T, struct mpm_point_state *state);

/* Longitudinal elastic wave speed sqrt((K + 4 G / 3) / rho0) at T_initial (m/s). */
double mpm_material_wave_speed(const struct mpm_material *m);

#endif
