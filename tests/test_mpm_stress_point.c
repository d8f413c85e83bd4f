/* The GPU step's stress update, on the host: mpm/cuda/step.cu updates a point with the functions of
 * mpm/stress_point.h compiled for one lane (STRESS_LANES 1) and the plastic return of stress_return_one.  Here the
 * same functions, compiled for the host with one lane, drive single points through loading paths that cross
 * yield (the return's yield check), harden quasi-statically, reach the shock regime of PTW (1e8 /s), heat to melt
 * and unload; each step's state and result must be the bits of mpm_stress_update_prepared (the CPU's update, whose
 * returns run in blocks of MPM_RETURN_LANES lanes).  So the GPU's return iterates as the CPU's does: what can
 * differ on the device is only libm against CUDA's maths (docs/gpu.md, "Bits"). */
#include <string.h>

#define STRESS_LANES 1
/* A white-box test: includes the module-private headers (only tests may; tests/test_symbols.sh). */
#include "mpm/stress_point.h"
#include "tests/check.h"

#define V0 1e-18 /* m3: a 1 um cube */

static struct mpm_material aluminium(void)
{
    struct mpm_material m = {0};
    m.strength = MPM_STRENGTH_PTW;
    m.density = 2700.0;
    m.ptw_theta = 0.01156, m.ptw_p = 3.0, m.ptw_s0 = 0.01489, m.ptw_sinf = 0.002819, m.ptw_kappa = 1.3;
    m.ptw_gamma = 2.04e-5, m.ptw_y0 = 0.0115, m.ptw_yinf = 0.002003, m.ptw_y1 = 0.0168, m.ptw_y2 = 0.2339;
    m.ptw_beta = 0.2034;
    m.atomic_mass = 4.48039e-26;
    m.rate_floor = 1e-3;
    m.G0 = 28.8e9, m.D = 3.44e9, m.T0 = 215.0;
    m.eos_c0 = 5240.0, m.eos_s = 1.4, m.eos_gamma0 = 1.97;
    m.melt_T0 = 933.0, m.melt_a = 1.5;
    m.specific_heat = 900.0, m.taylor_quinney = 0.9, m.T_initial = 298.0;
    m.bulk_modulus = m.density * m.eos_c0 * m.eos_c0;
    return m;
}

/* update_kernel of step.cu on the host: G(T), begin, the one-lane return, finish. */
static int update_one(const struct mpm_material *m, const struct mpm_material_constants *c,
                      const struct mpm_bulk_viscosity *q, const double de[6], const double spin[3], double dt,
                      double volume0, double volume_old, double volume_new, struct mpm_point_state *state,
                      struct mpm_update_result *result)
{
    double T = state->T;
    double G = fm_select(T == m->T_initial, c->G_initial, mts_lane_shear_modulus(m, T));
    struct mpm_stress_work work;
    if (stress_begin(m, c, de, spin, G, dt, log(dt), volume0, volume_new, state, &work))
        stress_return_one(m, &work.ret);
    return stress_finish(m, c, q, dt, volume0, volume_old, volume_new, &work, state, result);
}

/* A point sheared at `rate` (1/s) with a little compression and spin for `steps` steps, then unloaded for as many:
 * every step the same bits both ways.  Returns the steps with a plastic return. */
static int drive(double rate, double dt, int steps, int *mismatch)
{
    struct mpm_material m = aluminium();
    struct mpm_material_constants c;
    struct mpm_bulk_viscosity q = {.quadratic = 1.5, .linear = 0.06, .length = 1e-6};
    mpm_material_prepare(&m, &c);
    struct mpm_point_state cpu, one;
    mpm_point_state_init(&m, &cpu);
    one = cpu;
    double volume = V0;
    int plastic = 0;
    for (int k = 0; k < 2 * steps; k++) {
        double sign = k < steps ? 1.0 : -1.0, shear = sign * rate * dt;
        double de[6] = {-0.2 * shear, 0.1 * shear, 0.1 * shear, 0.5 * shear, 0.0, 0.3 * shear};
        double spin[3] = {0.0, 0.0, 0.05 * shear};
        double volume_new = volume * (1.0 + de[0] + de[1] + de[2]);
        struct mpm_update_result r_cpu, r_one;
        int rc_cpu =
            mpm_stress_update_prepared(&m, &c, &q, de, spin, dt, log(dt), V0, volume, volume_new, &cpu, &r_cpu);
        int rc_one = update_one(&m, &c, &q, de, spin, dt, V0, volume, volume_new, &one, &r_one);
        if (rc_cpu != rc_one || memcmp(&cpu, &one, sizeof cpu) != 0 || memcmp(&r_cpu, &r_one, sizeof r_cpu) != 0) {
            if (!*mismatch)
                printf("  rate %g, step %d: state or result differs (eps_p %.17g against %.17g)\n", rate, k, cpu.eps_p,
                       one.eps_p);
            (*mismatch)++;
        }
        plastic += r_cpu.eps_p_increment > 0.0;
        volume = volume_new;
    }
    return plastic;
}

static void test_one_lane_return_is_the_cpus(void)
{
    int mismatch = 0;
    int quasi = drive(1e3, 1e-7, 800, &mismatch);   /* yield at ~1e-3 strain: hardening, then unloading */
    int medium = drive(1e6, 1e-10, 800, &mismatch); /* the thermal-activation range of PTW */
    int shock = drive(1e8, 1e-11, 3000, &mismatch); /* the shock regime, heated towards melt */
    printf("  plastic steps: %d, %d, %d\n", quasi, medium, shock);
    CHECK(quasi > 100 && medium > 100 && shock > 100, "the paths yield: %d, %d, %d plastic steps", quasi, medium,
          shock);
    CHECK(mismatch == 0, "%d steps differ from mpm_stress_update_prepared", mismatch);
}

/* A PTW material whose saturation stress at melt is below its yield stress at melt (s_inf < y_inf: allowed, and
 * then tau_s < tau_y can hold, with no hardening range and the flow stress 2 G tau_s, Eq. 2.7).  Sheared slowly
 * at 298 K, the point must yield once its stress reaches PTW's flow stress: the elastic shortcut took every trial
 * stress under 2 G y_inf as elastic, and the point stayed elastic up to 102 MPa where PTW flows at about 50-80 MPa. */
static void test_yield_below_y_inf(void)
{
    struct mpm_material m = aluminium();
    m.ptw_sinf = 0.001;
    struct mpm_material_constants c;
    struct mpm_bulk_viscosity q = {.quadratic = 1.5, .linear = 0.06, .length = 1e-6};
    mpm_material_prepare(&m, &c);
    struct mpm_point_state state;
    mpm_point_state_init(&m, &state);
    const double rate = 1e3, dt = 1e-7;
    double elastic_max = 0.0, flow = NAN;
    for (int k = 0; k < 2000 && state.eps_p == 0.0; k++) {
        double shear = rate * dt, de[6] = {0.0, 0.0, 0.0, shear, 0.0, 0.0}, spin[3] = {0.0, 0.0, 0.0};
        struct mpm_update_result r;
        CHECK(mpm_stress_update_prepared(&m, &c, &q, de, spin, dt, log(dt), V0, V0, V0, &state, &r) == 0, "update");
        if (state.eps_p == 0.0)
            elastic_max = fmax(elastic_max, r.von_mises);
    }
    double G = mpm_mts_shear_modulus(&m, state.T), Tm = m.melt_T0;
    flow = mpm_ptw_flow_stress(&m, 0.0, rate, state.T, Tm, m.density, G);
    printf("  s_inf < y_inf: elastic up to %.4g MPa; PTW's flow stress at eps_p 0 and %g /s: %.4g MPa; 2 G y_inf %.4g "
           "MPa\n",
           elastic_max * 1e-6, rate, flow * 1e-6, 2.0 * G * m.ptw_yinf * 1e-6);
    CHECK(state.eps_p > 0.0, "the point never yielded");
    CHECK(elastic_max <= flow * (1.0 + 1e-6), "elastic up to %.6g Pa, above PTW's flow stress %.6g Pa", elastic_max,
          flow);
}

int main(void)
{
    RUN(test_one_lane_return_is_the_cpus);
    RUN(test_yield_below_y_inf);
    return check_finish();
}
