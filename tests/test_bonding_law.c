/* The bonding laws of mpm/bonding.c over a sweep of the rate ratio r (issue 22, item 4): bounded and monotone in
 * the rate, and equal to the thesis's Eqs. 4.16-4.17 (energy) and 4.3-4.5 (strain) where 1 - ln r is at least
 * bonding_floor.  As printed, dD = dG / (G_c (1 - ln r)) grows without bound as r -> e- and is 0 above e. */
#include <math.h>

#include "check.h"
/* A white-box test: includes the module-private header mpm/mpm_impl.h (only tests may; tests/test_symbols.sh). */
#include "mpm/mpm_impl.h"

/* Al constants of the thesis calibration, the shipped defaults when this test was written (G_c 1500 J/m2, dG_c/dt
 * 2e11 J/m2/s, eps_c 1.4, eps_rate_c 1.35e9 1/s; mpm/params.c now ships G_c 720, eps_c auto 2.468 (2.506 with
 * conduction) and eps_rate_c 1e5, dG_c/dt still 2e11), on a 1.5 um grid and a 0.5 ns ... 1 ps step: the sweep is
 * over the rate ratio r, which they only scale */
static struct mpm_config law(enum mpm_bonding model)
{
    return (struct mpm_config){.bonding = model,
                               .grid = 1.5e-6,
                               .Gc = 1500.0,
                               .Gc_rate = 2e11,
                               .eps_c = 1.4,
                               .eps_rate_c = 1.35e9,
                               .bonding_floor = 0.5};
}

#define SWEEP 2001 /* r from 1e-6 to 1e6, 2000 steps a decade / 6 */
static const double sigma_vm = 300e6, dt = 1e-12;

/* The plastic strain increment that gives rate ratio r in `model` (energy: dG / (G_c_rate dt); strain: the strain
 * rate over eps_rate_c). */
static double increment_for(const struct mpm_config *cfg, double r)
{
    return cfg->bonding == MPM_BONDING_ENERGY ? r * cfg->Gc_rate * dt / (sigma_vm * cfg->grid)
                                              : r * cfg->eps_rate_c * dt;
}

/* The printed law: Eq. 4.16 with Eq. 4.17, or Eq. 4.5 with Eq. 4.4 (NaN where its factor is not positive). */
static double printed(const struct mpm_config *cfg, double deps)
{
    if (cfg->bonding == MPM_BONDING_ENERGY) {
        double dG = sigma_vm * deps * cfg->grid, G_bond = cfg->Gc * (1.0 - log(dG / (cfg->Gc_rate * dt)));
        return G_bond > 0 ? dG / G_bond : NAN;
    }
    double eps_bond = cfg->eps_c * (1.0 - log(deps / dt / cfg->eps_rate_c));
    return eps_bond > 0 ? deps / eps_bond : NAN;
}

/* The largest dD the bounded law may give: the increment over the smallest critical value, floor x critical. */
static double bound(const struct mpm_config *cfg, double deps)
{
    return cfg->bonding == MPM_BONDING_ENERGY ? sigma_vm * deps * cfg->grid / (cfg->Gc * cfg->bonding_floor)
                                              : deps / (cfg->eps_c * cfg->bonding_floor);
}

static void sweep(enum mpm_bonding model)
{
    struct mpm_config cfg = law(model);
    double previous = 0.0, r_join = exp(1.0 - cfg.bonding_floor), worst_equal = 0.0;
    int increasing = 1, bounded = 1, compared = 0;
    for (int k = 0; k < SWEEP; k++) {
        double r = pow(10.0, -6.0 + 12.0 * k / (SWEEP - 1)), deps = increment_for(&cfg, r);
        double dD = mpm_bonding_increment(&cfg, deps, sigma_vm, dt, 1.0);
        if (!(dD >= previous) || !isfinite(dD)) {
            if (increasing)
                printf("  r = %.6g: dD = %.6g after %.6g\n", r, dD, previous);
            increasing = 0;
        }
        if (!(dD <= bound(&cfg, deps) * (1 + 1e-12))) {
            if (bounded)
                printf("  r = %.6g: dD = %.6g above the bound %.6g\n", r, dD, bound(&cfg, deps));
            bounded = 0;
        }
        if (r <= r_join) { /* the printed law's well-behaved range: 1 - ln r >= floor */
            worst_equal = fmax(worst_equal, fabs(dD / printed(&cfg, deps) - 1.0));
            compared++;
        }
        previous = dD;
    }
    CHECK(increasing, "dD increases with the rate over r = 1e-6 .. 1e6 (finite everywhere)");
    CHECK(bounded, "dD at most increment / (critical value x bonding_floor)");
    CHECK(compared > 1000, "%d rates in the printed law's well-behaved range", compared);
    CHECK(worst_equal <= 1e-14, "equal to the printed law for 1 - ln r >= floor: worst relative difference %.3g",
          worst_equal);
    /* the jetting points the printed law gave nothing (r > e) now bond fastest: more than just below e */
    double below = mpm_bonding_increment(&cfg, increment_for(&cfg, 0.99 * M_E), sigma_vm, dt, 1.0);
    double above = mpm_bonding_increment(&cfg, increment_for(&cfg, 10.0 * M_E), sigma_vm, dt, 1.0);
    CHECK(above > below && below > 0, "r = 10e: dD %.4g > r = 0.99e: dD %.4g > 0", above, below);
}

static void test_energy_law(void)
{
    sweep(MPM_BONDING_ENERGY);
}

static void test_strain_law(void)
{
    sweep(MPM_BONDING_STRAIN);
}

/* bonding_floor = 1: the factor never falls below 1, dD = dG / G_c above the critical rate. */
static void test_floor_one(void)
{
    struct mpm_config cfg = law(MPM_BONDING_ENERGY);
    cfg.bonding_floor = 1.0;
    double deps = increment_for(&cfg, 50.0);
    CHECK_CLOSE(mpm_bonding_increment(&cfg, deps, sigma_vm, dt, 1.0), sigma_vm * deps * cfg.grid / cfg.Gc, 1e-15, 0.0,
                "dD at r = 50 with floor 1");
    CHECK(mpm_bonding_increment(&cfg, 0.0, sigma_vm, dt, 1.0) == 0.0, "no plastic increment: dD = 0");
}

/* The factor of bonding_preheat = melt_heat from its q, the share of the melt heat to the power n: q / (2 - q). */
static double preheat_factor(double q)
{
    return q / (2.0 - q);
}

/* bonding_preheat = melt_heat: a body at T0 has the critical value times y = q / (2 - q), q = ((Tm - T0) / (Tm -
 * T_ref))^n, Tm the SCG melt at rho0 (Eq. 2.9: melt_T0 there), so that the harmonic mean 2 y / (1 + y) with a body at
 * the reference (Eq. 4.7's average) is q; exactly 1 at the reference, 1 with none, the floor at and above melt, the
 * ceiling where no factor reaches q. */
static void test_preheat_scale(void)
{
    struct mpm_material al = {
        .density = 2700.0, .melt_T0 = 933.0, .melt_a = 1.5, .eos_gamma0 = 2.0, .T_initial = 298.0};
    struct mpm_body body[4] = {
        {.temperature = 500.0}, {.temperature = 0.0}, {.temperature = 298.0}, {.temperature = 950.0}};
    struct mpm_config cfg = law(MPM_BONDING_STRAIN);
    cfg.materials = &al, cfg.material_count = 1, cfg.bodies = body, cfg.body_count = 4;
    cfg.bonding_preheat = MPM_PREHEAT_MELT_HEAT, cfg.bonding_T_reference = 298.0, cfg.bonding_preheat_exponent = 0.5;
    double y = mpm_bonding_preheat_scale(&cfg, 0), q = sqrt(433.0 / 635.0);
    CHECK_CLOSE(y, preheat_factor(q), 1e-15, 0.0, "500 K: q / (2 - q), q = sqrt(433/635)");
    CHECK_CLOSE(2.0 * y / (1.0 + y), q, 1e-14, 0.0, "500 K: the mean with a body at the reference is q");
    CHECK(mpm_bonding_preheat_scale(&cfg, 1) == 1.0, "a body at its material's T_initial = the reference: exactly 1");
    CHECK(mpm_bonding_preheat_scale(&cfg, 2) == 1.0, "a body at the reference temperature: exactly 1");
    CHECK(mpm_bonding_preheat_scale(&cfg, 3) == MPM_PREHEAT_SCALE_MIN, "above melt: the floor");
    cfg.bonding_preheat_exponent = 1.0;
    CHECK_CLOSE(mpm_bonding_preheat_scale(&cfg, 0), preheat_factor(433.0 / 635.0), 1e-15, 0.0,
                "exponent 1: q = 433/635");
    cfg.bonding_T_reference = 400.0;
    CHECK_CLOSE(mpm_bonding_preheat_scale(&cfg, 1), preheat_factor((933.0 - 298.0) / (933.0 - 400.0)), 1e-15, 0.0,
                "a body colder than the reference: above 1, q = (933 - 298) / (933 - 400)");
    cfg.bonding_T_reference = 800.0;
    CHECK(mpm_bonding_preheat_scale(&cfg, 1) == MPM_PREHEAT_SCALE_MAX,
          "q = 635/133 beyond 2 (no factor of its own reaches it): the ceiling");
    /* the solver's increment divides by the scaled critical value */
    double deps = increment_for(&cfg, 50.0);
    CHECK_CLOSE(mpm_bonding_increment(&cfg, deps, sigma_vm, dt, 0.5),
                2.0 * mpm_bonding_increment(&cfg, deps, sigma_vm, dt, 1.0), 1e-15, 0.0,
                "half the critical strain: twice the increment");
    cfg.bonding = MPM_BONDING_NONE;
    CHECK(mpm_bonding_preheat_scale(&cfg, 0) == 1.0, "bonding = none: 1 at 500 K (nothing to scale)");
    cfg.bonding = MPM_BONDING_STRAIN, cfg.bonding_preheat = MPM_PREHEAT_NONE;
    CHECK(mpm_bonding_preheat_scale(&cfg, 0) == 1.0, "bonding_preheat = none: 1 at 500 K");
}

int main(void)
{
    RUN(test_preheat_scale);
    RUN(test_energy_law);
    RUN(test_strain_law);
    RUN(test_floor_one);
    return check_finish();
}
