/* The direct bonding models of thesis Chapter 4, strain-based (Section 4.1.1, Eqs. 4.3-4.5) and energy-based
 * (Section 4.3, Eqs. 4.16-4.17; the nodal average and the bond of Eqs. 4.6-4.7 are in contact.c): the bonding
 * parameter D_bond of a surface point in contact
 * with another body grows with its plastic deformation; nodes where the bodies' average D_bond reaches 1 stick
 * the bodies together, also while they separate (contact.c).  D_bond never decreases. */
#include <math.h>

#include "mpm/bonding_law.h"
#include "mpm/mpm_impl.h"

/* The rate factor of Eqs. 4.4 and 4.16b, 1 - ln r for the rate ratio r, held at or above `floor`.  As printed,
 * 1 - ln r falls to 0 at r = e, so dD = d(energy or strain) / (critical value x factor) grows without bound just
 * below r = e and turns negative above it (docs/physics.md, "Bonding, bounded rate law").  With the floor the
 * factor is the printed one wherever that is at least `floor` (r <= e^(1 - floor)) and `floor` beyond: dD is
 * continuous, increasing in r, and at most the increment over (critical value x floor). */
double mpm_bonding_rate_factor(double r, double floor)
{
    return bonding_rate_factor(r, floor);
}

/* Energy model, Eqs. 4.16-4.17: dG_s = sigma_vm d eps_p DCell (DCell regularises the energy to the bonding
 * band's width), G_bond = G_c (1 - ln(dG_s / (dG_c/dt dt))) held at or above bonding_floor G_c, dD = dG_s / G_bond.
 * Strain model, Eqs. 4.3-4.5: dD = d eps_s / eps_bond, eps_bond = eps_c (1 - ln(eps_s_dot / eps_c_dot)) held at or
 * above bonding_floor eps_c.  The shear plastic strain increment is taken as the effective plastic strain
 * increment: with J2 plasticity the plastic flow is purely deviatoric (shear), and the thesis takes its magnitude,
 * not its direction.  (The laws in mpm/bonding_law.h, shared with the GPU step.) */
double mpm_bonding_increment(const struct mpm_config *cfg, double eps_p_increment, double von_mises, double dt,
                             double scale)
{
    return cfg->bonding == MPM_BONDING_ENERGY
               ? bonding_energy_increment(eps_p_increment, von_mises, dt, cfg->grid, cfg->Gc * scale, cfg->Gc_rate,
                                          cfg->bonding_floor)
               : bonding_strain_increment(eps_p_increment, dt, cfg->eps_c * scale, cfg->eps_rate_c, cfg->bonding_floor);
}

/* A particle that arrives preheated needs less of the plastic work that heats its interface towards the
 * instability bonding needs: both terms of Schmidt et al. 2006's critical velocity (after Assadi et al. 2003) fall
 * in proportion to Tm - T, the heat still needed to reach the melt, so v_crit(T) / v_crit(T_ref) = ((Tm - T) /
 * (Tm - T_ref))^(1/2), with the substrate at room temperature.  The calibrated eps_c or G_c belongs to
 * bonding_T_reference, and the model's v_crit grows as eps_c^1.02 where both bodies' eps_c change (the
 * calibration's runs): so the pair's critical value should fall as share^n, n = bonding_preheat_exponent (auto:
 * 0.5 for the strain model, 1 for the energy model, whose v_crit grows as G_c^0.54; params.c preheat_exponent),
 * with Tm the SCG melt at rho0 (Eq. 2.9).  But a node bonds where the average of the two bodies' D_bond reaches 1
 * (Eq. 4.7): for equal strains on both sides a body with factor y against one at the reference bonds at the
 * harmonic mean 2 y / (1 + y) of the critical values, so the body takes y = q / (2 - q), q = share^n, whose mean
 * with 1 is q.  share^n itself moved the pair by about half of it: v_crit(14 um, 500 K) / v_crit(298 K) was 0.93
 * against Schmidt's 0.83 (docs/physics.md "Bonding of a heated particle").  A body much colder than the reference
 * (q of 2 or more: no factor of its own reaches q) is held at MPM_PREHEAT_SCALE_MAX.  The rate term is left as
 * calibrated.  A body at the reference temperature gets exactly 1 (the calibration's runs unchanged, bit for bit). */
double mpm_bonding_preheat_scale(const struct mpm_config *cfg, int b)
{
    const struct mpm_body *body = &cfg->bodies[b];
    const struct mpm_material *m = &cfg->materials[body->material];
    double T0 = body->temperature > 0.0 ? body->temperature : m->T_initial;
    if (cfg->bonding == MPM_BONDING_NONE || cfg->bonding_preheat == MPM_PREHEAT_NONE || T0 == cfg->bonding_T_reference)
        return 1.0;
    double Tm = mpm_scg_melt_temperature(m, m->density);
    double share = fmax((Tm - T0) / (Tm - cfg->bonding_T_reference), 0.0);
    double q = pow(share, cfg->bonding_preheat_exponent);
    double y = q < 2.0 ? q / (2.0 - q) : MPM_PREHEAT_SCALE_MAX;
    return fmin(fmax(y, MPM_PREHEAT_SCALE_MIN), MPM_PREHEAT_SCALE_MAX);
}

/* A surface point in contact with a bonding model on (bonding_update in mpm_impl.h). */
void mpm_bonding_grow(struct mpm_solver *s, size_t q, double eps_p_increment, double von_mises)
{
    double scale = s->body_bond_scale[s->points.body[q]];
    s->points.d_bond[q] += mpm_bonding_increment(&s->cfg, eps_p_increment, von_mises, s->dt, scale);
}
