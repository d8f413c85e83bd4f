/* Geometric similarity of the impact stage (mpm_config_scale_lengths, docs/physics.md "Resolution in cells per
 * diameter"): without a length or time scale in the response, an impact whose lengths and times are all doubled is
 * the same solution in x/d and t v/d, on a grid with the same cells per particle.  A slow (elastic) impact of a 10 um
 * Al sphere, and the same set-up scaled by 2 (an exact binary scaling, so every ratio of lengths is the same double),
 * must take the same number of steps and give the same velocities, energies per mass and bonding state at the same
 * scaled times: any length or time the solver hides from the scaling (an absolute tolerance, a time constant in the
 * boundaries, the artificial viscosity's length, an unscaled window) breaks this.  At 700 m/s the same holds for a
 * PTW material without rate dependence; the shipped PTW's rate dependence (strain rates halve at twice the size) is
 * what makes the two sizes differ. */
#include <math.h>
#include <stdlib.h>

#include "check.h"
#include "impact_fixture.h"

#define CASE                                                                                                           \
    "[impact]\ngrid = 2e-6\nspacing = 1e-6\ndiameter = 10e-6\nsubstrate_diameter = 20e-6\nsubstrate_height = "         \
    "8e-6\nt_end = %g\nstop_when_settled = no\nvelocity = %g\nbonding = strain\neps_c = 0.4\neps_rate_c = "            \
    "1e5\n[material.aluminium]\n%s"

/* PTW without its rate dependence: no thermal activation (kappa), constant medium- and high-rate terms (y2, beta) */
#define RATE_FREE "ptw_kappa = 0\nptw_y2 = 0\nptw_beta = 0\n"

struct state {
    int64_t steps, points;
    double t, v_com_z, ke_per_mass, ie_per_mass, pbcp, mean_eps_p;
};

/* Run the case at `velocity` with every length and time times `factor` (material keys `material` added); the
 * particle's state at the end. */
static int run_scaled(double velocity, double t_end, double factor, const char *material, struct state *out)
{
    struct impact_fixture f;
    char ini[512];
    snprintf(ini, sizeof ini, CASE, t_end, velocity, material);
    memset(&f, 0, sizeof f);
    static const struct cfg_key *const registry[] = {run_case_keys, mpm_case_keys, NULL};
    int status = case_fixture_write(f.dir, ini, NULL, NULL, NULL, NULL) == 0 ? SC_OK : SC_EIO;
    if (status == SC_OK)
        status = case_fixture_load(f.dir, registry, &f.c);
    if (status == SC_OK)
        status = mpm_config_load(f.c, &f.cfg);
    if (status == SC_OK) {
        mpm_config_scale_lengths(&f.cfg, factor);
        status = mpm_create(&f.cfg, &f.solver);
    }
    if (status == SC_OK)
        status = impact_fixture_run(&f);
    if (status == SC_OK) {
        struct mpm_counts n = mpm_get_counts(f.solver);
        const struct mpm_diagnostics *d = mpm_compute_diagnostics(f.solver);
        const struct mpm_body_diagnostics *p = &d->body[1];
        *out = (struct state){
            n.step,  n.points,     n.t, p->v_com[2], p->kinetic_energy / p->mass, p->internal_energy / p->mass,
            p->pbcp, p->mean_eps_p};
        printf("  x%g at %g m/s: %lld steps, %lld points, t %.6g ns, v_com_z %.9g m/s, ke/m %.9g J/kg, eps_p %.6g\n",
               factor, velocity, (long long)n.step, (long long)n.points, 1e9 * n.t, p->v_com[2], out->ke_per_mass,
               p->mean_eps_p);
    } else {
        printf("  x%g: %s\n", factor, sc_error_message());
    }
    impact_fixture_close(&f);
    return status;
}

static double relative(double a, double b)
{
    return fabs(a - b) / fmax(fabs(a), fabs(b));
}

static void check_same(const struct state *a, const struct state *b)
{
    CHECK(a->points == b->points, "the same points: %lld and %lld", (long long)a->points, (long long)b->points);
    CHECK(a->steps == b->steps, "the same steps: %lld and %lld", (long long)a->steps, (long long)b->steps);
    CHECK(relative(2.0 * a->t, b->t) < 1e-12, "t scales with the size: %.17g and %.17g", 2.0 * a->t, b->t);
    CHECK(relative(a->v_com_z, b->v_com_z) < 1e-9, "the same v_com_z: %.12g and %.12g m/s", a->v_com_z, b->v_com_z);
    CHECK(relative(a->ke_per_mass, b->ke_per_mass) < 1e-9, "the same kinetic energy per mass: %.12g and %.12g J/kg",
          a->ke_per_mass, b->ke_per_mass);
    CHECK(relative(a->ie_per_mass, b->ie_per_mass) < 1e-9, "the same internal energy per mass: %.12g and %.12g J/kg",
          a->ie_per_mass, b->ie_per_mass);
    CHECK(fabs(a->mean_eps_p - b->mean_eps_p) <= 1e-9 * fabs(a->mean_eps_p), "the same mean eps_p: %.12g and %.12g",
          a->mean_eps_p, b->mean_eps_p);
    CHECK(fabs(a->pbcp - b->pbcp) < 1e-12, "the same PBCP: %.12g and %.12g", a->pbcp, b->pbcp);
}

/* 0.5 m/s: elastic contact and rebound (at 5 m/s the contact's corner points already yield): the same solution at
 * both sizes. */
static void test_elastic_impact_is_scale_free(void)
{
    struct state a, b;
    if (run_scaled(0.5, 12e-9, 1.0, "", &a) != SC_OK || run_scaled(0.5, 12e-9, 2.0, "", &b) != SC_OK) {
        CHECK(0, "both runs complete");
        return;
    }
    CHECK(a.mean_eps_p == 0.0, "elastic: mean eps_p %g", a.mean_eps_p);
    CHECK(fabs(a.v_com_z) > 0.01, "the particle is moving (in contact, rebounding): v_com_z %g m/s", a.v_com_z);
    check_same(&a, &b);
}

/* 700 m/s, 20 ns, strain bonding on: plastic flow, heating, jetting, bonding.  With PTW's rate dependence removed the
 * two sizes are the same solution; with it (the shipped PTW) the larger particle, whose strain rates are half the
 * smaller one's, has the lower flow stress and deforms more: the size effect that remains at equal cells per
 * diameter. */
static void test_plastic_impact_differs_by_the_rate_only(void)
{
    struct state a, b, rate_a, rate_b;
    if (run_scaled(700.0, 20e-9, 1.0, RATE_FREE, &a) != SC_OK ||
        run_scaled(700.0, 20e-9, 2.0, RATE_FREE, &b) != SC_OK || run_scaled(700.0, 20e-9, 1.0, "", &rate_a) != SC_OK ||
        run_scaled(700.0, 20e-9, 2.0, "", &rate_b) != SC_OK) {
        CHECK(0, "the four runs complete");
        return;
    }
    CHECK(a.mean_eps_p > 0.1, "plastic: mean eps_p %g", a.mean_eps_p);
    CHECK(a.pbcp > 0.0, "bonding: PBCP %g", a.pbcp);
    check_same(&a, &b);
    CHECK(rate_b.mean_eps_p > rate_a.mean_eps_p,
          "with the rate dependence the larger particle deforms more: mean eps_p %.6g against %.6g", rate_b.mean_eps_p,
          rate_a.mean_eps_p);
}

int main(void)
{
    if (getenv("SPRAYCOAT_SANITIZED")) {
        printf("  skipped in the sanitized build (six impacts; physics check only)\n");
        return 0;
    }
    RUN(test_elastic_impact_is_scale_free);
    RUN(test_plastic_impact_differs_by_the_rate_only);
    return check_finish();
}
