/* The spray's `table` deposition rule over diameter and temperature (issue 26 item 3, docs/physics.md
 * "v_crit(d, T)"): dem_vcrit_lookup against values worked by hand (bilinear inside the grid, clamped at its ends),
 * the 1-D table v_crit(d) unchanged, 2-D tables read from CSV (rows in any order) and from HDF5, an incomplete grid
 * refused, and the rule's use of the normal velocity component for oblique impacts through the solver. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "spray_fixture.h"
#include "core/h5io.h"

/* d = 20, 40 um; T = 300, 500, 700 K; v_crit in m/s, the temperatures of one diameter side by side. */
static double grid_d[2] = {20e-6, 40e-6}, grid_t[3] = {300.0, 500.0, 700.0};
static double grid_v[6] = {700.0, 650.0, 560.0, 500.0, 470.0, 420.0};

static struct dem_config grid_config(void)
{
    struct dem_config cfg = {0};
    cfg.table_count = 2;
    cfg.table_diameter = grid_d;
    cfg.table_temperature_count = 3;
    cfg.table_temperature = grid_t;
    cfg.table_velocity = grid_v;
    return cfg;
}

/* Inside: (30 um, 400 K): 675 at 20 um, 485 at 40 um, 580 half way; (25 um, 600 K): 605 and 445, a quarter of
 * the way: 565.  The grid's nodes exactly. */
static void test_bilinear_inside(void)
{
    struct dem_config cfg = grid_config();
    CHECK_CLOSE(dem_vcrit_lookup(&cfg, 30e-6, 400.0), 580.0, 1e-12, 0, "v_crit(30 um, 400 K)");
    CHECK_CLOSE(dem_vcrit_lookup(&cfg, 25e-6, 600.0), 565.0, 1e-12, 0, "v_crit(25 um, 600 K)");
    for (int i = 0; i < 2; i++)
        for (int j = 0; j < 3; j++)
            CHECK_CLOSE(dem_vcrit_lookup(&cfg, grid_d[i], grid_t[j]), grid_v[3 * i + j], 0, 0, "a node of the grid");
}

/* Outside the grid the value of its nearest edge: no extrapolation. */
static void test_bilinear_clamped(void)
{
    struct dem_config cfg = grid_config();
    CHECK_CLOSE(dem_vcrit_lookup(&cfg, 10e-6, 200.0), 700.0, 0, 0, "below both ends");
    CHECK_CLOSE(dem_vcrit_lookup(&cfg, 50e-6, 900.0), 420.0, 0, 0, "above both ends");
    CHECK_CLOSE(dem_vcrit_lookup(&cfg, 10e-6, 600.0), 605.0, 1e-12, 0, "below the diameters, inside in T");
    CHECK_CLOSE(dem_vcrit_lookup(&cfg, 30e-6, 900.0), 490.0, 1e-12, 0, "inside in d, above the temperatures");
    CHECK_CLOSE(dem_vcrit_lookup(&cfg, 50e-6, 400.0), 485.0, 1e-12, 0, "above the diameters, inside in T");
}

/* A 1-D table v_crit(d): linear in d, the temperature ignored; one temperature column of a 2-D table acts alike. */
static void test_one_dimensional(void)
{
    double d[2] = {20e-6, 40e-6}, v[2] = {700.0, 500.0}, t[1] = {400.0};
    struct dem_config cfg = {.table_count = 2, .table_diameter = d, .table_velocity = v};
    CHECK_CLOSE(dem_vcrit_lookup(&cfg, 30e-6, 1000.0), 600.0, 1e-12, 0, "1-D v_crit(30 um)");
    CHECK_CLOSE(dem_vcrit_lookup(&cfg, 5e-6, 1000.0), 700.0, 0, 0, "1-D clamped below");
    CHECK_CLOSE(dem_vcrit_lookup(&cfg, 90e-6, 1.0), 500.0, 0, 0, "1-D clamped above");
    cfg.table_temperature_count = 1;
    cfg.table_temperature = t;
    CHECK_CLOSE(dem_vcrit_lookup(&cfg, 35e-6, 200.0), 550.0, 1e-12, 0, "one temperature: v_crit(35 um)");
}

/* Load a case whose [deposition] table is `name` in the fixture's folder, written by `write`; the status. */
static int load_table(const char *name, const char *contents, int as_h5, struct dem_config *cfg)
{
    char dir[64], path[256], ini[512];
    snprintf(ini, sizeof ini, "[jet]\nmodel = none\n[deposition]\nrule = table\ntable = %s\n", name);
    if (case_fixture_write(dir, ini, "unused.csv", "", NULL, "") != 0)
        return -1;
    snprintf(path, sizeof path, "%s/%s", dir, name);
    int status = SC_OK;
    if (as_h5) {
        /* the rows of the CSV grid as vcrit.h5 holds them: columns diameter, temperature, v_crit */
        double dd[6], tt[6], vv[6];
        for (int k = 0; k < 6; k++)
            dd[k] = grid_d[k / 3], tt[k] = grid_t[k % 3], vv[k] = grid_v[k];
        hsize_t dims[1] = {6};
        struct h5_out out;
        status = h5_create_atomic(path, &out);
        if (status == SC_OK)
            status = h5_write_doubles(out.file, "diameter", 1, dims, dd, "m", 0);
        if (status == SC_OK)
            status = h5_write_doubles(out.file, "temperature", 1, dims, tt, "K", 0);
        if (status == SC_OK)
            status = h5_write_doubles(out.file, "v_crit", 1, dims, vv, "m/s", 0);
        if (status == SC_OK)
            status = h5_commit(&out);
    } else {
        FILE *file = fopen(path, "w");
        if (!file)
            return -1;
        fputs(contents, file);
        fclose(file);
    }
    struct case_file *c = NULL;
    if (status == SC_OK)
        status = case_fixture_load(dir, spraycoat_registry, &c);
    if (status == SC_OK)
        status = dem_config_load(c, cfg);
    case_free(c);
    case_fixture_remove(dir);
    return status;
}

static void check_loaded_grid(const struct dem_config *cfg, const char *what)
{
    CHECK(cfg->table_count == 2 && cfg->table_temperature_count == 3, "%s: a 2 x 3 grid (%zu x %zu)", what,
          cfg->table_count, cfg->table_temperature_count);
    if (cfg->table_count != 2 || cfg->table_temperature_count != 3)
        return;
    CHECK_CLOSE(dem_vcrit_lookup(cfg, 30e-6, 400.0), 580.0, 1e-12, 0, what);
    CHECK_CLOSE(dem_vcrit_lookup(cfg, 25e-6, 600.0), 565.0, 1e-12, 0, what);
}

/* The CSV rows in any order, with vcrit.csv's further columns; the HDF5 rows as vcrit.h5 writes them. */
static void test_table_files(void)
{
    const char *csv = "diameter,temperature,v_crit,pbcp,runs\n"
                      "4e-5,700,420,0.1,5\n2e-5,500,650,0.1,5\n4e-5,300,500,0.1,5\n"
                      "# a comment line\n2e-5,300,700,0.1,5\n2e-5,700,560,0.1,5\n4e-5,500,470,0.1,5\n";
    struct dem_config cfg;
    CHECK(load_table("vcrit.csv", csv, 0, &cfg) == SC_OK, "2-D CSV loads: %s", sc_error_message());
    check_loaded_grid(&cfg, "2-D CSV");
    dem_config_free(&cfg);
    CHECK(load_table("vcrit.h5", NULL, 1, &cfg) == SC_OK, "2-D HDF5 loads: %s", sc_error_message());
    check_loaded_grid(&cfg, "2-D HDF5");
    dem_config_free(&cfg);
    CHECK(load_table("old.csv", "diameter,v_crit\n2e-5,700\n4e-5,500\n", 0, &cfg) == SC_OK, "1-D CSV loads");
    CHECK(cfg.table_temperature_count == 0, "1-D CSV: no temperatures");
    CHECK_CLOSE(dem_vcrit_lookup(&cfg, 30e-6, 293.15), 600.0, 1e-12, 0, "1-D CSV v_crit(30 um)");
    dem_config_free(&cfg);
}

/* A pair missing (vcrit leaves out one it could not bracket) or given twice: refused, naming the key. */
static void test_incomplete_grid(void)
{
    struct dem_config cfg;
    const char *missing = "diameter,temperature,v_crit\n2e-5,300,700\n2e-5,500,650\n4e-5,300,500\n";
    int status = load_table("vcrit.csv", missing, 0, &cfg);
    CHECK(status == SC_EINPUT, "a missing pair refused (status %d)", status);
    CHECK(strstr(sc_error_message(), "table") && strstr(sc_error_message(), "grid"), "message: %s", sc_error_message());
    const char *twice = "diameter,temperature,v_crit\n2e-5,300,700\n2e-5,300,650\n4e-5,300,500\n4e-5,500,500\n";
    status = load_table("vcrit.csv", twice, 0, &cfg);
    CHECK(status == SC_EINPUT, "a pair given twice refused (status %d)", status);
}

/* One particle of 30 um at `speed` m/s, `angle_deg` from the target's normal, against the table of `table_csv`,
 * with the case lines `extra`; the outcome of its first impact (-1: none) and its normal speed there. */
static int64_t last_table_impacts = -1, last_table_outside = -1; /* the last particle_outcome's DE counts */

static int particle_outcome(const char *table_csv, const char *extra, double speed, double angle_deg, double *vn)
{
    last_table_impacts = last_table_outside = -1;
    char dir[64], path[256], ini[640], rows[160];
    if (case_fixture_write(dir, "", "unused.csv", "", NULL, "") != 0)
        return -1;
    snprintf(path, sizeof path, "%s/table.csv", dir);
    FILE *file = fopen(path, "w");
    if (!file)
        return -1;
    fputs(table_csv, file);
    fclose(file);
    snprintf(ini, sizeof ini,
             "[spray]\ndt = 1e-8\nt_end = 1e-6\n[jet]\nmodel = none\n[deposition]\nrule = table\ntable = %s\n%s", path,
             extra);
    double a = angle_deg * M_PI / 180.0;
    snprintf(rows, sizeof rows, "0,0,0.299983,%.17g,0,%.17g,0,0,0,3e-5\n", speed * sin(a), speed * cos(a));
    struct fixture f;
    int outcome = -1;
    if (fixture_open(&f, ini, rows) != SC_OK)
        return -1;
    fixture_steps(&f, 5);
    size_t n;
    const struct dem_impact *hit = dem_impacts(f.solver, &n);
    if (n) {
        outcome = (int)hit->outcome;
        *vn = hit->v_in[2];
    }
    struct dem_deposition_efficiency de;
    if (dem_deposition_efficiency(f.solver, &de) == SC_OK) {
        last_table_impacts = de.table_impacts, last_table_outside = de.table_impacts_outside;
        dem_deposition_efficiency_free(&de);
    }
    fixture_close(&f);
    case_fixture_remove(dir);
    return outcome;
}

static int oblique_outcome(const char *table_csv, double speed, double angle_deg, double *vn)
{
    return particle_outcome(table_csv, "", speed, angle_deg, vn);
}

/* v_crit 600 m/s at every diameter: 800 m/s at 60 degrees (normal 400 m/s) rebounds, though faster than v_crit;
 * 700 m/s at 30 degrees (normal 606 m/s) sticks; 590 m/s straight down rebounds. */
static void test_oblique_normal_component(void)
{
    const char *table = "diameter,v_crit\n1e-5,600\n1e-4,600\n";
    double vn = NAN;
    int outcome = oblique_outcome(table, 800.0, 60.0, &vn);
    CHECK(outcome == DEM_REBOUND, "800 m/s at 60 deg (normal %g m/s): outcome %d, rebound expected", vn, outcome);
    CHECK_CLOSE(vn, 400.0, 1e-9, 0, "normal component at the wall");
    outcome = oblique_outcome(table, 700.0, 30.0, &vn);
    CHECK(outcome == DEM_STUCK, "700 m/s at 30 deg (normal %g m/s): outcome %d, stuck expected", vn, outcome);
    outcome = oblique_outcome(table, 590.0, 0.0, &vn);
    CHECK(outcome == DEM_REBOUND, "590 m/s normal: outcome %d, rebound expected", outcome);
}

/* A 2-D table through the solver: v_crit(30 um) is 500 m/s at 200 K and 700 m/s at 400 K, so 593.15 m/s at the
 * default powder temperature 293.15 K (590 m/s rebounds, 597 m/s sticks) and 650 m/s at 350 K. */
static void test_solver_two_dimensional(void)
{
    const char *table = "diameter,temperature,v_crit\n1e-5,200,500\n1e-5,400,700\n1e-4,200,500\n1e-4,400,700\n";
    double vn;
    CHECK(oblique_outcome(table, 590.0, 0.0, &vn) == DEM_REBOUND, "590 m/s below v_crit(293.15 K) = 593.15 m/s");
    CHECK(oblique_outcome(table, 597.0, 0.0, &vn) == DEM_STUCK, "597 m/s above v_crit(293.15 K) = 593.15 m/s");
    /* the particle's own temperature, not the default: a powder at 350 K has v_crit 650 m/s */
    const char *hot = "[powder]\ntemperature = 350\n";
    CHECK(particle_outcome(table, hot, 640.0, 0.0, &vn) == DEM_REBOUND, "350 K: 640 m/s below v_crit = 650 m/s");
    CHECK(particle_outcome(table, hot, 660.0, 0.0, &vn) == DEM_STUCK, "350 K: 660 m/s above v_crit = 650 m/s");
}

/* Impacts beyond the table's grid are judged at its edge, and counted (/deposition_efficiency table_impacts_outside,
 * a warning): the 30 um particle against tables over 10-20 um and over 30-40 um at 300-400 K (its 293.15 K below
 * them), and one inside both. */
static void test_outside_counted(void)
{
    double vn;
    const char *tables[3] = {"diameter,v_crit\n1e-5,600\n2e-5,600\n",
                             "diameter,temperature,v_crit\n3e-5,300,600\n3e-5,400,600\n4e-5,300,600\n4e-5,400,600\n",
                             "diameter,v_crit\n1e-5,600\n1e-4,600\n"};
    const int64_t outside[3] = {1, 1, 0};
    for (int k = 0; k < 3; k++) {
        CHECK(particle_outcome(tables[k], "", 700.0, 0.0, &vn) == DEM_STUCK, "table %d: 700 m/s sticks", k);
        CHECK(last_table_impacts == 1 && last_table_outside == outside[k],
              "table %d: %lld impacts judged, %lld outside; 1 and %lld expected", k, (long long)last_table_impacts,
              (long long)last_table_outside, (long long)outside[k]);
    }
}

int main(void)
{
    RUN(test_bilinear_inside);
    RUN(test_bilinear_clamped);
    RUN(test_one_dimensional);
    RUN(test_table_files);
    RUN(test_incomplete_grid);
    RUN(test_oblique_normal_component);
    RUN(test_solver_two_dimensional);
    RUN(test_outside_counted);
    return check_finish();
}
