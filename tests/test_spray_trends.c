/* The trends of Mukherjee & Zohdi Section 5 as regression tests, on small runs of the Table 1 case
 * (cases/mz2015_table1.ini: the same powder, target, jet and adhesion rule, 200 particles in 0.8 ms, dt 10 us,
 * 80 ms): the deposit fraction rises with alpha_ADH and falls with the release speed.  Each trend's sign must hold
 * with a margin larger than the scatter over three seeds (the largest minus the smallest deposit fraction of one
 * setting).  docs/validation.md gives the figures and what the paper shows. */
#include <math.h>

#include "check.h"
#include "spray_fixture.h"

#define SEEDS 3

static double deposit_fraction(double alpha, double release_max, int seed)
{
    char ini[2048];
    snprintf(ini, sizeof ini,
             "[run]\nseed = %d\n"
             "[spray]\ndt = 1e-5\nt_end = 0.08\ninjection = stream\nfeed_count = 50\nfeed_every = 20\n"
             "max_injected = 200\nnozzle_radius = 0.01\nrelease_speed_min = 0\nrelease_speed_max = %g\nphi = 0.5\n"
             "domain_radius = 0.1\nhandoff_height = 0.01\nmetrics_every = 1000\n"
             "[powder]\ndistribution = weibull\nmedian_diameter = 160e-6\nshape = 5\ndensity = 5680\n"
             "shear_modulus = 77e9\nbulk_modulus = 167e9\nyield_stress = 690e6\nsurface_energy = 46e-3\n"
             "friction = 0.5\n"
             "[target]\nstandoff = 0.30\nshear_modulus = 80e9\nbulk_modulus = 160e9\nyield_stress = 690e6\n"
             "surface_energy = 1.1\nfriction = 0.5\ndeposit_radius = 0.005\n"
             "[jet]\nC1 = 30\nC3 = 20\nvirtual_origin = 0.1\ncore_length = 0.02\n"
             "[deposition]\nrule = adhesion\nalpha_adh = %g\n",
             seed, release_max, alpha);
    struct fixture f;
    double fraction = NAN;
    if (fixture_open(&f, ini, NULL) == SC_OK && fixture_steps(&f, dem_total_steps(f.solver)) == SC_OK) {
        struct dem_counts c = dem_get_counts(f.solver);
        fraction = (double)c.deposited / (double)c.injected;
    }
    fixture_close(&f);
    return fraction;
}

struct setting {
    double alpha, release_max;
    double mean, scatter;
};

static void measure(struct setting *s)
{
    double lo = INFINITY, hi = -INFINITY, sum = 0.0;
    for (int seed = 1; seed <= SEEDS; seed++) {
        double fraction = deposit_fraction(s->alpha, s->release_max, seed);
        lo = fmin(lo, fraction), hi = fmax(hi, fraction), sum += fraction;
    }
    s->mean = sum / SEEDS;
    s->scatter = hi - lo;
    printf("  alpha_ADH %g, release speed 0-%g m/s: deposit fraction %.3f (scatter over %d seeds %.3f)\n", s->alpha,
           s->release_max, s->mean, SEEDS, s->scatter);
}

/* a rise from `low` to `high` larger than either setting's scatter */
static void check_rise(const struct setting *low, const struct setting *high, const char *what)
{
    double margin = fmax(low->scatter, high->scatter);
    CHECK(isfinite(low->mean) && isfinite(high->mean) && high->mean - low->mean > margin,
          "%s: deposit fraction %.3f -> %.3f, rise %.3f > scatter %.3f", what, low->mean, high->mean,
          high->mean - low->mean, margin);
}

/* Fig. 5 of the paper: more adhesion, more deposit (alpha_ADH 2000, 5000, 20000 at release speeds 0-25 m/s); and
 * Section 5: faster particles rebound more (release speeds 0, 0-25, 0-50 m/s at alpha_ADH = 5000). */
static void test_trends(void)
{
    struct setting weak = {2000, 25, 0, 0}, paper = {5000, 25, 0, 0}, strong = {20000, 25, 0, 0};
    struct setting still = {5000, 0, 0, 0}, fast = {5000, 50, 0, 0};
    struct setting *all[] = {&weak, &paper, &strong, &still, &fast};
    for (int k = 0; k < 5; k++)
        measure(all[k]);
    check_rise(&weak, &paper, "alpha_ADH 2000 -> 5000");
    check_rise(&paper, &strong, "alpha_ADH 5000 -> 20000");
    check_rise(&paper, &still, "release 0-25 -> 0 m/s");
    check_rise(&fast, &paper, "release 0-50 -> 0-25 m/s");
}

int main(void)
{
    RUN(test_trends);
    return check_finish();
}
