/* The substrate as a semi-infinite body (thesis Section 3.5.5; issue 22, item 5): a plane P-wave pulse running
 * down a substrate column leaves it through the absorbing (dashpot, Eqs. 3.45-3.46) bottom, and the fixed bottom
 * (substrate_bottom = fixed: no vertical nodal velocity at the bottom face) sends it back up.
 *
 * The column: 4 mm x 4 mm x 40 mm of an elastic material with Poisson ratio 0 (no lateral expansion: the column
 * carries the uniaxial-strain wave at c_L = sqrt((K + 4G/3)/rho) = 1414 m/s, as a half-space under a plane wave
 * does), 1 mm cells, 2 points per cell edge, no bulk viscosity.  Its sides stand for planes of symmetry of that
 * half-space, not for its edges: their dashpots (whose tangential part would damp the wave's v_z along the sides)
 * are switched off here.  The pulse: the top 4 (or 8) mm start moving down at 1 m/s; half of it runs down at once, half
 * after reflecting off the free top, an 8 (16) mm pulse in all.  When it has had time to pass the bottom (t = (h + 2
 * slabs) / c_L + 3 us) and before a reflection could reach the top again, the energy left in the column over the energy
 * put in is the energy reflection coefficient.
 *
 * Bounds: the dashpot of a lattice point (rho c_L dp^2) matches the impedance of the continuum exactly at normal
 * incidence, so what comes back is discretisation error (the dashpot acts on the points of the last half cell,
 * spread over two node planes; the pulse disperses on the grid) and must fall as the pulse gets more cells:
 * measured 10.1 % of the energy for a pulse 8 cells long and 4.5 % for 16 cells (amplitude reflection 32 % and
 * 21 %), so the bounds are 12 % and 6 %.  An impact's stress pulse is about a particle diameter long, 7-20
 * cells on the grids of docs/physics.md.  The fixed bottom must keep more than 80 % (it reflects all but the
 * numerical dissipation; measured 101.7 %, the excess being the energy measure's own error). */
#include <math.h>

#include "check.h"
#include "impact_fixture.h"
/* A white-box test: includes the module-private header mpm/mpm_impl.h (only tests may; tests/test_symbols.sh). */
#include "mpm/mpm_impl.h"

#define NU0_MATERIAL                                                                                                   \
    "[material.nu0]\nstrength = elastic\ndensity = 1000\neos_c0 = 816.496580927726\neos_s = 0\n"                       \
    "eos_gamma0 = 0\nG0 = 1e9\nD = 0\nmelt_T0 = 1e5\n"

static const double height = 0.04, c_L = 1414.213562373095;

/* The energy left in the column over the energy put in, and the absorbed energy booked over the same, for a
 * start slab `pulse` thick (a pulse twice as long). */
static int reflected(const char *bottom, double pulse, double *left, double *absorbed)
{
    struct impact_fixture f;
    char ini[1024];
    snprintf(ini, sizeof ini,
             "[impact]\nsubstrate = box\nsubstrate_material = nu0\nmaterial = nu0\nsubstrate_diameter = 0.004\n"
             "substrate_height = %g\nsubstrate_bottom = %s\nabsorbing = yes\ngrid = 1e-3\nspacing = 0.5e-3\n"
             "t_end = %g\ncfl = 0.2\nbonding = none\nbulk_viscosity_linear = 0\nbulk_viscosity_quadratic = 0\n"
             "box_margin = 2e-3\nstop_when_settled = no\n" NU0_MATERIAL,
             height, bottom, (height + 2 * pulse) / c_L + 3e-6);
    /* a small body at rest well above the column (a case holds a particle; this one takes no part) */
    if (impact_fixture_open(&f, ini, "sphere,0,0,0.006,0,0,0,0.002,0,nu0\n") != SC_OK)
        return -1;
    struct mpm_points *p = &f.solver->points;
    double e0 = 0.0;
    for (size_t q = 0; q < p->count; q++) {
        if (p->body[q] != 0)
            continue;
        p->flags[q] &= (uint8_t)~POINT_SIDE;
        if (p->x[3 * q + 2] > -pulse) {
            p->v[3 * q + 2] = -1.0;
            e0 += 0.5 * p->mass[q];
        }
    }
    f.solver->energy_initial = e0;
    int status = impact_fixture_run(&f);
    const struct mpm_diagnostics *d = mpm_compute_diagnostics(f.solver);
    *left = (d->body[0].kinetic_energy + d->body[0].internal_energy) / e0;
    *absorbed = d->energy_absorbed / e0;
    printf("  %s bottom, %g mm pulse: %.4f of the pulse's energy left in the column, %.4f absorbed (t = %.4g s)\n",
           bottom, 2e3 * pulse, *left, *absorbed, mpm_get_counts(f.solver).t);
    impact_fixture_close(&f);
    return status;
}

static void test_absorbing_bottom(void)
{
    /* pulses 8 and 16 cells long: what reflects is discretisation error, and falls as the pulse is resolved */
    const double pulse[2] = {0.004, 0.008}, bound[2] = {0.12, 0.06};
    for (int k = 0; k < 2; k++) {
        double left = NAN, absorbed = NAN;
        CHECK(reflected("free", pulse[k], &left, &absorbed) == SC_OK, "run");
        CHECK(left < bound[k], "%g cells a pulse: reflected energy %.4f of the incident (bound %g)", 2e3 * pulse[k],
              left, bound[k]);
        CHECK(absorbed > 0.85, "the dashpots booked %.4f of the incident energy as absorbed", absorbed);
    }
}

static void test_fixed_bottom_reflects(void)
{
    double left = NAN, absorbed = NAN;
    CHECK(reflected("fixed", 0.004, &left, &absorbed) == SC_OK, "run");
    CHECK(left > 0.8, "the fixed bottom sends back %.4f of the incident energy (at least 0.8)", left);
}

int main(void)
{
    RUN(test_absorbing_bottom);
    RUN(test_fixed_bottom_reflects);
    return check_finish();
}
