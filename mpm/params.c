/* The impact stage's case keys ([impact], [material.NAME]) and their resolution into struct mpm_config. */
#include <errno.h>
#include <limits.h>
#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "core/csv.h"
#include "core/error.h"
#include "core/log.h"
#include "mpm/mpm.h"
#include "mpm/gpu.h"
#include "mpm/mpm_impl.h"

#define MAT "material.*"

const struct cfg_key mpm_case_keys[] = {
    /* [impact] */
    {"impact", "material", CFG_STRING, "", "aluminium", 0, 0, 0, NULL,
     "material NAME of the sprayed particle(s); needs a [material.NAME] section"},
    {"impact", "substrate_material", CFG_STRING, "", "aluminium", 0, 0, 0, NULL,
     "material NAME of the substrate; needs a [material.NAME] section"},
    {"impact", "substrate", CFG_CHOICE, "", "cylinder", 0, 0, 0, "cylinder|box|rigid",
     "substrate body (top face at z = 0): a cylinder, a square box, or a rigid frictionless wall"},
    {"impact", "substrate_diameter", CFG_REAL, "m", "30e-6", 0, 1, 1, NULL,
     "substrate cylinder diameter or box side (Tang Table 5.3)"},
    {"impact", "substrate_height", CFG_REAL, "m", "10e-6", 0, 1, 1, NULL, "substrate thickness"},
    {"impact", "grid", CFG_REAL, "m", "1.5e-6", 0, 1, 1, NULL, "DCell: edge of the cubic grid cells"},
    {"impact", "spacing", CFG_REAL, "m", "0.5e-6", 0, 1, 1, NULL,
     "dp: lattice spacing of the material points (at most DCell)"},
    {"impact", "cfl", CFG_REAL, "-", "0.1", 0, 1, 1, NULL, "dt = cfl DCell / (c + max|v|) every step"},
    {"impact", "t_end", CFG_REAL, "s", "100e-9", 0, 1e-3, 1, NULL,
     "simulated time after first contact at most: the run ends earlier once every verdict settled (Tang judges "
     "at 80-100 ns)"},
    {"impact", "shape_functions", CFG_CHOICE, "", "linear", 0, 0, 0, "linear|ugimp",
     "linear: trilinear (Eq. 3.20); ugimp: uniform GIMP (Bardenhagen & Kober 2004), less cell-crossing noise"},
    {"impact", "bodies", CFG_PATH, "", NULL, 0, 0, 0, NULL,
     "CSV with header shape,x,y,z,vx,vy,vz,d,h,material and optionally temperature (shape sphere|cylinder|box; "
     "x,y,z the centre; d the diameter or box side, h the height; temperature in K, the body's start instead of its "
     "material's T_initial); replaces diameter/velocity/angle"},
    {"impact", "diameter", CFG_REAL, "m", "14e-6", 0, 1, 1, NULL, "single particle: diameter"},
    {"impact", "velocity", CFG_REAL, "m/s", "810", 0, 1e5, 0, NULL, "single particle: impact speed"},
    {"impact", "angle", CFG_REAL, "degree", "0", 0, 89, 0, NULL,
     "single particle: angle of the velocity from the substrate normal (oblique impact along +x)"},
    {"impact", "contact", CFG_CHOICE, "", "frictionless", 0, 0, 0, "stick|frictionless|friction",
     "contact at nodes where bodies approach (Eqs. 3.29, 3.31): stick, frictionless (thesis), Coulomb friction"},
    {"impact", "friction", CFG_REAL, "-", "0.2", 0, 10, 0, NULL, "Coulomb coefficient, contact = friction"},
    {"impact", "contact_scheme", CFG_CHOICE, "", "once", 0, 0, 0, "once|thesis|consistent",
     "once: two corrections a step, on the start momenta and on the updated ones computed from them (Nairn et "
     "al. 2020: contact where approaching with the surfaces within contact_gap; bonds only while separating); "
     "thesis: the contact of the updated and of the re-projected momenta decided apart (dissipates energy); "
     "consistent: one decision for all momenta, no gap test, bonded nodes sticking also while approaching "
     "(docs/physics.md, \"Contact\")"},
    {"impact", "contact_gap", CFG_REAL, "-", "0.8", 0, 2, 0, NULL,
     "contact_scheme = once: bodies touch at a node where their nodal centres of mass lie at most this many cells "
     "apart along the normal (Nairn's position-based detection; 0.75-0.86 for touching surfaces, 2 points a cell)"},
    {"impact", "contact_approach", CFG_CHOICE, "", "both", 0, 0, 0, "both|common",
     "contact_scheme = once: a pair is in contact at a node where it approaches along the common normal and, with "
     "both, also along each body's own normal (its volume gradient; Bardenhagen et al. 2000's test, for both bodies): "
     "where a body's corner meets the other's face the common normal is the corner's, and sliding or leaving "
     "along the face counts as an approach with common alone (docs/physics.md, \"Contact\")"},
    {"impact", "bond_growth", CFG_CHOICE, "", "approach", 0, 0, 0, "approach|contact",
     "contact_scheme = once: where a pair only touches or is bonded (no contact impulse), its nodes' surface points "
     "count as in contact for the bonding model only while the two bodies' centres of mass approach along the "
     "node's normal (approach: bonds form during the impact, not after a particle has turned; pressed nodes always "
     "count), or always (contact; docs/physics.md, \"Bonds form during the impact\")"},
    {"impact", "bond_gap", CFG_REAL, "-", "0.9", 0, 2, 0, NULL,
     "contact_scheme = once: a bonded pair holds at a node only while its nodal centres of mass lie at most this "
     "many cells apart along the normal, the test of contact_gap (a bond joins surfaces that meet and does not "
     "reach across a gap); 0: wherever both bodies have mass, as Tang 2021 Section 4.1.1 (docs/physics.md, "
     "\"Contact\")"},
    {"impact", "conduction", CFG_CHOICE, "", "off", 0, 0, 0, "off|on",
     "heat conduction inside each body (Fourier's law with the materials' conductivity; off: adiabatic, as Tang 2021 "
     "Eq. 3.44, the shipped calibrations' assumption): holds the interface's temperature, which adiabatic grows with "
     "every refinement of the grid (docs/physics.md \"Heat conduction\")"},
    {"impact", "symmetry", CFG_CHOICE, "", "none", 0, 0, 0, "none|half|quarter",
     "mirror planes through the particle's centre, which model only the part of the set-up on their positive side "
     "with the same result: half: y = 0 (the oblique velocity lies in it), a run of half the points; quarter: x = 0 "
     "and y = 0, a quarter of the points, normal impacts only; every body centred on the planes and not moving "
     "across them; linear shape functions; conduction exchanges heat with the neighbours' mirror images; the CPU or "
     "the GPU step (docs/physics.md \"Mirror symmetry\")"},
    {"impact", "flip", CFG_REAL, "-", "1", 0, 1, 0, NULL,
     "share of FLIP in the points' new velocity, the rest PIC (grid velocity at the point); 1: Eq. 3.32"},
    {"impact", "bonding", CFG_CHOICE, "", "strain", 0, 0, 0, "energy|strain|none",
     "bonding model: strain (Eqs. 4.3-4.5; its default eps_c, eps_rate_c belong to 10 grid cells across the "
     "particle), energy (Eqs. 4.16-4.17; its default Gc, Gc_rate to 2.0/0.667 um), none (docs/physics.md \"Bonding "
     "calibration\")"},
    {"impact", "Gc", CFG_REAL, "J/m2", "720", 0, 1e9, 1, NULL,
     "critical surface adhesion energy G_c, Eq. 4.16b (default from the sweep in docs/physics.md, \"Bonding "
     "calibration\")"},
    {"impact", "Gc_rate", CFG_REAL, "J/m2/s", "2e11", 0, 1e30, 1, NULL,
     "critical adhesion energy rate dG_c/dt, Eq. 4.16b (default from the sweep in docs/physics.md; not the printed "
     "value)"},
    {"impact", "eps_c", CFG_REAL, "-", "auto", 0, 1e3, 1, "auto",
     "critical bonding strain, Eq. 4.4; auto: the calibration for the case's heat transport at 10 grid cells per "
     "particle diameter (1.4/0.467 um for 14 um), the value whose v_crit by logistic regression meets the measured "
     "810 and 770 m/s of 14 and 30 um on average within 10 m/s, and their difference within 10 m/s, with eps_rate_c "
     "1e5: 2.468 adiabatic (conduction = off, cases/calibrate_vcrit_al.ini), 2.506 with conduction = on "
     "(cases/calibrate_vcrit_al_conduction.ini); it belongs to its grid: docs/physics.md \"Bonding calibration\""},
    {"impact", "eps_rate_c", CFG_REAL, "1/s", "1e5", 0, 1e20, 1, NULL,
     "critical bonding strain rate, Eq. 4.4 (the 10-cell calibration's, the low end of its range: the rate term out "
     "of play wherever bonding happens, eps_bond = bonding_floor eps_c above e^0.5 eps_rate_c; docs/physics.md "
     "\"Bonding calibration\")"},
    {"impact", "bonding_floor", CFG_REAL, "-", "0.5", 0, 1, 1, NULL,
     "smallest G_bond/G_c (energy model) and eps_bond/eps_c (strain model) at high rates: keeps dD bounded and "
     "monotone in the rate; the printed law where 1 - ln(rate ratio) is at least this (docs/physics.md)"},
    {"impact", "bonding_preheat", CFG_CHOICE, "", "melt_heat", 0, 0, 0, "melt_heat|none",
     "melt_heat: a body that starts at T0 (a particle heated in the nozzle) has eps_c (strain model) or G_c (energy "
     "model) times q / (2 - q), q = ((Tm - T0) / (Tm - bonding_T_reference))^n, n = bonding_preheat_exponent: the "
     "factor whose mean with a body at the reference (Eq. 4.7 averages the two bodies' D_bond) is q, q the share "
     "left of the heat that brings its material to the SCG melt Tm (Eq. 2.9 at rho0) to the power n, in which both "
     "terms of Schmidt et al. 2006's critical velocity fall; none: the calibrated value at every temperature "
     "(docs/physics.md \"Bonding of a heated particle\")"},
    {"impact", "bonding_preheat_exponent", CFG_REAL, "-", "auto", 0, 10, 0, "auto",
     "n of bonding_preheat = melt_heat: the pair's critical value falls as ((Tm - T0) / (Tm - "
     "bonding_T_reference))^n; auto: 0.5 with bonding = strain (its v_crit grows as eps_c^1.02), 1 with bonding = "
     "energy (as G_c^0.54), so that v_crit falls as the square root of the melt-heat share, as Schmidt et al. "
     "2006's critical velocity (docs/physics.md \"Bonding of a heated particle\")"},
    {"impact", "bonding_T_reference", CFG_REAL, "K", "298", 0, 1e5, 1, NULL,
     "the temperature eps_c and G_c were calibrated at (the shipped calibration: particle and substrate at 298 K); "
     "below every material's melt temperature"},
    {"impact", "pbcp_threshold", CFG_REAL, "-", "0.05", 0, 1, 0, NULL,
     "bonded verdict needs PBCP (Eq. 5.1) at least this"},
    {"impact", "vrest_threshold", CFG_REAL, "m/s", "0.6", 0, 1e4, 0, NULL,
     "bonded verdict needs the (window-mean) restitution velocity at most this (Tang Section 5.2.1: 0.6 m/s)"},
    {"impact", "settle_window", CFG_REAL, "s", "10e-9", 0, 1, 1, NULL,
     "each row is judged on the means of v_rest and v_com over this window, and a verdict is settled when PBCP and "
     "those means have kept it over this last stretch of time (docs/physics.md, "
     "\"Settled verdicts\"); at least 4 series_every"},
    {"impact", "settle_vcom", CFG_REAL, "m/s", "0.5", 0, 1e4, 0, NULL,
     "settled: each component of the body's window-mean centre-of-mass velocity moved by at most this over "
     "settle_window"},
    {"impact", "settle_pbcp", CFG_REAL, "-", "0.005", 0, 1, 0, NULL,
     "settled: PBCP moved by at most this over settle_window"},
    {"impact", "stop_when_settled", CFG_CHOICE, "", "yes", 0, 0, 0, "yes|no",
     "end the impact run once every particle's verdict is settled (else at t_end)"},
    {"impact", "vrest_filter", CFG_REAL, "m/s", "60", 0, 1e5, 1, NULL,
     "only points slower than this count in the restitution velocity (ejected material left out); a body leaving "
     "with no point that slow is judged on its centre of mass's speed"},
    {"impact", "snapshot_every", CFG_REAL, "s", "10e-9", 0, 1, 1, NULL,
     "simulated time between snapshots; at least t_end / 1e12"},
    {"impact", "series_every", CFG_REAL, "s", "0.5e-9", 0, 1, 1, NULL,
     "simulated time between series rows; at least t_end / 1e12"},
    {"impact", "box_margin", CFG_REAL, "m", "5e-6", 0, 1, 0, NULL,
     "grid box = bounding box of the bodies + this on every side; points leaving it are removed"},
    {"impact", "bulk_viscosity_linear", CFG_REAL, "-", "0.06", 0, 10, 0, NULL,
     "linear coefficient c_l of the artificial bulk viscosity (0 = off)"},
    {"impact", "bulk_viscosity_quadratic", CFG_REAL, "-", "1.5", 0, 100, 0, NULL,
     "quadratic coefficient c_q of the artificial bulk viscosity (0 = off)"},
    {"impact", "substrate_bottom", CFG_CHOICE, "", "fixed", 0, 0, 0, "fixed|free|spring",
     "fixed: the grid holds the substrate's bottom face vertically (Tang Section 4.3.3); free: only the dashpots; "
     "spring: dashpots and springs (viscous-spring boundary, Deeks & Randolph 1994)"},
    {"impact", "absorbing", CFG_CHOICE, "", "yes", 0, 0, 0, "yes|no",
     "viscous absorbing boundaries (Eqs. 3.45-3.46) on the substrate's bottom and sides"},
    {"impact", "substrate_sides", CFG_CHOICE, "", "dashpot", 0, 0, 0, "dashpot|spring",
     "dashpot: the sides absorb only (Tang Section 3.5.5); spring: dashpots and springs with R = substrate radius"},
    {"impact", "spring_alpha_normal", CFG_REAL, "-", "2", 0, 1e6, 0, NULL,
     "viscous-spring boundary: normal spring alpha_N G / R per unit area (2: spherical P wave, Liu et al. 2006)"},
    {"impact", "spring_alpha_tangential", CFG_REAL, "-", "1", 0, 1e6, 0, NULL,
     "viscous-spring boundary: tangential spring alpha_T G / R per unit area (1: spherical S wave)"},
    {"impact", "transfer", CFG_CHOICE, "", "flip", 0, 0, 0, "flip|apic",
     "grid-to-point transfer: flip (Eq. 3.32, blended with PIC by `flip`) or apic (affine particle-in-cell, Jiang "
     "et al. 2015: the grid velocity at the point and its gradient; not with `flip` nor on the GPU)"},
    /* [material.NAME]: defaults are Tang's Al (Table 2.1; docs/physics.md erratum on the atomic mass) */
    {MAT, "density", CFG_REAL, "kg/m3", "2700", 0, 1e5, 1, NULL, "rho0"},
    {MAT, "strength", CFG_CHOICE, "", "ptw", 0, 0, 0, "ptw|elastic", "deviatoric model: PTW, or elastic (no yield)"},
    {MAT, "ptw_theta", CFG_REAL, "-", "0.01156", 0, 10, 0, NULL, "PTW strain hardening rate theta"},
    {MAT, "ptw_p", CFG_REAL, "-", "3", 0, 100, 0, NULL, "PTW strain hardening constant p (Tang's d)"},
    {MAT, "ptw_s0", CFG_REAL, "-", "0.01489", 0, 10, 1, NULL, "PTW saturation stress at 0 K"},
    {MAT, "ptw_sinf", CFG_REAL, "-", "0.002819", 0, 10, 1, NULL, "PTW saturation stress at melt"},
    {MAT, "ptw_kappa", CFG_REAL, "-", "1.3", 0, 100, 0, NULL, "PTW temperature dependence kappa"},
    {MAT, "ptw_gamma", CFG_REAL, "-", "2.04e-5", 0, 1, 1, NULL, "PTW strain rate dependence gamma"},
    {MAT, "ptw_y0", CFG_REAL, "-", "0.0115", 0, 10, 1, NULL, "PTW yield stress at 0 K"},
    {MAT, "ptw_yinf", CFG_REAL, "-", "0.002003", 0, 10, 1, NULL, "PTW yield stress at melt"},
    {MAT, "ptw_y1", CFG_REAL, "-", "0.0168", 0, 10, 0, NULL, "PTW medium strain rate constant y1"},
    {MAT, "ptw_y2", CFG_REAL, "-", "0.2339", 0, 10, 0, NULL, "PTW medium strain rate exponent y2"},
    {MAT, "ptw_beta", CFG_REAL, "-", "0.2034", 0, 10, 0, NULL, "PTW high strain rate exponent beta (Tang's s1)"},
    {MAT, "ptw_rate_floor", CFG_REAL, "1/s", "1", 0, 1e6, 1, NULL,
     "smallest plastic strain rate given to PTW (its ln(gamma xi / rate) diverges at rate 0)"},
    {MAT, "atomic_mass", CFG_REAL, "kg", "4.48039e-26", 0, 1e-20, 1, NULL, "mass of one atom M, Eq. 2.8"},
    {MAT, "G0", CFG_REAL, "Pa", "28.8e9", 0, 1e13, 1, NULL, "MTS shear modulus at 0 K, Eq. 2.6"},
    {MAT, "D", CFG_REAL, "Pa", "3.44e9", 0, 1e13, 0, NULL, "MTS constant D, Eq. 2.6"},
    {MAT, "T0", CFG_REAL, "K", "215", 0, 1e5, 1, NULL, "MTS temperature constant T0, Eq. 2.6"},
    {MAT, "eos_c0", CFG_REAL, "m/s", "5240", 0, 1e5, 1, NULL, "Mie-Grueneisen bulk sound speed c0 (Steinberg 6061-T6)"},
    {MAT, "eos_s", CFG_REAL, "-", "1.4", 0, 10, 0, NULL, "Mie-Grueneisen Hugoniot slope s (Steinberg 6061-T6)"},
    {MAT, "eos_gamma0", CFG_REAL, "-", "1.97", 0, 10, 0, NULL, "Grueneisen gamma0 (Steinberg 6061-T6)"},
    {MAT, "melt_T0", CFG_REAL, "K", "933", 0, 1e5, 1, NULL, "SCG melt temperature at rho0, Eq. 2.9 (pure Al)"},
    {MAT, "melt_a", CFG_REAL, "-", "1.5", 0, 10, 0, NULL, "SCG volume correction a, Eq. 2.9 (Steinberg)"},
    {MAT, "specific_heat", CFG_REAL, "J/(kg K)", "900", 0, 1e6, 1, NULL, "C_p of Eq. 3.44"},
    {MAT, "conductivity", CFG_REAL, "W/(m K)", "167", 0, 1e4, 0, NULL,
     "thermal conductivity k for [impact] conduction = on (Al 6061-T6 at room temperature, ASM Handbook Vol. 2)"},
    {MAT, "taylor_quinney", CFG_REAL, "-", "0.9", 0, 1, 0, NULL, "fraction of plastic work turned into heat"},
    {MAT, "T_initial", CFG_REAL, "K", "298", 0, 1e5, 1, NULL,
     "initial temperature; below T0 / ln(1 + D/G0), where the MTS shear modulus reaches 0 (1905 K for the defaults)"},
    {MAT, "poisson", CFG_REAL, "-", NULL, 0, 0.499, CFG_MIN_EXCLUSIVE, NULL,
     "Poisson ratio for the wave speeds (K = 2 G(T_initial)(1 + nu)/(3(1 - 2 nu)), G of MTS, Eq. 2.6); default K = "
     "rho0 c0^2"},
    {MAT, "bulk_modulus", CFG_REAL, "Pa", NULL, 0, 1e13, 1, NULL,
     "bulk modulus for the wave speeds (time step, absorbing boundaries); default rho0 c0^2"},
    {NULL, NULL, 0, NULL, NULL, 0, 0, 0, NULL, NULL},
};

/* The MTS shear modulus G(T) = G0 - D/(exp(T0/T) - 1) (Eq. 2.6) is not positive at T_initial: this said so naming
 * D (default), without a line or a range, for T_initial = 2000 degC.  Named now: T_initial where the case gives it
 * or gives none of D, T0, G0, with the temperature below which G stays positive for the section's constants (and
 * the bound of each constant the case gives); else the constant the case gives (D, T0, then G0), with its bound at
 * this T_initial.  The melt temperature is only told: a body may start molten (no strength), as before. */
/* A bound moved inwards by 1e-5 of itself, so that printed with %.6g (rounding by at most 5e-6) every value it lets
 * through holds: "below 1905.48 K" would let 1905.48 K through, where G(T) is already negative (the bound is
 * 1905.4788 K). */
static double printable_bound(double x, int above)
{
    return above ? x * (1.0 + 1e-5) : x * (1.0 - 1e-5);
}

static int too_hot_for_shear_modulus(const struct case_file *c, const char *section, const struct mpm_material *m)
{
    static const char *const constants[] = {"D", "T0", "G0"};
    double T = m->T_initial, e = expm1(m->T0 / T), Tm = mpm_scg_melt_temperature(m, m->density);
    /* each constant's bound at T: D below G0 (exp(T0/T) - 1), T0 above T ln(1 + D/G0), G0 above D / (exp(T0/T) - 1) */
    const double bound[] = {printable_bound(m->G0 * e, 0), printable_bound(T * log1p(m->D / m->G0), 1),
                            printable_bound(m->D / e, 1)};
    double T_max = printable_bound(mpm_mts_positive_below(m), 0);
    const char *const side[] = {"below", "above", "above"}, *const unit[] = {"Pa", "K", "Pa"};
    char other[256] = "", melt[96] = "";
    const char *given = NULL;
    for (int k = 0; k < 3; k++)
        if (case_is_given(c, section, constants[k])) {
            size_t used = strlen(other);
            snprintf(other + used, sizeof other - used, "%s%s %s %.6g %s",
                     used ? " or " : "; or at this T_initial: ", constants[k], side[k], bound[k], unit[k]);
            if (!given)
                given = constants[k];
        }
    if (T >= Tm)
        snprintf(melt, sizeof melt, " (the SCG melt temperature at rho0 is %.6g K)", Tm);
    if (case_is_given(c, section, "T_initial") || !given)
        return case_invalid(c, section, "T_initial",
                            "the MTS shear modulus G0 - D/(exp(T0/T)-1) is not positive at %g K%s; allowed: above 0 K "
                            "and below %.6g K (G > 0 there for G0 = %g Pa, D = %g Pa, T0 = %g K)%s",
                            T, melt, T_max, m->G0, m->D, m->T0, other);
    int k = given[0] == 'D' ? 0 : given[0] == 'T' ? 1 : 2;
    return case_invalid(c, section, given,
                        "the MTS shear modulus G0 - D/(exp(T0/T)-1) is not positive at T_initial = %g K (G0 = %g Pa, "
                        "D = %g Pa, T0 = %g K); allowed: %s %.6g %s at this T_initial, or T_initial below %.6g K",
                        T, m->G0, m->D, m->T0, side[k], bound[k], unit[k], T_max);
}

static int load_material(const struct case_file *c, const char *key, const char *name, struct mpm_material *m)
{
    char section[96];
    /* "Al.6061" or "steel 316" cannot name a [material.NAME] section: say so instead of looking it up */
    if (!case_valid_name(name))
        return case_invalid(c, "impact", key,
                            "not a valid material name; allowed: " CASE_NAME_ALLOWED " (the NAME of "
                            "a [material.NAME] section)");
    if (strlen(name) >= sizeof m->name)
        return case_invalid(c, "impact", key, "material name longer than %zu characters", sizeof m->name - 1);
    snprintf(section, sizeof section, "material.%s", name);
    if (!case_has(c, section, "density"))
        return case_invalid(c, "impact", key,
                            "no [%s] section in the case (its keys default to Tang's aluminium: an empty "
                            "section is enough for aluminium; another material needs its own values)",
                            section);
    memset(m, 0, sizeof *m);
    snprintf(m->name, sizeof m->name, "%s", name);
    m->strength = case_is(c, section, "strength", "elastic") ? MPM_STRENGTH_ELASTIC : MPM_STRENGTH_PTW;
    m->density = case_real(c, section, "density");
    m->ptw_theta = case_real(c, section, "ptw_theta");
    m->ptw_p = case_real(c, section, "ptw_p");
    m->ptw_s0 = case_real(c, section, "ptw_s0");
    m->ptw_sinf = case_real(c, section, "ptw_sinf");
    m->ptw_kappa = case_real(c, section, "ptw_kappa");
    m->ptw_gamma = case_real(c, section, "ptw_gamma");
    m->ptw_y0 = case_real(c, section, "ptw_y0");
    m->ptw_yinf = case_real(c, section, "ptw_yinf");
    m->ptw_y1 = case_real(c, section, "ptw_y1");
    m->ptw_y2 = case_real(c, section, "ptw_y2");
    m->ptw_beta = case_real(c, section, "ptw_beta");
    m->rate_floor = case_real(c, section, "ptw_rate_floor");
    m->atomic_mass = case_real(c, section, "atomic_mass");
    m->G0 = case_real(c, section, "G0");
    m->D = case_real(c, section, "D");
    m->T0 = case_real(c, section, "T0");
    m->eos_c0 = case_real(c, section, "eos_c0");
    m->eos_s = case_real(c, section, "eos_s");
    m->eos_gamma0 = case_real(c, section, "eos_gamma0");
    m->melt_T0 = case_real(c, section, "melt_T0");
    m->melt_a = case_real(c, section, "melt_a");
    m->specific_heat = case_real(c, section, "specific_heat");
    m->conductivity = case_real(c, section, "conductivity");
    m->taylor_quinney = case_real(c, section, "taylor_quinney");
    m->T_initial = case_real(c, section, "T_initial");
    if (case_has(c, section, "bulk_modulus") && case_has(c, section, "poisson"))
        return case_invalid(c, section, "poisson", "give poisson or bulk_modulus, not both");
    m->bulk_modulus = m->density * m->eos_c0 * m->eos_c0;
    if (case_has(c, section, "bulk_modulus"))
        m->bulk_modulus = case_real(c, section, "bulk_modulus");
    if (case_has(c, section, "poisson")) {
        double nu = case_real(c, section, "poisson");
        m->bulk_modulus = 2.0 * mpm_mts_shear_modulus(m, m->T_initial) * (1.0 + nu) / (3.0 * (1.0 - 2.0 * nu));
    }
    if (!(mpm_mts_shear_modulus(m, m->T_initial) > 0.0))
        return too_hot_for_shear_modulus(c, section, m);
    if (m->ptw_sinf > m->ptw_s0)
        return case_invalid(c, section, "ptw_sinf", "above ptw_s0 = %g", m->ptw_s0);
    if (m->ptw_yinf > m->ptw_y0)
        return case_invalid(c, section, "ptw_yinf", "above ptw_y0 = %g", m->ptw_y0);
    return SC_OK;
}

/* Index of material `name` in cfg, loading it on first use. */
static int material_index(const struct case_file *c, const char *key, const char *name, struct mpm_config *cfg,
                          int *index)
{
    for (int i = 0; i < cfg->material_count; i++)
        if (strcmp(cfg->materials[i].name, name) == 0) {
            *index = i;
            return SC_OK;
        }
    struct mpm_material *grown = realloc(cfg->materials, (size_t)(cfg->material_count + 1) * sizeof *grown);
    if (!grown)
        SC_FAIL_OOM((size_t)(cfg->material_count + 1) * sizeof *grown, "the impact materials");
    cfg->materials = grown;
    SC_TRY(load_material(c, key, name, &cfg->materials[cfg->material_count]));
    *index = cfg->material_count++;
    return SC_OK;
}

static int add_body(struct mpm_config *cfg, const struct mpm_body *body)
{
    struct mpm_body *grown = realloc(cfg->bodies, (size_t)(cfg->body_count + 1) * sizeof *grown);
    if (!grown)
        SC_FAIL_OOM((size_t)(cfg->body_count + 1) * sizeof *grown, "the impact bodies");
    cfg->bodies = grown;
    cfg->bodies[cfg->body_count++] = *body;
    return SC_OK;
}

static int load_substrate(const struct case_file *c, struct mpm_config *cfg)
{
    cfg->substrate = case_is(c, "impact", "substrate", "rigid") ? MPM_SUBSTRATE_RIGID
                     : case_is(c, "impact", "substrate", "box") ? MPM_SUBSTRATE_BOX
                                                                : MPM_SUBSTRATE_CYLINDER;
    cfg->substrate_top = 0.0;
    if (cfg->substrate == MPM_SUBSTRATE_RIGID)
        return SC_OK;
    struct mpm_body body = {
        .shape = cfg->substrate == MPM_SUBSTRATE_BOX ? MPM_BOX : MPM_CYLINDER,
        .d = case_real(c, "impact", "substrate_diameter"),
        .h = case_real(c, "impact", "substrate_height"),
        .substrate = 1,
    };
    body.center[2] = -0.5 * body.h;
    cfg->fixed_bottom = case_is(c, "impact", "substrate_bottom", "fixed");
    cfg->spring_bottom = case_is(c, "impact", "substrate_bottom", "spring");
    cfg->spring_sides = case_is(c, "impact", "substrate_sides", "spring");
    cfg->spring_alpha_normal = case_real(c, "impact", "spring_alpha_normal");
    cfg->spring_alpha_tangential = case_real(c, "impact", "spring_alpha_tangential");
    if (cfg->device == MPM_DEVICE_GPU && (cfg->spring_bottom || cfg->spring_sides))
        return case_invalid(c, "impact", cfg->spring_bottom ? "substrate_bottom" : "substrate_sides",
                            "the GPU step has no boundary springs; allowed: fixed or free (substrate_bottom), "
                            "dashpot (substrate_sides), or [run] device = cpu");
    cfg->substrate_bottom = -body.h;
    SC_TRY(material_index(c, "substrate_material", case_text(c, "impact", "substrate_material"), cfg, &body.material));
    /* the key that is too small, the diameter (box side) first */
    if (body.d < 2.0 * cfg->spacing)
        return case_invalid(c, "impact", "substrate_diameter",
                            "the substrate's %s must be at least two point spacings; allowed: at least %g m (twice "
                            "spacing = %g m), at most 1 m",
                            body.shape == MPM_BOX ? "side" : "diameter", 2.0 * cfg->spacing, cfg->spacing);
    if (body.h < 2.0 * cfg->spacing)
        return case_invalid(c, "impact", "substrate_height",
                            "the substrate's height must be at least two point spacings; allowed: at least %g m (twice "
                            "spacing = %g m), at most 1 m",
                            2.0 * cfg->spacing, cfg->spacing);
    return add_body(cfg, &body);
}

/* [run] device = gpu: a build with the GPU step (make CUDA=1), a device it runs on, and trilinear shape functions
 * (the GPU step has no others). */
static int load_device(const struct case_file *c, struct mpm_config *cfg)
{
    cfg->device = case_is(c, "run", "device", "gpu") ? MPM_DEVICE_GPU : MPM_DEVICE_CPU;
    if (cfg->device == MPM_DEVICE_CPU)
        return SC_OK;
    if (!mpm_gpu_built())
        return case_invalid(c, "run", "device",
                            "this spraycoat was built without the GPU step; allowed: cpu, or gpu with a build of "
                            "make CUDA=1 (docs/gpu.md)");
    if (mpm_gpu_probe() != 0)
        return case_invalid(c, "run", "device", "%s", mpm_gpu_message());
    if (cfg->shape_function != MPM_LINEAR)
        return case_invalid(c, "run", "device",
                            "the GPU step has trilinear shape functions only; allowed: cpu, or gpu with [impact] "
                            "shape_functions = linear");
    return SC_OK;
}

/* [impact] transfer, after the device: apic has no FLIP share to blend, and the GPU step is FLIP's only. */
static int load_transfer(const struct case_file *c, struct mpm_config *cfg)
{
    cfg->transfer = case_is(c, "impact", "transfer", "apic") ? MPM_TRANSFER_APIC : MPM_TRANSFER_FLIP;
    if (cfg->transfer == MPM_TRANSFER_FLIP)
        return SC_OK;
    if (case_is_given(c, "impact", "flip"))
        return case_invalid(c, "impact", "flip",
                            "given with transfer = apic, which has no FLIP share to blend; allowed: leave flip out, "
                            "or transfer = flip");
    if (cfg->device == MPM_DEVICE_GPU)
        return case_invalid(c, "impact", "transfer",
                            "apic is not in the GPU step; allowed: flip with [run] device = gpu, or apic with "
                            "device = cpu");
    return SC_OK;
}

/* [impact] symmetry, after the shape functions: the mirror planes' nodal condition (contact_node.h mirror_node, for
 * the CPU and the GPU step) is exact for trilinear weights only, whose points on one side reach no node on the
 * other.  Heat conduction takes the mirror images of the neighbours (conduction.c exchange_sum). */
static int load_symmetry(const struct case_file *c, struct mpm_config *cfg)
{
    cfg->mirror[1] = !case_is(c, "impact", "symmetry", "none");
    cfg->mirror[0] = case_is(c, "impact", "symmetry", "quarter");
    if (cfg->mirror[1] && cfg->shape_function != MPM_LINEAR)
        return case_invalid(c, "impact", "symmetry",
                            "shape_functions = ugimp reach across the planes; allowed: none, or half|quarter with "
                            "shape_functions = linear");
    return SC_OK;
}

int mpm_mirror_copies(const struct mpm_config *cfg)
{
    return 1 << (cfg->mirror[0] + cfg->mirror[1]);
}

/* bonding_preheat_exponent = auto: the n that makes the pair's v_crit fall as the square root of the melt-heat share
 * (Schmidt et al. 2006), n = 0.5 / a for a v_crit that grows as (critical value)^a: a = 1.02 for the strain model
 * (eps_c 2.3 and 2.8: 757.5 and 926.4 m/s, cases/calibrate_vcrit_al.csv), a = 0.54 for the energy model (G_c 480 to
 * 936 J/m2: 650 to 917 m/s at 14 um, docs/physics.md "Bonding of a heated particle"), rounded to 0.5 and 1. */
#define PREHEAT_EXPONENT_STRAIN 0.5
#define PREHEAT_EXPONENT_ENERGY 1.0
static double preheat_exponent(const struct case_file *c, enum mpm_bonding bonding)
{
    if (!case_is(c, "impact", "bonding_preheat_exponent", "auto"))
        return case_real(c, "impact", "bonding_preheat_exponent");
    return bonding == MPM_BONDING_ENERGY ? PREHEAT_EXPONENT_ENERGY : PREHEAT_EXPONENT_STRAIN;
}

/* eps_c = auto: the strain model's 10-cell calibration for the case's heat transport (docs/physics.md "Bonding
 * calibration"): adiabatic, cases/calibrate_vcrit_al.csv; with conduction = on, cases/calibrate_vcrit_al_conduction.csv
 * (the whole model: v_crit 797.5 and 767.5 m/s of 14 and 30 um against the adiabatic fit's 797.5 and 762.5). */
#define EPS_C_ADIABATIC  2.4680778017283251
#define EPS_C_CONDUCTION 2.5060015761506595
static double eps_c(const struct case_file *c)
{
    if (!case_is(c, "impact", "eps_c", "auto"))
        return case_real(c, "impact", "eps_c");
    return case_is(c, "impact", "conduction", "on") ? EPS_C_CONDUCTION : EPS_C_ADIABATIC;
}

/* The default of an [impact] key of the table above, as a number. */
static double impact_default(const char *key)
{
    for (const struct cfg_key *k = mpm_case_keys; k->key; k++)
        if (strcmp(k->section, "impact") == 0 && strcmp(k->key, key) == 0)
            return strtod(k->default_value, NULL);
    return NAN;
}

/* Whether the case's bonding model runs with the shipped calibration's parameters (the keys' defaults, or the same
 * numbers typed, as cases/vcrit_al.ini does). */
static int shipped_bonding(const struct mpm_config *cfg)
{
    if (cfg->bonding == MPM_BONDING_STRAIN)
        return (cfg->eps_c == EPS_C_ADIABATIC || cfg->eps_c == EPS_C_CONDUCTION) &&
               cfg->eps_rate_c == impact_default("eps_rate_c");
    if (cfg->bonding == MPM_BONDING_ENERGY)
        return cfg->Gc == impact_default("Gc") && cfg->Gc_rate == impact_default("Gc_rate");
    return 0;
}

/* docs/physics.md "Bonding calibration": the strain model's parameters were fitted at 10 cells across the particle
 * with points a third of a cell apart (cases/calibrate_vcrit_al.ini, the grid scaled with the diameter), the energy
 * model's on cells of 2.0 um with points 0.667 um apart for every size (cases/bonding_calibration_al.csv). */
#define CALIBRATED_CELLS_ACROSS 10.0
#define CALIBRATED_ENERGY_GRID  2.0e-6
int mpm_bonding_calibrated_resolution(const struct mpm_config *cfg, int b)
{
    const struct mpm_body *body = &cfg->bodies[b];
    if (body->substrate || !shipped_bonding(cfg))
        return -1;
    double per_cell = cfg->grid / cfg->spacing; /* points per cell edge: 3 in both calibrations */
    if (fabs(per_cell - 3.0) > 0.1)
        return 0;
    if (cfg->bonding == MPM_BONDING_STRAIN)
        return fabs(body->d / cfg->grid - CALIBRATED_CELLS_ACROSS) <= 0.05 * CALIBRATED_CELLS_ACROSS;
    return fabs(cfg->grid - CALIBRATED_ENERGY_GRID) <= 0.01 * CALIBRATED_ENERGY_GRID;
}

/* series_every and snapshot_every against t_end (MPM_MAX_CLOCK_TICKS): an interval of 1e-30 s passed "> 0" and the
 * run stalled at its first step, adding it to a time it could no longer move. */
#define TEXT_OF(x)             #x
#define CLOCK_TICKS_TEXT_OF(x) TEXT_OF(x)
#define CLOCK_TICKS_TEXT       CLOCK_TICKS_TEXT_OF(MPM_MAX_CLOCK_TICKS)
static int check_clock(const struct case_file *c, const char *key, const char *what, double every, double t_end)
{
    double least = t_end / MPM_MAX_CLOCK_TICKS;
    if (every >= least * (1.0 - 1e-9))
        return SC_OK;
    return case_invalid(c, "impact", key,
                        "%.3g %s over t_end = %g s, more than " CLOCK_TICKS_TEXT
                        "; allowed: at least %g s (t_end / " CLOCK_TICKS_TEXT "), at most 1 s",
                        t_end / every, what, t_end, least);
}

static int load_numerics(const struct case_file *c, struct mpm_config *cfg)
{
    cfg->grid = case_real(c, "impact", "grid");
    cfg->spacing = case_real(c, "impact", "spacing");
    cfg->cfl = case_real(c, "impact", "cfl");
    cfg->t_end = case_real(c, "impact", "t_end");
    cfg->box_margin = case_real(c, "impact", "box_margin");
    cfg->shape_function = case_is(c, "impact", "shape_functions", "ugimp") ? MPM_UGIMP : MPM_LINEAR;
    cfg->contact = case_is(c, "impact", "contact", "stick")      ? MPM_CONTACT_STICK
                   : case_is(c, "impact", "contact", "friction") ? MPM_CONTACT_FRICTION
                                                                 : MPM_CONTACT_FRICTIONLESS;
    cfg->contact_scheme = case_is(c, "impact", "contact_scheme", "consistent") ? MPM_CONTACT_CONSISTENT
                          : case_is(c, "impact", "contact_scheme", "thesis")   ? MPM_CONTACT_THESIS
                                                                               : MPM_CONTACT_ONCE;
    cfg->contact_gap = case_real(c, "impact", "contact_gap");
    cfg->bond_gap = case_real(c, "impact", "bond_gap");
    cfg->contact_approach =
        case_is(c, "impact", "contact_approach", "common") ? MPM_APPROACH_COMMON : MPM_APPROACH_BOTH;
    cfg->bond_growth = case_is(c, "impact", "bond_growth", "contact") ? MPM_GROWTH_CONTACT : MPM_GROWTH_APPROACH;
    cfg->flip = case_real(c, "impact", "flip");
    cfg->friction = case_real(c, "impact", "friction");
    cfg->bonding = case_is(c, "impact", "bonding", "strain") ? MPM_BONDING_STRAIN
                   : case_is(c, "impact", "bonding", "none") ? MPM_BONDING_NONE
                                                             : MPM_BONDING_ENERGY;
    cfg->Gc = case_real(c, "impact", "Gc");
    cfg->Gc_rate = case_real(c, "impact", "Gc_rate");
    cfg->eps_c = eps_c(c);
    cfg->eps_rate_c = case_real(c, "impact", "eps_rate_c");
    cfg->bonding_floor = case_real(c, "impact", "bonding_floor");
    cfg->bonding_preheat = case_is(c, "impact", "bonding_preheat", "none") ? MPM_PREHEAT_NONE : MPM_PREHEAT_MELT_HEAT;
    cfg->bonding_T_reference = case_real(c, "impact", "bonding_T_reference");
    cfg->bonding_preheat_exponent = preheat_exponent(c, cfg->bonding);
    cfg->pbcp_threshold = case_real(c, "impact", "pbcp_threshold");
    cfg->vrest_threshold = case_real(c, "impact", "vrest_threshold");
    cfg->vrest_filter = case_real(c, "impact", "vrest_filter");
    cfg->settle_window = case_real(c, "impact", "settle_window");
    cfg->settle_vcom = case_real(c, "impact", "settle_vcom");
    cfg->settle_pbcp = case_real(c, "impact", "settle_pbcp");
    cfg->stop_when_settled = case_is(c, "impact", "stop_when_settled", "yes");
    cfg->snapshot_every = case_real(c, "impact", "snapshot_every");
    cfg->series_every = case_real(c, "impact", "series_every");
    cfg->viscosity.linear = case_real(c, "impact", "bulk_viscosity_linear");
    cfg->viscosity.quadratic = case_real(c, "impact", "bulk_viscosity_quadratic");
    cfg->viscosity.length = cfg->grid;
    cfg->absorbing = case_is(c, "impact", "absorbing", "yes");
    SC_TRY(check_clock(c, "series_every", "series rows", cfg->series_every, cfg->t_end));
    SC_TRY(check_clock(c, "snapshot_every", "snapshots", cfg->snapshot_every, cfg->t_end));
    if (cfg->settle_window < 4.0 * cfg->series_every * (1.0 - 1e-9))
        return case_invalid(c, "impact", "settle_window",
                            "shorter than 4 series_every (%g s): the window must hold several series rows; allowed: "
                            "at least %g s",
                            cfg->series_every, 4.0 * cfg->series_every);
    if (cfg->spacing > cfg->grid)
        return case_invalid(c, "impact", "spacing", "larger than the grid cell %g m; allowed: at most DCell",
                            cfg->grid);
    if (cfg->grid / cfg->spacing > 16.0)
        return case_invalid(c, "impact", "spacing",
                            "more than 16 points per cell edge (DCell = %g m); allowed: "
                            "spacing >= DCell/16",
                            cfg->grid);
    SC_TRY(load_device(c, cfg));
    SC_TRY(load_transfer(c, cfg));
    cfg->conduction = case_is(c, "impact", "conduction", "on");
    return load_symmetry(c, cfg);
}

/* The bodies CSV's columns, with the ranges of the [impact] keys they stand for (positions and sizes as
 * substrate_diameter and diameter: at most 1 m, and d at least 1 nm; velocities as velocity: at most 1e5 m/s).  The
 * order is the order of the fields of struct mpm_body's set-up below; a file may list the columns in any order. */
enum {
    BODY_SHAPE,
    BODY_X,
    BODY_VX = BODY_X + 3,
    BODY_D = BODY_VX + 3,
    BODY_H,
    BODY_MATERIAL,
    BODY_TEMPERATURE,
    BODY_COLUMNS
};
static const struct csv_column body_columns[BODY_COLUMNS] = {
    {"shape", CSV_WORD, 0, 0, 0, NULL, "sphere|cylinder|box"},
    {"x", CSV_NUMBER, -1, 1, 0, "m", NULL},
    {"y", CSV_NUMBER, -1, 1, 0, "m", NULL},
    {"z", CSV_NUMBER, -1, 1, 0, "m", NULL},
    {"vx", CSV_NUMBER, -1e5, 1e5, 0, "m/s", NULL},
    {"vy", CSV_NUMBER, -1e5, 1e5, 0, "m/s", NULL},
    {"vz", CSV_NUMBER, -1e5, 1e5, 0, "m/s", NULL},
    {"d", CSV_NUMBER, 1e-9, 1, 0, "m", NULL},
    {"h", CSV_NUMBER, 0, 1, 0, "m", NULL},
    {"material", CSV_NAME, 0, 0, 0, NULL, NULL},
    /* optional (last): the body's points start at this temperature instead of its material's T_initial (range as
     * T_initial's) */
    {"temperature", CSV_NUMBER, 0, 1e5, 1, "K", NULL},
};

static int parse_body_row(const struct case_file *c, const char *path, const struct csv_table *table, size_t row,
                          struct mpm_config *cfg, struct mpm_body *body)
{
    static const enum mpm_shape shapes[] = {MPM_SPHERE, MPM_CYLINDER, MPM_BOX};
    const double *values = table->numbers + row * (size_t)table->columns;
    long line = table->lines[row];
    body->shape = shapes[(int)values[BODY_SHAPE]];
    memcpy(body->center, values + BODY_X, sizeof body->center);
    memcpy(body->velocity, values + BODY_VX, sizeof body->velocity);
    body->d = values[BODY_D];
    body->h = values[BODY_H];
    if (body->shape != MPM_SPHERE && !(body->h > 0))
        return case_invalid(c, "impact", "bodies", "%s:%ld: h = %g: a cylinder's or box's height h must be > 0 m", path,
                            line, body->h);
    if (body->center[2] - (body->shape == MPM_SPHERE ? 0.5 * body->d : 0.5 * body->h) < cfg->substrate_top - 1e-12)
        return case_invalid(c, "impact", "bodies", "%s:%ld: the body reaches below the substrate's top z = 0", path,
                            line);
    SC_TRY(
        material_index(c, "bodies", table->names[row * (size_t)table->columns + BODY_MATERIAL], cfg, &body->material));
    if (table->columns < BODY_COLUMNS)
        return SC_OK; /* no temperature column: the material's T_initial */
    double T = values[BODY_TEMPERATURE];
    /* the MTS shear modulus (Eq. 2.6) must stay positive, as load_material checks it at T_initial */
    if (!(mpm_mts_shear_modulus(&cfg->materials[body->material], T) > 0.0))
        return case_invalid(c, "impact", "bodies",
                            "%s:%ld: temperature = %g K: the shear modulus G0 - D/(exp(T0/T)-1) of the body's "
                            "material is not positive there; allowed: above 0 K and below %.6g K",
                            path, line, T, printable_bound(mpm_mts_positive_below(&cfg->materials[body->material]), 0));
    body->temperature = T;
    return SC_OK;
}

static int load_bodies_file(const struct case_file *c, struct mpm_config *cfg)
{
    char path[4096], message[1024];
    SC_TRY(case_path(c, "impact", "bodies", path, sizeof path));
    struct csv_table table;
    int columns = csv_header_has(path, "temperature") ? BODY_COLUMNS : BODY_COLUMNS - 1;
    if (csv_read(path, body_columns, columns, 0, &table, message, sizeof message) != SC_OK)
        return case_invalid(c, "impact", "bodies", "%s", message);
    int status = SC_OK;
    if (table.rows > (size_t)INT_MAX / 2)
        SC_CHECK(status,
                 case_invalid(c, "impact", "bodies", "%s: %zu bodies; at most %d", path, table.rows, INT_MAX / 2),
                 done);
    size_t bytes = ((size_t)cfg->body_count + table.rows) * sizeof *cfg->bodies;
    struct mpm_body *grown = realloc(cfg->bodies, bytes ? bytes : 1);
    if (!grown)
        SC_FAIL_OOM_AT(status, done, bytes, "the impact bodies");
    cfg->bodies = grown;
    for (size_t row = 0; row < table.rows; row++) {
        struct mpm_body body = {0};
        SC_CHECK(status, parse_body_row(c, path, &table, row, cfg, &body), done);
        cfg->bodies[cfg->body_count++] = body;
    }
done:
    csv_free(&table);
    return status;
}

static int load_single_particle(const struct case_file *c, struct mpm_config *cfg)
{
    int material;
    SC_TRY(material_index(c, "material", case_text(c, "impact", "material"), cfg, &material));
    struct mpm_body body = {.shape = MPM_SPHERE, .material = material};
    SC_TRY(add_body(cfg, &body));
    return mpm_config_single_particle(cfg, case_real(c, "impact", "diameter"), case_real(c, "impact", "velocity"),
                                      case_real(c, "impact", "angle") * M_PI / 180.0);
}

int mpm_config_set_spheres(struct mpm_config *cfg, int count, const double *diameter, const double *center,
                           const double *velocity)
{
    int keep = 0, material = -1;
    for (int i = 0; i < cfg->body_count; i++) {
        if (cfg->bodies[i].substrate)
            cfg->bodies[keep++] = cfg->bodies[i];
        else if (material < 0)
            material = cfg->bodies[i].material;
    }
    if (material < 0)
        SC_FAIL(SC_EINPUT, "no particle material for the spheres");
    cfg->body_count = keep;
    for (int k = 0; k < count; k++) {
        struct mpm_body body = {.shape = MPM_SPHERE, .d = diameter[k], .material = material};
        for (int j = 0; j < 3; j++) {
            body.center[j] = center[3 * k + j];
            body.velocity[j] = velocity[3 * k + j];
        }
        body.center[2] += cfg->substrate_top;
        SC_TRY(add_body(cfg, &body));
    }
    return SC_OK;
}

int mpm_config_set_particle_temperatures(struct mpm_config *cfg, int count, const double *temperature)
{
    if (count > cfg->body_count)
        SC_FAIL(SC_EINPUT, "impact: %d particle temperatures for %d bodies", count, cfg->body_count);
    for (int k = 0; k < count; k++) {
        struct mpm_body *b = &cfg->bodies[cfg->body_count - count + k];
        const struct mpm_material *m = &cfg->materials[b->material];
        double T = temperature[k];
        /* the MTS shear modulus (Eq. 2.6) must stay positive, as load_material checks it at T_initial */
        if (!(T > 0.0 && T <= 1e5) || !(mpm_mts_shear_modulus(m, T) > 0.0))
            SC_FAIL(SC_EINPUT,
                    "impact: particle %d: temperature %g K; allowed: above 0 K, at most 1e5 K, with a positive "
                    "shear modulus G0 - D/(exp(T0/T)-1) of its material",
                    k, T);
        b->temperature = T;
    }
    return SC_OK;
}

int mpm_config_single_particle(struct mpm_config *cfg, double diameter, double speed, double angle)
{
    /* touching the substrate's top: the thesis starts its runs at first contact (Section 5.2.1) */
    const double center[3] = {0.0, 0.0, 0.5 * diameter};
    const double velocity[3] = {speed * sin(angle), 0.0, -speed * cos(angle)};
    return mpm_config_set_spheres(cfg, 1, &diameter, center, velocity);
}

/* Geometric similarity (docs/physics.md "Resolution in cells per diameter"): every length and time of the set-up
 * times `factor`.  Without a length scale in the response (rate-independent, adiabatic) the scaled impact is the same
 * solution in x/d and t v/d, on a grid with the same cells per particle; what stays of the size is the rate
 * dependence of strength and bonding, and with conduction = on the diffusion length sqrt(kappa t), a physical length
 * (the conduction's kernel scales with the spacing, its diffusivity does not).  The spring boundaries' stiffness alpha
 * G / R follows R, the dashpots need nothing. */
void mpm_config_scale_lengths(struct mpm_config *cfg, double factor)
{
    cfg->grid *= factor;
    cfg->spacing *= factor;
    cfg->box_margin *= factor;
    cfg->viscosity.length *= factor;
    cfg->substrate_top *= factor;
    cfg->substrate_bottom *= factor;
    for (int b = 0; b < cfg->body_count; b++) {
        struct mpm_body *body = &cfg->bodies[b];
        body->d *= factor;
        body->h *= factor;
        for (int k = 0; k < 3; k++)
            body->center[k] *= factor;
    }
    cfg->t_end *= factor;
    cfg->settle_window *= factor;
    cfg->series_every *= factor;
    cfg->snapshot_every *= factor;
}

/* bonding_preheat = melt_heat divides by Tm - bonding_T_reference: the reference must lie below every melt. */
static int check_bonding_reference(const struct case_file *c, const struct mpm_config *cfg)
{
    if (cfg->bonding_preheat == MPM_PREHEAT_NONE || cfg->bonding == MPM_BONDING_NONE)
        return SC_OK;
    for (int k = 0; k < cfg->material_count; k++) {
        double Tm = mpm_scg_melt_temperature(&cfg->materials[k], cfg->materials[k].density);
        if (!(cfg->bonding_T_reference < Tm))
            return case_invalid(
                c, "impact", "bonding_T_reference",
                "%g K is not below the melt temperature %g K of a material; allowed: above 0 and below %g K "
                "(or bonding_preheat = none)",
                cfg->bonding_T_reference, Tm, Tm);
    }
    return SC_OK;
}

/* The bodies of the case against its mirror planes (mpm_mirror_check), named with the file and line of symmetry. */
static int check_mirrored_bodies(const struct case_file *c, const struct mpm_config *cfg)
{
    char why[256];
    if (mpm_mirror_check(cfg, why, sizeof why) == 0)
        return SC_OK;
    return case_invalid(c, "impact", "symmetry",
                        "%s; allowed: none, or half|quarter with every body centred on its "
                        "planes and not moving across them (quarter: angle = 0)",
                        why);
}

int mpm_config_load(const struct case_file *c, struct mpm_config *cfg)
{
    memset(cfg, 0, sizeof *cfg);
    int status, unused;
    SC_CHECK(status, load_numerics(c, cfg), done);
    SC_CHECK(status, load_substrate(c, cfg), done);
    SC_CHECK(status, case_has(c, "impact", "bodies") ? load_bodies_file(c, cfg) : load_single_particle(c, cfg), done);
    /* every material the case names is checked, also one used by no body */
    SC_CHECK(status, material_index(c, "material", case_text(c, "impact", "material"), cfg, &unused), done);
    SC_CHECK(status, check_bonding_reference(c, cfg), done);
    SC_CHECK(status, check_mirrored_bodies(c, cfg), done);
done:
    if (status != SC_OK)
        mpm_config_free(cfg);
    return status;
}

/* A [material.NAME] section that gives no key is Tang's aluminium whatever its name: said when the name does not
 * say aluminium (the message refusing a missing section says an empty one is enough, which is true for aluminium
 * only; a review: [material.copper] left empty ran as aluminium without a word). */
static void warn_all_defaults(const struct case_file *c, const char *name)
{
    char section[96];
    snprintf(section, sizeof section, "material.%s", name);
    for (const struct cfg_key *k = mpm_case_keys; k->section; k++)
        if (strcmp(k->section, MAT) == 0 && case_is_given(c, section, k->key))
            return;
    int aluminium = strncasecmp(name, "aluminium", 9) == 0 || strncasecmp(name, "aluminum", 8) == 0 ||
                    (strncasecmp(name, "al", 2) == 0 && isdigit((unsigned char)name[2])); /* al6061, AL1100 */
    if (!aluminium) /* alumina and alloy625 are not */
        log_warn("impact: [material.%s] gives no key, so every property is Tang's aluminium default: give the "
                 "material's own (docs/keys.md, [material.NAME])",
                 name);
}

int mpm_config_warn_unused_materials(const struct case_file *c, const struct mpm_config *cfg)
{
    const char *names[64];
    size_t count = case_section_names(c, "material", names, 64), unused = 0;
    char used[256] = ""; /* for the message: the materials the bodies use */
    for (int m = 0, length = 0; m < cfg->material_count && length < (int)sizeof used; m++) {
        int bodies = 0;
        for (int b = 0; b < cfg->body_count; b++)
            bodies += cfg->bodies[b].material == m;
        if (bodies)
            length += snprintf(used + length, sizeof used - (size_t)length, "%s%s", length ? ", " : "",
                               cfg->materials[m].name);
    }
    for (size_t k = 0; k < count && k < 64; k++) {
        int in_use = 0;
        for (int b = 0; b < cfg->body_count; b++)
            in_use |= strcmp(cfg->materials[cfg->bodies[b].material].name, names[k]) == 0;
        if (in_use)
            continue;
        unused++;
        log_warn("impact: [material.%s] is used by no body (the bodies' materials: %s): a misspelt name leaves the "
                 "bodies on another material",
                 names[k], used[0] ? used : "none");
    }
    for (int m = 0; m < cfg->material_count; m++)
        warn_all_defaults(c, cfg->materials[m].name);
    return (int)unused;
}

void mpm_config_free(struct mpm_config *cfg)
{
    free(cfg->materials);
    free(cfg->bodies);
    cfg->materials = NULL;
    cfg->bodies = NULL;
    cfg->material_count = cfg->body_count = 0;
}
