/* The direct bonding models of thesis Chapter 4, strain-based (Section 4.1.1, Eqs. 4.3-4.5) and energy-based
 * (Section 4.3, Eqs. 4.16-4.17; the nodal average and the bond of Eqs. 4.6-4.7 are in contact.c): the bonding
 * parameter D_bond of a surface point in contact
 * with another body grows with its plastic deformation; nodes where the bodies' average D_bond reaches 1 stick
 * the bodies together, also while they separate (contact.c).  D_bond never decreases. */
#include <math.h>

#include "mpm/mpm_impl.h"

/* Energy model, Eqs. 4.16-4.17: dG_s = sigma_vm d eps_p DCell (DCell regularises the energy to the bonding
 * band's width), G_bond = G_c (1 - ln(dG_s / (dG_c/dt dt))), dD = dG_s / G_bond.
 * Erratum (docs/physics.md): as printed, G_bond turns negative when dG_s > e (dG_c/dt) dt; there we add nothing (a bond
 * parameter that decreases, or grows without bound as G_bond -> 0+, has no physical meaning).  G_bond between
 * 0 and G_c (rates between 1 and e times the critical rate) speeds bonding up, as the printed law says. */
static double energy_increment(const struct mpm_config *cfg, double eps_p_increment, double von_mises, double dt)
{
    double dG = von_mises * eps_p_increment * cfg->grid;
    if (!(dG > 0.0))
        return 0.0;
    double G_bond = cfg->Gc * (1.0 - log(dG / (cfg->Gc_rate * dt)));
    return G_bond > 0.0 ? dG / G_bond : 0.0;
}

/* Strain model, Eqs. 4.3-4.5: dD = d eps_s / eps_bond, eps_bond = eps_c (1 - ln(eps_s_dot / eps_c_dot)).  The
 * shear plastic strain increment is taken as the effective plastic strain increment: with J2 plasticity the
 * plastic flow is purely deviatoric (shear), and the thesis takes its magnitude, not its direction. */
static double strain_increment(const struct mpm_config *cfg, double eps_p_increment, double dt)
{
    if (!(eps_p_increment > 0.0))
        return 0.0;
    double eps_bond = cfg->eps_c * (1.0 - log(eps_p_increment / dt / cfg->eps_rate_c));
    return eps_bond > 0.0 ? eps_p_increment / eps_bond : 0.0;
}

/* A surface point in contact with a bonding model on (bonding_update in mpm_impl.h). */
void mpm_bonding_grow(struct mpm_solver *s, size_t q, double eps_p_increment, double von_mises)
{
    const struct mpm_config *cfg = &s->cfg;
    double increment = cfg->bonding == MPM_BONDING_ENERGY ? energy_increment(cfg, eps_p_increment, von_mises, s->dt)
                                                          : strain_increment(cfg, eps_p_increment, s->dt);
    s->points.d_bond[q] += increment;
}
