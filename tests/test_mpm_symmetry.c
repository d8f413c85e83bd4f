/* [impact] symmetry (docs/physics.md "Mirror symmetry"): a normal impact modelled as a half or a quarter gives the
 * whole set-up's diagnostics, and the contact's decisions do not hang on rounding (docs/physics.md "Contact"): the
 * same impact on a grid 1e-8 larger is the same impact.  Each run is a 14 um aluminium particle at 810 m/s, 7 cells
 * across, to 3 ns (the contact's first 250 steps, where its decisions are made afresh at every node). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "check.h"
#include "impact_fixture.h"

#define SET_UP                                                                                                         \
    "[impact]\nstop_when_settled = no\nmaterial = aluminium\nsubstrate_material = aluminium\ndiameter = 14e-6\n"       \
    "velocity = 810\nt_end = 3e-9\nspacing = 0.4667e-6\nbonding = strain\n[material.aluminium]\n"

struct outcome {
    int64_t points, interface_nodes, bonded_nodes;
    double energy_total, kinetic, internal, plastic_work, v_com[3], pbcp, v_rest;
};

/* Run SET_UP with `extra` keys of [impact] (and a grid) and keep the particle's (last body's) diagnostics. */
static int run_case(const char *extra, struct outcome *out)
{
    char ini[1024];
    snprintf(ini, sizeof ini, SET_UP "[impact]\n%s\n", extra);
    struct impact_fixture f;
    int status = impact_fixture_open(&f, ini, NULL);
    if (status == SC_OK)
        status = impact_fixture_run(&f);
    if (status == SC_OK) {
        const struct mpm_diagnostics *d = mpm_compute_diagnostics(f.solver);
        const struct mpm_body_diagnostics *b = &d->body[d->body_count - 1];
        *out = (struct outcome){.points = mpm_get_counts(f.solver).points,
                                .energy_total = d->energy_total,
                                .kinetic = b->kinetic_energy,
                                .internal = b->internal_energy,
                                .plastic_work = b->plastic_work,
                                .v_com = {b->v_com[0], b->v_com[1], b->v_com[2]},
                                .pbcp = b->pbcp,
                                .v_rest = b->v_rest,
                                .interface_nodes = b->interface_nodes,
                                .bonded_nodes = b->bonded_nodes};
        printf("  %-40s %7lld points: v_com (%.3g, %.3g, %.8g) m/s, KE %.8g J, W_p %.8g J, PBCP %.4g, interface "
               "%lld nodes (%lld bonded)\n",
               extra, (long long)out->points, out->v_com[0], out->v_com[1], out->v_com[2], out->kinetic,
               out->plastic_work, out->pbcp, (long long)out->interface_nodes, (long long)out->bonded_nodes);
    }
    impact_fixture_close(&f);
    return status;
}

/* The modelled part's diagnostics against the whole's: energies and v_com_z within rtol of the whole's. */
static void check_same(const struct outcome *part, const struct outcome *whole, double rtol, const char *what)
{
    CHECK_CLOSE(part->energy_total, whole->energy_total, rtol, 0.0, what);
    CHECK_CLOSE(part->kinetic, whole->kinetic, rtol, 0.0, what);
    CHECK_CLOSE(part->internal, whole->internal, rtol, 0.0, what);
    CHECK_CLOSE(part->plastic_work, whole->plastic_work, rtol, 0.0, what);
    CHECK_CLOSE(part->v_com[2], whole->v_com[2], rtol, 0.0, what);
    CHECK_CLOSE(part->pbcp, whole->pbcp, rtol, 1e-12, what);
}

/* A sphere on a rigid wall: the quarter model is the whole one but for the order of its sums (no contact decision
 * between bodies: the mirror planes' nodal condition alone; the plastic work agrees to 3e-8), with a quarter of the
 * points and no motion across the planes. */
static void test_quarter_on_the_wall(void)
{
    struct outcome whole, quarter;
    if (run_case("grid = 2e-6\nsubstrate = rigid", &whole) != SC_OK ||
        run_case("grid = 2e-6\nsubstrate = rigid\nsymmetry = quarter", &quarter) != SC_OK) {
        CHECK(0, "runs");
        return;
    }
    CHECK(4 * quarter.points == whole.points, "a quarter of the points: %lld of %lld", (long long)quarter.points,
          (long long)whole.points);
    check_same(&quarter, &whole, 1e-6, "quarter against whole, rigid wall");
    CHECK(quarter.v_com[0] == 0.0 && quarter.v_com[1] == 0.0, "no motion across the planes");
    CHECK(fabs(whole.v_com[0]) < 1e-9 && fabs(whole.v_com[1]) < 1e-9, "the whole impact is symmetric: v_com %g, %g",
          whole.v_com[0], whole.v_com[1]);
}

/* On a deformable substrate (contact between bodies at every node of the interface, the nodes on the planes
 * included): half and quarter agree with the whole to 1e-6, and the whole on a grid larger by 1e-8 to 1e-5 (its
 * plastic work moves by 2.5e-6).  Before the contact's second decision was taken on the forces, the grid's 1e-8
 * moved v_com_z by 0.4 % and the kinetic energy by 2 % at 8 ns, and the quarter model's contact started 0.3 ns late. */
static void test_half_and_quarter_on_a_substrate(void)
{
    struct outcome whole, nudged, half, quarter;
    if (run_case("grid = 2e-6", &whole) != SC_OK || run_case("grid = 2.00000002e-6", &nudged) != SC_OK ||
        run_case("grid = 2e-6\nsymmetry = half", &half) != SC_OK ||
        run_case("grid = 2e-6\nsymmetry = quarter", &quarter) != SC_OK) {
        CHECK(0, "runs");
        return;
    }
    CHECK(whole.v_com[2] > -700.0, "the particle has been slowed: v_com_z %g m/s", whole.v_com[2]);
    check_same(&nudged, &whole, 1e-5, "grid 1e-8 larger against whole");
    check_same(&half, &whole, 1e-6, "half against whole");
    check_same(&quarter, &whole, 1e-6, "quarter against whole");
    /* the whole set-up's interface nodes: a node on a mirror plane stands for itself only (counting it as the
     * part's copies made the quarter's 16 where the whole has 9) */
    CHECK(whole.interface_nodes > 0, "the particle meets the substrate at %lld nodes",
          (long long)whole.interface_nodes);
    CHECK(half.interface_nodes == whole.interface_nodes && quarter.interface_nodes == whole.interface_nodes,
          "interface nodes: half %lld, quarter %lld, whole %lld", (long long)half.interface_nodes,
          (long long)quarter.interface_nodes, (long long)whole.interface_nodes);
    CHECK(half.bonded_nodes == whole.bonded_nodes && quarter.bonded_nodes == whole.bonded_nodes,
          "bonded interface nodes: half %lld, quarter %lld, whole %lld", (long long)half.bonded_nodes,
          (long long)quarter.bonded_nodes, (long long)whole.bonded_nodes);
    CHECK(fabs(whole.v_com[0]) < 1e-9 && fabs(whole.v_com[1]) < 1e-9, "the whole impact is symmetric: v_com %g, %g",
          whole.v_com[0], whole.v_com[1]);
}

/* An oblique impact (30 degrees, along +x) keeps its mirror plane y = 0: the half model gives the whole one's
 * motion along x as well. */
static void test_half_oblique(void)
{
    struct outcome whole, half;
    if (run_case("grid = 2e-6\nangle = 30", &whole) != SC_OK ||
        run_case("grid = 2e-6\nangle = 30\nsymmetry = half", &half) != SC_OK) {
        CHECK(0, "runs");
        return;
    }
    check_same(&half, &whole, 1e-6, "half against whole, oblique");
    CHECK_CLOSE(half.v_com[0], whole.v_com[0], 1e-6, 0.0, "v_com_x, oblique");
    CHECK(whole.v_com[0] > 100.0, "the oblique particle moves along x: %g m/s", whole.v_com[0]);
}

/* With heat conduction the quarter model exchanges heat with its neighbours' mirror images (conduction.c): its
 * impact is the whole one's, the temperature-softened plastic work included, to 1e-6 as without conduction.
 * Without the images the points by the planes lose the heat of their unmodelled neighbours' exchange. */
static void test_quarter_with_conduction(void)
{
    struct outcome whole, quarter;
    if (run_case("grid = 2e-6\nconduction = on", &whole) != SC_OK ||
        run_case("grid = 2e-6\nconduction = on\nsymmetry = quarter", &quarter) != SC_OK) {
        CHECK(0, "runs");
        return;
    }
    check_same(&quarter, &whole, 1e-6, "quarter against whole, conduction on");
}

/* What a mirror plane cannot model is refused, naming the key. */
static void test_refusals(void)
{
    static const char *const cases[] = {
        "grid = 2e-6\nsymmetry = quarter\nangle = 30",
        "grid = 2e-6\nsymmetry = half\nshape_functions = ugimp",
    };
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        char ini[1024];
        snprintf(ini, sizeof ini, SET_UP "[impact]\n%s\n", cases[k]);
        struct impact_fixture f;
        int status = impact_fixture_open(&f, ini, NULL);
        CHECK(status == SC_EINPUT && strstr(sc_error_message(), "symmetry"), "refused naming symmetry: %s (%s)",
              cases[k], sc_error_message());
        impact_fixture_close(&f);
    }
}

int main(void)
{
    RUN(test_quarter_on_the_wall);
    RUN(test_half_and_quarter_on_a_substrate);
    RUN(test_half_oblique);
    RUN(test_quarter_with_conduction);
    RUN(test_refusals);
    return check_finish();
}
