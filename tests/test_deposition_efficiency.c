/* The deposition efficiency by mass (dem/efficiency.c, spray.h5 /deposition_efficiency) against counts made
 * independently from the run's own spray.h5 datasets.
 *
 * With a v_crit of a single step at v* (rule critical_velocity, and a table of two diameters with the same v*), a
 * particle sticks exactly when its first impact arrives at a normal speed >= v*: no gas (jet none), so nothing
 * slows a rebounder into a second sticking impact, and a sparse spray (a 30-degree cone over a 2 cm target),
 * whose first impacts all meet the target itself (checked), where the normal is the spray axis.  So the DE
 * (deposited mass / sprayed mass) of a monodisperse powder must equal the number of first impacts in /impacts
 * with v_in,z >= v* over the number injected (/stats injected); and of a Weibull powder, the mass of those impacts
 * over the mass of /particles and /escapes.  The split by size and by angle must add up to the headline, and
 * each angle class must hold the first impacts of its angles, counted from /impacts. */
#include <hdf5.h>
#include <math.h>

#include "check.h"
#include "core/h5io.h"
#include "spray_fixture.h"

#define V_STAR 500.0

static const char *const case_head =
    "[run]\nseed = 3\n"
    "[spray]\ndt = 1e-7\nt_end = 1e-4\nfeed_count = 10\nfeed_every = 2\nmax_injected = 300\n"
    "nozzle_radius = 0.002\nrelease_speed_min = 300\nrelease_speed_max = 700\nrelease_cone = 30\n"
    "domain_radius = 0.05\nhandoff_height = 0.001\nmetrics_every = 100\n"
    "[target]\nstandoff = 0.01\ndeposit_radius = 0.005\n"
    "[jet]\nmodel = none\n";

/* A column of a group of spray.h5 (NULL when missing); n its length. */
static double *read_column(hid_t file, const char *group, const char *name, size_t *n)
{
    hid_t g = H5Gopen2(file, group, H5P_DEFAULT);
    double *data = NULL;
    if (g >= 0 && h5_dataset_size(g, name, n) == SC_OK) {
        data = malloc((*n ? *n : 1) * sizeof *data);
        if (h5_read_doubles(g, name, data, *n) != SC_OK)
            free(data), data = NULL;
    }
    if (g >= 0)
        H5Gclose(g);
    return data;
}

static double read_scalar(hid_t file, const char *name)
{
    size_t n = 0;
    double *value = read_column(file, "deposition_efficiency", name, &n);
    double x = value && n == 1 ? value[0] : NAN;
    free(value);
    return x;
}

static double sum(const double *x, size_t n)
{
    double total = 0;
    for (size_t i = 0; i < n; i++)
        total += x[i];
    return total;
}

/* Run the case to its end and write its spray.h5 into the fixture's folder; returns the open file or -1. */
static hid_t run_case(struct fixture *f, const char *powder, const char *deposition)
{
    char ini[4096];
    snprintf(ini, sizeof ini, "%s%s%s", case_head, powder, deposition);
    if (fixture_open(f, ini, NULL) != SC_OK)
        return -1;
    if (fixture_steps(f, dem_total_steps(f->solver)) != SC_OK)
        return -1;
    char path[256];
    snprintf(path, sizeof path, "%s/spray.h5", f->dir);
    hid_t file = H5Fcreate(path, H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    if (file < 0 || dem_write_output(f->solver, file) != SC_OK) {
        printf("  writing spray.h5: %s\n", sc_error_message());
        return -1;
    }
    return file;
}

struct first_impacts {
    size_t count, above, on_deposits;
    double mass, mass_above;
};

/* The first contacts (contact_index 0) of /impacts: how many, how many at v_z >= v*, their masses. */
static struct first_impacts count_first_impacts(hid_t file)
{
    struct first_impacts out = {0};
    size_t n = 0, n_index = 0, n_partner = 0, n_v = 0, n_m = 0;
    int64_t *index_i = NULL, *partner_i = NULL;
    hid_t g = H5Gopen2(file, "impacts", H5P_DEFAULT);
    h5_dataset_size(g, "contact_index", &n_index);
    h5_dataset_size(g, "partner", &n_partner);
    index_i = malloc((n_index + 1) * sizeof *index_i);
    partner_i = malloc((n_partner + 1) * sizeof *partner_i);
    h5_read_int64s(g, "contact_index", index_i, n_index);
    h5_read_int64s(g, "partner", partner_i, n_partner);
    H5Gclose(g);
    double *v = read_column(file, "impacts", "v_in", &n_v);
    double *m = read_column(file, "impacts", "m", &n_m);
    n = n_m;
    CHECK(n_v == 3 * n && n_index == n && n_partner == n, "/impacts columns of %zu rows", n);
    for (size_t r = 0; r < n && n_v == 3 * n; r++) {
        if (index_i[r] != 0)
            continue;
        out.count++;
        out.mass += m[r];
        out.on_deposits += partner_i[r] != -1;
        if (v[3 * r + 2] >= V_STAR)
            out.above++, out.mass_above += m[r];
    }
    free(index_i), free(partner_i), free(v), free(m);
    return out;
}

static char table_path[64];

static void check_monodisperse(const char *deposition, const char *label)
{
    struct fixture f;
    hid_t file = run_case(&f, "[powder]\ndistribution = mono\nmedian_diameter = 20e-6\ndensity = 2700\n", deposition);
    CHECK(file >= 0, "the run and its spray.h5");
    if (file >= 0) {
        int64_t injected = 0;
        hid_t stats = H5Gopen2(file, "stats", H5P_DEFAULT);
        h5_attr_read_int64(stats, "injected", &injected);
        H5Gclose(stats);
        struct first_impacts first = count_first_impacts(file);
        CHECK(first.on_deposits == 0, "%zu first impacts met a deposit: the spray is not sparse enough",
              first.on_deposits);
        CHECK(first.above > 20 && first.above + 20 < (size_t)injected,
              "%zu of %lld arrive above v*: the test needs both kinds", first.above, (long long)injected);
        double expected = (double)first.above / (double)injected;
        printf("  %s: %zu of %lld particles arrive at v_z >= %g m/s: DE %.6f\n", label, first.above,
               (long long)injected, V_STAR, read_scalar(file, "de"));
        CHECK_CLOSE(read_scalar(file, "de"), expected, 1e-12, 0, "DE against the count of arrivals above v*");
        H5Fclose(file);
    }
    fixture_close(&f);
}

static void test_de_is_fraction_above_step(void)
{
    check_monodisperse("[deposition]\nrule = critical_velocity\ncritical_velocity = 500\n", "step");
}

static void test_de_is_fraction_above_table_step(void)
{
    /* v_crit(d) of two diameters with the same v*, as `spraycoat vcrit` writes it (written by main) */
    char deposition[256];
    snprintf(deposition, sizeof deposition, "[deposition]\nrule = table\ntable = %s\n", table_path);
    check_monodisperse(deposition, "table");
}

/* Weibull powder: the DE against the masses of /impacts, /particles and /escapes; the classes add up. */
static void test_weibull_masses_and_classes(void)
{
    struct fixture f;
    hid_t file = run_case(&f,
                          "[powder]\ndistribution = weibull\nmedian_diameter = 20e-6\nshape = 3.5\nd_min = 10e-6\n"
                          "d_max = 30e-6\ndensity = 2700\n",
                          "[deposition]\nrule = critical_velocity\ncritical_velocity = 500\nsize_classes = 5\n"
                          "angle_class_width = 10\n");
    CHECK(file >= 0, "the run and its spray.h5");
    if (file < 0) {
        fixture_close(&f);
        return;
    }
    size_t n_particles = 0, n_escapes = 0;
    double *m_held = read_column(file, "particles", "m", &n_particles);
    double *m_escaped = read_column(file, "escapes", "m", &n_escapes);
    double sprayed = sum(m_held, n_particles) + sum(m_escaped, n_escapes);
    struct first_impacts first = count_first_impacts(file);
    CHECK(first.on_deposits == 0, "%zu first impacts met a deposit", first.on_deposits);
    CHECK(n_escapes > 0, "some particles escaped (%zu): the sprayed mass must count them", n_escapes);
    double de = read_scalar(file, "de");
    printf("  Weibull: deposited %.6g of %.6g kg sprayed (count %zu of %zu held + %zu escaped): DE %.6f\n",
           first.mass_above, sprayed, first.above, n_particles, n_escapes, de);
    CHECK_CLOSE(read_scalar(file, "sprayed_mass"), sprayed, 1e-12, 0, "sprayed mass");
    CHECK_CLOSE(read_scalar(file, "deposited_mass"), first.mass_above, 1e-12, 0, "deposited mass");
    CHECK_CLOSE(de, first.mass_above / sprayed, 1e-12, 0, "DE by mass");

    size_t n = 0;
    double *size_sprayed = read_column(file, "deposition_efficiency/by_size", "sprayed_mass", &n);
    double *size_deposited = read_column(file, "deposition_efficiency/by_size", "deposited_mass", &n);
    CHECK(n == 5, "5 size classes, got %zu", n);
    CHECK_CLOSE(sum(size_sprayed, n), sprayed, 1e-12, 0, "size classes: sprayed mass adds up");
    CHECK_CLOSE(sum(size_deposited, n), first.mass_above, 1e-12, 0, "size classes: deposited mass adds up");

    size_t na = 0;
    double *angle_sprayed = read_column(file, "deposition_efficiency/by_angle", "sprayed_mass", &na);
    double *angle_deposited = read_column(file, "deposition_efficiency/by_angle", "deposited_mass", &na);
    double *angle_lo = read_column(file, "deposition_efficiency/by_angle", "lo", &na);
    double *angle_hi = read_column(file, "deposition_efficiency/by_angle", "hi", &na);
    CHECK(na == 9, "9 angle classes of 10 degrees, got %zu", na);
    CHECK_CLOSE(sum(angle_sprayed, na) + read_scalar(file, "unimpacted_mass"), sprayed, 1e-12, 0,
                "angle classes and the unimpacted: sprayed mass adds up");
    CHECK_CLOSE(sum(angle_deposited, na), first.mass_above, 1e-12, 0, "angle classes: deposited mass adds up");
    /* each angle class against the first impacts of /impacts at its angles */
    size_t n_v = 0, n_m = 0, n_index = 0;
    double *v = read_column(file, "impacts", "v_in", &n_v);
    double *m = read_column(file, "impacts", "m", &n_m);
    hid_t g = H5Gopen2(file, "impacts", H5P_DEFAULT);
    h5_dataset_size(g, "contact_index", &n_index);
    int64_t *index = malloc((n_index + 1) * sizeof *index);
    h5_read_int64s(g, "contact_index", index, n_index);
    H5Gclose(g);
    int classes_seen = 0;
    for (size_t k = 0; k < na; k++) {
        double in_class = 0, in_class_above = 0;
        for (size_t r = 0; r < n_m; r++) {
            double speed = sqrt(v[3 * r] * v[3 * r] + v[3 * r + 1] * v[3 * r + 1] + v[3 * r + 2] * v[3 * r + 2]);
            double angle = acos(v[3 * r + 2] / speed) * 180.0 / M_PI;
            if (index[r] != 0 || angle < angle_lo[k] || angle >= angle_hi[k])
                continue;
            in_class += m[r];
            if (v[3 * r + 2] >= V_STAR)
                in_class_above += m[r];
        }
        classes_seen += in_class > 0;
        char what[96];
        snprintf(what, sizeof what, "angle class %g-%g degrees: sprayed mass", angle_lo[k], angle_hi[k]);
        CHECK_CLOSE(angle_sprayed[k], in_class, 1e-12, 0, what);
        snprintf(what, sizeof what, "angle class %g-%g degrees: deposited mass", angle_lo[k], angle_hi[k]);
        CHECK_CLOSE(angle_deposited[k], in_class_above, 1e-12, 0, what);
    }
    CHECK(classes_seen >= 3, "first impacts in %d angle classes: the test needs several", classes_seen);
    free(m_held), free(m_escaped), free(size_sprayed), free(size_deposited), free(angle_sprayed);
    free(angle_deposited), free(angle_lo), free(angle_hi), free(v), free(m), free(index);
    H5Fclose(file);
    fixture_close(&f);
}

/* A particle still far from the target after one step: no impact, so no mean impact speed (NaN, not 0 m/s: the
 * sweep's map printed "0 m/s" in such a cell) */
static void test_no_impact_no_speed(void)
{
    struct fixture f;
    if (fixture_open(&f, "[spray]\ndt = 1e-8\nt_end = 1e-6\n[jet]\nmodel = none\n", "0,0,0.1,0,0,600,0,0,0,3e-5\n") !=
        SC_OK) {
        CHECK(0, "set-up");
        return;
    }
    fixture_steps(&f, 1);
    struct dem_deposition_efficiency de;
    CHECK(dem_deposition_efficiency(f.solver, &de) == SC_OK, "DE");
    CHECK(isnan(de.mean_impact_speed) && isnan(de.mean_impact_normal_speed), "no impact: mean speeds %g, %g m/s",
          de.mean_impact_speed, de.mean_impact_normal_speed);
    dem_deposition_efficiency_free(&de);
    fixture_close(&f);
}

int main(void)
{
    h5_quiet();
    snprintf(table_path, sizeof table_path, "/tmp/spraycoat-test-vstar-%ld.csv", (long)getpid());
    FILE *table = fopen(table_path, "w");
    if (!table)
        return 1;
    fputs("diameter,v_crit\n1e-6,500\n1e-4,500\n", table);
    fclose(table);
    RUN(test_de_is_fraction_above_step);
    RUN(test_de_is_fraction_above_table_step);
    RUN(test_weibull_masses_and_classes);
    RUN(test_no_impact_no_speed);
    remove(table_path);
    return check_finish();
}
