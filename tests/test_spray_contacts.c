/* Particle-level benchmarks through the public spray solver (Chung & Ooi 2011 style): normal and oblique
 * impacts with the target, pair collisions, the Johnson restitution and the deposition threshold. */
#include <math.h>

#include "check.h"
#include "core/h5io.h"
/* A white-box test: includes the module-private header dem/dem_impl.h (only tests may; tests/test_symbols.sh). */
#include "dem/dem_impl.h"
#include "spray_fixture.h"

/* Vacuum, constant restitution, no deposition; the target 0.3 m away. */
#define VACUUM_CASE(e, mu, eps)                                                                                        \
    "[spray]\ndt = 1e-6\nt_end = 1e-3\n[jet]\nmodel = none\n[deposition]\nrule = none\n"                               \
    "[contact]\nrestitution = " e "\nfriction_regularization = " eps "\n[powder]\ndensity = 4000\nfriction = " mu      \
    "\n[target]\nfriction = " mu "\n"

static const struct dem_impact *first_impact(struct fixture *f)
{
    size_t n;
    const struct dem_impact *rows = dem_impacts(f->solver, &n);
    return n ? rows : NULL;
}

/* Chung & Ooi test 3: the rebound speed ratio equals the prescribed e. */
static void test_normal_wall_restitution(void)
{
    const char *values[] = {"0", "0.2", "0.5", "0.8", "1"};
    for (int k = 0; k < 5; k++) {
        char ini[1024];
        snprintf(ini, sizeof ini, VACUUM_CASE("%s", "0.3", "1e-4"), values[k]);
        struct fixture f;
        if (fixture_open(&f, ini, "0,0,0.297499,0,0,3.9,0,0,0,0.005\n") != SC_OK) {
            CHECK(0, "fixture");
            return;
        }
        fixture_steps(&f, 2);
        const struct dem_impact *hit = first_impact(&f);
        CHECK(hit != NULL, "e = %s: no impact recorded", values[k]);
        if (hit) {
            CHECK_CLOSE(hit->v_out[2], -atof(values[k]) * 3.9, 1e-12, 1e-14, "rebound velocity");
            CHECK(hit->partner == -1 && hit->outcome == DEM_REBOUND, "partner/outcome");
            CHECK_CLOSE(hit->x[2], 0.3 - 0.0025, 1e-12, 0, "centre at contact");
        }
        fixture_close(&f);
    }
}

/* Chung & Ooi test 4: Al2O3 sphere, |v| = 3.9 m/s at incidence 5..85 deg, mu = 0.092, e = 0.98, against
 * the rigid-body solution: sliding throughout when v_t > 7/2 mu (1+e) v_n, else ending in rolling. */
static void test_oblique_wall_rigid_body(void)
{
    const double mu = 0.092, e = 0.98, speed = 3.9, radius = 0.0025;
    for (int degrees = 5; degrees <= 85; degrees += 5) {
        double angle = degrees * M_PI / 180.0, vt = speed * sin(angle), vn = speed * cos(angle);
        char ini[1024], rows[256];
        snprintf(ini, sizeof ini, VACUUM_CASE("0.98", "0.092", "1e-12"));
        snprintf(rows, sizeof rows, "0,0,0.297499,%.17g,0,%.17g,0,0,0,0.005\n", vt, vn);
        struct fixture f;
        if (fixture_open(&f, ini, rows) != SC_OK) {
            CHECK(0, "fixture");
            return;
        }
        fixture_steps(&f, 5);
        const struct dem_impact *hit = first_impact(&f);
        CHECK(hit != NULL, "%d deg: no impact", degrees);
        if (!hit) {
            fixture_close(&f);
            continue;
        }
        int sliding = vt > 3.5 * mu * (1 + e) * vn;
        double vt_after = sliding ? vt - mu * (1 + e) * vn : 5.0 / 7.0 * vt;
        double spin_after = sliding ? -2.5 * mu * (1 + e) * vn / radius : -5.0 / 7.0 * vt / radius;
        char what[64];
        snprintf(what, sizeof what, "%d deg tangential velocity (%s)", degrees, sliding ? "sliding" : "rolling");
        CHECK_CLOSE(hit->v_out[0], vt_after, 1e-9, 1e-12, what);
        snprintf(what, sizeof what, "%d deg spin", degrees);
        CHECK_CLOSE(hit->w_out[1], spin_after, 1e-9, 1e-9, what);
        CHECK_CLOSE(hit->v_out[2], -e * vn, 1e-12, 1e-14, "normal rebound");
        /* the contact-point slip never reverses */
        double slip_after = hit->v_out[0] + hit->w_out[1] * radius;
        CHECK(slip_after >= -1e-12 * speed, "%d deg: slip reversed (%g m/s)", degrees, slip_after);
        if (degrees == 50)
            CHECK_CLOSE(hit->v_out[0] / vt, 0.847, 0, 5e-4, "50 deg tangential CoR (docs/references.md)");
        if (degrees == 70)
            CHECK_CLOSE(hit->w_out[1], -243.0, 0, 1.0, "70 deg spin (docs/references.md)");
        fixture_close(&f);
    }
}

static double kinetic_energy(const struct dem_particle_view *p)
{
    double inertia = 0.1 * p->m * p->d * p->d; /* 2/5 m r^2 */
    double v2 = p->v[0] * p->v[0] + p->v[1] * p->v[1] + p->v[2] * p->v[2];
    double w2 = p->w[0] * p->w[0] + p->w[1] * p->w[1] + p->w[2] * p->w[2];
    return 0.5 * p->m * v2 + 0.5 * inertia * w2;
}

/* Two spheres of different size, head-on plus an offset: momentum exactly conserved, energy loss
 * (1 - e^2) of the normal relative kinetic energy for a central collision. */
static void test_pair_momentum_and_energy(void)
{
    struct fixture f;
    const char *rows = "0,0,0.1,0,0,20,0,0,0,0.0002\n"
                       "0,0,0.10016,0,0,-10,0,0,0,0.0001\n";
    if (fixture_open(&f, VACUUM_CASE("0.6", "0.3", "1e-4"), rows) != SC_OK) {
        CHECK(0, "fixture");
        return;
    }
    struct dem_particle_view a0 = dem_particle(f.solver, 0), b0 = dem_particle(f.solver, 1);
    double momentum0 = a0.m * a0.v[2] + b0.m * b0.v[2];
    fixture_steps(&f, 1);
    struct dem_particle_view a1 = dem_particle(f.solver, 0), b1 = dem_particle(f.solver, 1);
    CHECK(dem_get_counts(f.solver).contacts_pair == 1, "one pair contact");
    CHECK_CLOSE(a1.m * a1.v[2] + b1.m * b1.v[2], momentum0, 1e-14, 0, "momentum");
    double reduced = a0.m * b0.m / (a0.m + b0.m), relative = 30.0;
    double loss = kinetic_energy(&a0) + kinetic_energy(&b0) - kinetic_energy(&a1) - kinetic_energy(&b1);
    CHECK_CLOSE(loss, (1 - 0.36) * 0.5 * reduced * relative * relative, 1e-12, 0, "energy loss 1 - e^2");
    CHECK_CLOSE(b1.v[2] - a1.v[2], 0.6 * relative, 1e-12, 0, "relative rebound speed e v");
    fixture_close(&f);
}

/* Oblique pair collision with spins, touching at the start of the step (time of impact 0): linear and
 * angular momentum (about the origin, orbital plus spin) conserved. */
static void test_pair_angular_momentum(void)
{
    struct fixture f;
    /* exactly touching: centre distance = sum of radii */
    double dz = sqrt(0.00016 * 0.00016 - 0.00005 * 0.00005 - 0.00003 * 0.00003);
    char rows[256];
    snprintf(rows, sizeof rows,
             "0,0,0.1,3,-1,20,100,-300,50,0.0002\n"
             "0.00005,0.00003,%.17g,-2,4,-10,-500,200,80,0.00012\n",
             0.1 + dz);
    if (fixture_open(&f, VACUUM_CASE("0.7", "0.4", "1e-4"), rows) != SC_OK) {
        CHECK(0, "fixture");
        return;
    }
    double before[6] = {0}, after[6] = {0};
    for (int pass = 0; pass < 2; pass++) {
        double *total = pass ? after : before;
        for (int i = 0; i < 2; i++) {
            struct dem_particle_view p = dem_particle(f.solver, (size_t)i);
            double inertia = 0.1 * p.m * p.d * p.d;
            double r[3] = {p.x[0], p.x[1], p.x[2]};
            for (int c = 0; c < 3; c++)
                total[c] += p.m * p.v[c];
            total[3] += p.m * (r[1] * p.v[2] - r[2] * p.v[1]) + inertia * p.w[0];
            total[4] += p.m * (r[2] * p.v[0] - r[0] * p.v[2]) + inertia * p.w[1];
            total[5] += p.m * (r[0] * p.v[1] - r[1] * p.v[0]) + inertia * p.w[2];
        }
        if (!pass) {
            /* resolve the contact without moving the particles, to compare at one instant */
            dem_collide(f.solver);
        }
    }
    CHECK(dem_get_counts(f.solver).contacts_pair == 1, "one pair contact");
    for (int c = 0; c < 3; c++)
        CHECK_CLOSE(after[c], before[c], 1e-13, 1e-22, "linear momentum");
    for (int c = 3; c < 6; c++)
        CHECK_CLOSE(after[c], before[c], 1e-9, 1e-22, "angular momentum");
    fixture_close(&f);
}

/* Chung & Ooi test 7: identical spheres, head-on, with spins.  Opposite spins (w_a = -w_b about the same
 * axis) leave no slip at the contact: no friction, no tangential velocity, spins unchanged.  Spins of the
 * same sense slip: friction gives equal and opposite sideways velocities and slows both spins equally. */
static void test_pair_spins(void)
{
    const char *cases[2][2] = {{"0,0,0.1,0,0,5,0,200,0,0.0002\n", "0,0,0.100205,0,0,-5,0,-200,0,0.0002\n"},
                               {"0,0,0.1,0,0,5,0,200,0,0.0002\n", "0,0,0.100205,0,0,-5,0,200,0,0.0002\n"}};
    for (int same_sense = 0; same_sense < 2; same_sense++) {
        char rows[256];
        snprintf(rows, sizeof rows, "%s%s", cases[same_sense][0], cases[same_sense][1]);
        struct fixture f;
        if (fixture_open(&f, VACUUM_CASE("0.5", "0.4", "1e-4"), rows) != SC_OK) {
            CHECK(0, "fixture");
            return;
        }
        fixture_steps(&f, 1);
        struct dem_particle_view a = dem_particle(f.solver, 0), b = dem_particle(f.solver, 1);
        CHECK(dem_get_counts(f.solver).contacts_pair == 1, "one pair contact");
        if (!same_sense) {
            CHECK(a.v[0] == 0.0 && b.v[0] == 0.0, "tangential velocities %g %g", a.v[0], b.v[0]);
            CHECK(a.w[1] == 200.0 && b.w[1] == -200.0, "spins unchanged (%g, %g)", a.w[1], b.w[1]);
        } else {
            CHECK(fabs(a.v[0]) > 0 && a.v[0] == -b.v[0], "equal and opposite kicks %g %g", a.v[0], b.v[0]);
            CHECK(a.w[1] == b.w[1] && a.w[1] < 200.0, "spins slowed equally (%g, %g)", a.w[1], b.w[1]);
            /* slip 2 w R = 0.04 m/s is below the stick limit here, so the contact ends rolling: no slip left */
            double slip = (b.v[0] - b.w[1] * 1e-4) - (a.v[0] + a.w[1] * 1e-4);
            CHECK(fabs(slip) < 1e-12, "slip after %g", slip);
        }
        fixture_close(&f);
    }
}

/* Johnson's restitution (Eqs. 16-19) through the solver: Table 1 materials, R = 10 um at 10 m/s
 * (contact_johnson.csv: wall, 1e-5, 10 -> e = 0.6532139824). */
static void test_johnson_wall_impact(void)
{
    struct fixture f;
    const char *ini = "[spray]\ndt = 1e-7\nt_end = 1e-5\n[jet]\nmodel = none\n[deposition]\nrule = none\n";
    if (fixture_open(&f, ini, "0,0,0.29999,0,0,10,0,0,0,2e-5\n") != SC_OK) {
        CHECK(0, "fixture");
        return;
    }
    fixture_steps(&f, 2);
    const struct dem_impact *hit = first_impact(&f);
    CHECK(hit != NULL, "impact recorded");
    if (hit)
        CHECK_CLOSE(-hit->v_out[2] / hit->v_in[2], 0.6532139824, 1e-9, 0, "Johnson e");
    fixture_close(&f);
}

/* Eq. 34: a particle just below the capture speed sticks, just above it rebounds
 * (adhesion_threshold.csv: R = 40 um, alpha = 1000 -> 2.524128265 m/s). */
static void test_adhesion_threshold(void)
{
    const double threshold = 2.524128265;
    const double factors[2] = {0.99, 1.01};
    for (int k = 0; k < 2; k++) {
        char ini[512], rows[128];
        snprintf(ini, sizeof ini,
                 "[spray]\ndt = 1e-6\nt_end = 1e-4\n[jet]\nmodel = none\n[deposition]\n"
                 "rule = adhesion\nalpha_adh = 1000\n");
        snprintf(rows, sizeof rows, "0,0,0.29995,0,0,%.12g,0,0,0,8e-5\n", factors[k] * threshold);
        struct fixture f;
        if (fixture_open(&f, ini, rows) != SC_OK) {
            CHECK(0, "fixture");
            return;
        }
        fixture_steps(&f, 20);
        const struct dem_impact *hit = first_impact(&f);
        CHECK(hit != NULL, "impact recorded");
        if (hit) {
            CHECK(hit->outcome == (k == 0 ? DEM_STUCK : DEM_REBOUND), "%.2f v*: outcome %lld", factors[k],
                  (long long)hit->outcome);
            if (k == 0)
                CHECK(hit->v_out[2] == 0.0 && dem_particle(f.solver, 0).state == DEM_DEPOSITED, "frozen");
        }
        fixture_close(&f);
    }
}

/* Eq. 33 through the solver: above the capture speed v* of Eq. 34 a particle rebounds with e (v0 - v*), the
 * adhesion acting through the whole contact (R = 40 um, alpha = 1000: v* = 2.524128265 m/s from
 * adhesion_threshold.csv; e = 0.5; v0 = 10 m/s: 3.737935868 m/s, where e v0 would be 5). */
static void test_adhesion_slows_rebound(void)
{
    const double capture = 2.524128265, e = 0.5, v0 = 10.0;
    struct fixture f;
    const char *ini = "[spray]\ndt = 1e-6\nt_end = 1e-4\n[jet]\nmodel = none\n[contact]\nrestitution = 0.5\n"
                      "[deposition]\nrule = adhesion\nalpha_adh = 1000\n";
    if (fixture_open(&f, ini, "0,0,0.29995,0,0,10,0,0,0,8e-5\n") != SC_OK) {
        CHECK(0, "fixture");
        return;
    }
    fixture_steps(&f, 20);
    const struct dem_impact *hit = first_impact(&f);
    CHECK(hit != NULL, "impact recorded");
    if (hit) {
        CHECK(hit->outcome == DEM_REBOUND, "outcome %lld", (long long)hit->outcome);
        CHECK_CLOSE(-hit->v_out[2], e * (v0 - capture), 1e-8, 0.0, "Eq. 33 rebound e (v0 - v*)");
        CHECK_CLOSE(hit->v_out[0], 0.0, 0.0, 1e-12, "no tangential velocity from a normal impact");
    }
    fixture_close(&f);
}

/* Deposit build-up: the second of two particles on the axis lands on the first, sticks to it and rests
 * touching it. */
static void test_deposit_on_deposit(void)
{
    struct fixture f;
    const char *ini = "[spray]\ndt = 1e-6\nt_end = 1e-3\n[jet]\nmodel = none\n[deposition]\n"
                      "rule = critical_velocity\ncritical_velocity = 1e-6\n";
    const char *rows = "0,0,0.299,0,0,10,0,0,0,1e-4\n"
                       "0.00003,0,0.298,0,0,10,0,0,0,1e-4\n";
    if (fixture_open(&f, ini, rows) != SC_OK) {
        CHECK(0, "fixture");
        return;
    }
    fixture_steps(&f, 300);
    size_t n;
    const struct dem_impact *rows_out = dem_impacts(f.solver, &n);
    CHECK(n == 2, "two impacts (%zu)", n);
    if (n == 2) {
        CHECK(rows_out[0].partner == -1 && rows_out[0].outcome == DEM_STUCK, "first on the target");
        CHECK(rows_out[1].partner == 0 && rows_out[1].outcome == DEM_STUCK, "second on the first");
        struct dem_particle_view a = dem_particle(f.solver, 0), b = dem_particle(f.solver, 1);
        double gap = sqrt((a.x[0] - b.x[0]) * (a.x[0] - b.x[0]) + (a.x[2] - b.x[2]) * (a.x[2] - b.x[2]));
        CHECK_CLOSE(gap, 1e-4, 1e-9, 0, "centres one diameter apart");
    }
    CHECK(dem_get_counts(f.solver).deposited == 2, "both deposited");
    fixture_close(&f);
}

/* rule = table: v_crit(d) interpolated linearly between the rows of a `spraycoat vcrit` table (CSV, or
 * HDF5 with datasets diameter and v_crit).  A 30 um particle with v_crit(30 um) = 600 m/s between rows
 * (20 um, 700 m/s) and (40 um, 500 m/s): 594 m/s rebounds, 606 m/s sticks. */
static int write_vcrit_table(const char *path, int as_h5)
{
    if (as_h5) {
        struct h5_out out;
        const double diameter[2] = {20e-6, 40e-6}, vcrit[2] = {700.0, 500.0};
        hsize_t dims[1] = {2};
        if (h5_create_atomic(path, &out) != SC_OK)
            return -1;
        int status = h5_write_doubles(out.file, "diameter", 1, dims, diameter, "m", 0);
        if (status == SC_OK)
            status = h5_write_doubles(out.file, "v_crit", 1, dims, vcrit, "m/s", 0);
        return status == SC_OK ? h5_commit(&out) : status;
    }
    FILE *csv = fopen(path, "w");
    if (!csv)
        return -1;
    fputs("diameter,v_crit,pbcp,v_rest,runs\n2e-5,700,0.1,10,5\n4e-5,500,0.1,10,5\n", csv);
    return fclose(csv);
}

static void run_table_case(const char *table_name, int as_h5)
{
    const double speeds[2] = {594.0, 606.0};
    char folder[] = "/tmp/spraycoat-table-XXXXXX", path[256], command[300];
    CHECK(mkdtemp(folder) != NULL, "mkdtemp");
    snprintf(path, sizeof path, "%s/%s", folder, table_name);
    CHECK(write_vcrit_table(path, as_h5) == 0, "write %s", path);
    for (int k = 0; k < 2; k++) {
        char ini[512], rows[128];
        snprintf(ini, sizeof ini,
                 "[spray]\ndt = 1e-8\nt_end = 1e-6\n[jet]\nmodel = none\n[deposition]\n"
                 "rule = table\ntable = %s\n",
                 path);
        snprintf(rows, sizeof rows, "0,0,0.299983,0,0,%.17g,0,0,0,3e-5\n", speeds[k]);
        struct fixture f;
        if (fixture_open(&f, ini, rows) != SC_OK) {
            CHECK(0, "fixture");
            break;
        }
        fixture_steps(&f, 5);
        const struct dem_impact *hit = first_impact(&f);
        CHECK(hit != NULL, "%s: impact at %g m/s", table_name, speeds[k]);
        if (hit)
            CHECK(hit->outcome == (k == 0 ? DEM_REBOUND : DEM_STUCK), "%s: %g m/s against v_crit 600 m/s: outcome %lld",
                  table_name, speeds[k], (long long)hit->outcome);
        fixture_close(&f);
    }
    snprintf(command, sizeof command, "rm -rf %s", folder);
    CHECK(system(command) == 0, "cleanup");
}

static void test_vcrit_table_csv(void)
{
    run_table_case("vcrit.csv", 0);
}
static void test_vcrit_table_h5(void)
{
    run_table_case("vcrit.h5", 1);
}

/* The hand-off plane is crossed and the target reached in the same step: the crossing is still recorded,
 * at the plane, with the velocity before the impact. */
static void test_handoff_crossing_before_deposit(void)
{
    struct fixture f;
    const char *ini = "[spray]\ndt = 1e-5\nt_end = 1e-4\nhandoff_height = 2e-5\n[jet]\nmodel = none\n"
                      "[deposition]\nrule = critical_velocity\ncritical_velocity = 1e-6\n";
    if (fixture_open(&f, ini, "0,0,0.29995,0,0,10,0,0,0,2e-5\n") != SC_OK) {
        CHECK(0, "fixture");
        return;
    }
    fixture_steps(&f, 1);
    size_t n;
    const struct dem_handoff *row = dem_handoffs(f.solver, &n);
    CHECK(dem_get_counts(f.solver).deposited == 1, "deposited in the first step");
    CHECK(n == 1, "one hand-off crossing (%zu)", n);
    if (n == 1) {
        CHECK_CLOSE(row->x[2], 0.29998, 1e-12, 0, "crossing at the plane");
        CHECK_CLOSE(row->t, 3e-6, 1e-6, 0, "crossing time");
        CHECK_CLOSE(row->v[2], 10.0, 0, 0, "velocity before the impact");
    }
    fixture_close(&f);
}

/* Still gas (model uniform at 0 m/s), Al powder, constant e 0.5, no deposition: particles that the drag slows by a
 * few per cent per microsecond. */
#define STILL_GAS_CASE(dt)                                                                                             \
    "[spray]\ndt = " dt "\nt_end = 1e-3\n[jet]\nmodel = uniform\nuniform_velocity = 0\n[deposition]\nrule = none\n"    \
    "[contact]\nrestitution = 0.5\n[powder]\ndensity = 2700\n"

/* A 5 um particle at 150 m/s meets an 8 um one at -50 m/s head-on 0.5 us into the second step of 1 us, in still
 * gas (response times 53 and 175 us: the drag takes 1.4 and 0.14 m/s off them in the half step before the
 * contact), then flies on to 3 us: (vz of both at 3 us). */
static int pair_after_contact(const char *ini, int64_t steps, double vz[2])
{
    struct fixture f;
    const char *rows = "0,0,0.1,0,0,150,0,0,0,5e-6\n0,0,0.1003065,0,0,-50,0,0,0,8e-6\n";
    int ok = fixture_open(&f, ini, rows) == SC_OK && fixture_steps(&f, steps) == SC_OK &&
             dem_get_counts(f.solver).contacts_pair == 1;
    if (ok)
        for (int k = 0; k < 2; k++)
            vz[k] = dem_particle(f.solver, (size_t)k).v[2];
    fixture_close(&f);
    return ok;
}

/* A pair contact between flying particles takes each one's velocity on the drag's path at the contact's time
 * (dem/collide.c resolve_pair), not the start of the step's: at 3 us both velocities at dt = 1 us within 0.02 m/s
 * (1e-4 of the 200 m/s closing speed) of a run at dt = 0.01 us: 0.009 and 0.010 m/s off.  With the start of the
 * step's velocities, 0.43 and 0.31 m/s. */
static void test_pair_velocities_at_contact(void)
{
    double coarse[2], fine[2];
    if (!pair_after_contact(STILL_GAS_CASE("1e-6"), 3, coarse) ||
        !pair_after_contact(STILL_GAS_CASE("1e-8"), 300, fine)) {
        CHECK(0, "one pair contact in each run");
        return;
    }
    for (int k = 0; k < 2; k++) {
        double off = fabs(coarse[k] - fine[k]);
        printf("  particle %d at 3 us: vz %.6g m/s at dt = 1 us, %.6g at 0.01 us (%.3g m/s off)\n", k, coarse[k],
               fine[k], off);
        CHECK(off < 0.02, "particle %d within 0.02 m/s of dt = 0.01 us (%g m/s)", k, off);
    }
}

/* A 5 um particle moving at 2 m/s towards a body, the target or a 200 um particle, against gas blowing from it at
 * 200 m/s: its straight path meets the body within the step, but the drag turns it back before (it stops in
 * 0.5 us, 0.5 um on; the contact is found at 4.5 um).  No impulse, no impact: it goes on from the drag's state,
 * counted once (contacts_turned_away; dem/collide.c turned_away), and it neither vanishes nor overlaps the body;
 * its velocity after the step within 1 % of a run at dt = 1 ns (-2.3369 against -2.3367 m/s).  Before, such a
 * contact was dropped uncounted and the particle left on its straight path (into the body) for the rest of the
 * step's contacts; the pair's, resolved with the start of the step's approaching velocities, bounced it off at
 * -3.98 m/s. */
static int turned_away_run(const char *dt, int64_t steps, int pair, struct dem_particle_view *out,
                           struct dem_counts *counts, double *gap)
{
    char ini[512], rows[256];
    snprintf(ini, sizeof ini,
             "[spray]\ndt = %s\nt_end = 1e-3\n[jet]\nmodel = uniform\nuniform_velocity = -200\n"
             "[deposition]\nrule = none\n[powder]\ndensity = 2700\n",
             dt);
    double body = pair ? 0.2 : 0.3, z = body - (pair ? 100e-6 : 0.0) - 2.5e-6 - 5.5e-6;
    snprintf(rows, sizeof rows, "0,0,%.17g,0,0,2,0,0,0,5e-6\n%s", z, pair ? "0,0,0.2,0,0,0,0,0,0,200e-6\n" : "");
    struct fixture f;
    int ok = fixture_open(&f, ini, rows) == SC_OK && fixture_steps(&f, steps) == SC_OK &&
             dem_get_counts(f.solver).in_flight == 1 + pair;
    if (ok) {
        *out = dem_particle(f.solver, 0);
        *counts = dem_get_counts(f.solver);
        double top = pair ? dem_particle(f.solver, 1).x[2] - 100e-6 : 0.3;
        *gap = top - (out->x[2] + 2.5e-6);
        ok = dem_check_accounting(f.solver) == SC_OK;
    }
    fixture_close(&f);
    return ok;
}

static void test_turned_away_by_drag(void)
{
    for (int pair = 0; pair < 2; pair++) {
        struct dem_particle_view coarse, fine;
        struct dem_counts c, c_fine;
        double gap, gap_fine;
        if (!turned_away_run("1e-6", 1, pair, &coarse, &c, &gap) ||
            !turned_away_run("1e-9", 1000, pair, &fine, &c_fine, &gap_fine)) {
            CHECK(0, "%s: runs, both particles kept, accounting", pair ? "pair" : "target");
            continue;
        }
        printf("  %s: after 1 us: vz %.5g m/s, %.4g um clear (dt = 1 ns: %.5g m/s, %.4g um); turned away %lld\n",
               pair ? "pair" : "target", coarse.v[2], 1e6 * gap, fine.v[2], 1e6 * gap_fine,
               (long long)c.contacts_turned_away);
        CHECK(c.contacts_turned_away == 1 && c.contacts_target + c.contacts_pair + c.contacts_deposit == 0,
              "one contact turned away (%lld), none resolved (%lld target, %lld pair)",
              (long long)c.contacts_turned_away, (long long)c.contacts_target, (long long)c.contacts_pair);
        CHECK(c_fine.contacts_target + c_fine.contacts_pair == 0, "dt = 1 ns: no contact either");
        CHECK(coarse.state == DEM_FLYING && gap > 0.0 && c.clamps == 0, "flying and clear of the body (%g m)", gap);
        CHECK(fabs(coarse.v[2] - fine.v[2]) <= 0.01 * fabs(fine.v[2]), "vz within 1 %% of dt = 1 ns (%g against %g)",
              coarse.v[2], fine.v[2]);
    }
}

int main(void)
{
    RUN(test_normal_wall_restitution);
    RUN(test_oblique_wall_rigid_body);
    RUN(test_pair_momentum_and_energy);
    RUN(test_pair_angular_momentum);
    RUN(test_pair_spins);
    RUN(test_johnson_wall_impact);
    RUN(test_adhesion_threshold);
    RUN(test_adhesion_slows_rebound);
    RUN(test_deposit_on_deposit);
    RUN(test_vcrit_table_csv);
    RUN(test_vcrit_table_h5);
    RUN(test_handoff_crossing_before_deposit);
    RUN(test_pair_velocities_at_contact);
    RUN(test_turned_away_by_drag);
    return check_finish();
}
