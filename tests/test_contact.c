/* Impulse contact of rigid spheres (dem/contact.c): Johnson's restitution against the reference table,
 * the adhesion capture speed, restitution and energy of normal impacts, conservation laws of oblique pair
 * collisions, Chung & Ooi (2011) tests 4 and 7 against the rigid-body solution, the friction
 * regularisation, and separating bodies. */
/* A white-box test: includes the module-private headers dem/contact.h and dem/material.h (only tests may;
 * tests/test_symbols.sh). */
#include "dem/contact.h"
#include "dem/material.h"
#include "tests/check.h"
#include "tests/verification_csv.h"

#include <stdint.h>
#include <string.h>

#define PI 3.14159265358979323846

/* ---- small vector and body helpers ---- */

static double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
static double norm3(const double a[3])
{
    return sqrt(dot3(a, a));
}

static void cross3(const double a[3], const double b[3], double out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

static double sphere_mass(double radius, double density)
{
    return 4.0 / 3.0 * PI * radius * radius * radius * density;
}
static double sphere_inertia(const struct sphere_state *s)
{
    return 0.4 * s->mass * s->radius * s->radius;
}

static double kinetic_energy(const struct sphere_state *s)
{
    return 0.5 * s->mass * dot3(s->v, s->v) + 0.5 * sphere_inertia(s) * dot3(s->w, s->w);
}

/* A material from Young's modulus and Poisson's ratio (G = E/(2(1+nu)), K = E/(3(1-2nu))). */
static struct dem_material material_from_e_nu(double youngs, double poisson, double density, double mu)
{
    struct dem_material m = {0};
    m.density = density;
    m.shear_modulus = youngs / (2.0 * (1.0 + poisson));
    m.bulk_modulus = youngs / (3.0 * (1.0 - 2.0 * poisson));
    m.yield_stress = 1e9;
    m.surface_energy = 1.0;
    m.friction = mu;
    return m;
}

static struct sphere_state sphere_at_rest(double radius, const struct dem_material *material)
{
    struct sphere_state s = {0};
    s.radius = radius;
    s.mass = sphere_mass(radius, material->density);
    s.material = material;
    return s;
}

/* Contact point velocity v + w x (r n_body), n_body from the centre to the contact point. */
static void point_velocity(const struct sphere_state *s, const double n_body[3], double out[3])
{
    double arm[3] = {s->radius * n_body[0], s->radius * n_body[1], s->radius * n_body[2]}, spin[3];
    cross3(s->w, arm, spin);
    for (int k = 0; k < 3; k++)
        out[k] = s->v[k] + spin[k];
}

/* Tangential part of (contact-point velocity of a) - (that of b), n from a to b. */
static void pair_slip(const struct sphere_state *a, const struct sphere_state *b, const double n[3], double slip[3])
{
    double n_b[3] = {-n[0], -n[1], -n[2]}, va[3], vb[3], rel[3];
    point_velocity(a, n, va);
    point_velocity(b, n_b, vb);
    for (int k = 0; k < 3; k++)
        rel[k] = va[k] - vb[k];
    double normal = dot3(rel, n);
    for (int k = 0; k < 3; k++)
        slip[k] = rel[k] - normal * n[k];
}

/* ---- Johnson's restitution table (Mukherjee & Zohdi Eqs. 16-19) ---- */

static struct dem_material table_particle(void)
{
    struct dem_material m = {.density = 5680.0,
                             .shear_modulus = 77e9,
                             .bulk_modulus = 167e9,
                             .yield_stress = 690e6,
                             .surface_energy = 0.046,
                             .friction = 0.3};
    return m;
}

static struct dem_material table_target(void)
{
    struct dem_material m = {.density = 0.0,
                             .shear_modulus = 80e9,
                             .bulk_modulus = 160e9,
                             .yield_stress = 690e6,
                             .surface_energy = 1.1,
                             .friction = 0.3};
    return m;
}

#define TABLE_RTOL 1e-8

static void check_johnson_row(const struct csv_row *row)
{
    struct dem_material particle = table_particle(), target = table_target();
    int is_wall = strcmp(row->field[0], "wall") == 0;
    double radius = csv_number(row, 1), vn = csv_number(row, 2);
    double particle_mass = sphere_mass(radius, particle.density);
    double m_eff = is_wall ? particle_mass : 0.5 * particle_mass;
    double r_eff = is_wall ? radius : 0.5 * radius;
    double e_star = dem_material_effective_modulus(&particle, is_wall ? &target : &particle);
    CHECK_CLOSE(m_eff, csv_number(row, 3), TABLE_RTOL, 0.0, "mass or reduced mass");
    CHECK_CLOSE(e_star, csv_number(row, 4), TABLE_RTOL, 0.0, "E*");

    struct dem_contact_law law = {DEM_RESTITUTION_JOHNSON, 0.0, 1e-6};
    struct restitution r = dem_contact_restitution(&law, m_eff, r_eff, e_star, particle.yield_stress, vn);
    CHECK_CLOSE(r.v_lim, csv_number(row, 5), TABLE_RTOL, 0.0, "V_lim (Eq. 17)");
    CHECK_CLOSE(r.e, csv_number(row, 6), TABLE_RTOL, 0.0, "e (Eq. 18, capped at 1)");
    CHECK_CLOSE(r.dt_compression, csv_number(row, 7), TABLE_RTOL, 0.0, "dt1 (Eq. 19)");
    CHECK_CLOSE(r.dt_elastic, csv_number(row, 8), TABLE_RTOL, 0.0, "Hertz duration (Eq. 16)");

    /* The collision routines must pick the same reduced quantities: a head-on impact at vn. */
    struct sphere_state a = sphere_at_rest(radius, &particle);
    struct contact_outcome out;
    double down[3] = {0.0, 0.0, -1.0};
    if (is_wall) {
        a.v[2] = -vn;
        CHECK(dem_contact_fixed(&law, &a, &target, INFINITY, down, &out) == 1, "wall impact applied");
    } else {
        struct sphere_state b = sphere_at_rest(radius, &particle);
        a.v[2] = -0.5 * vn;
        b.v[2] = 0.5 * vn;
        CHECK(dem_contact_pair(&law, &a, &b, down, &out) == 1, "pair impact applied");
        CHECK_CLOSE(b.v[2] - a.v[2], -r.e * vn, 1e-12, 0.0, "pair: separation speed = e vn");
    }
    CHECK_CLOSE(out.vn, vn, 1e-14, 0.0, "outcome vn");
    CHECK_CLOSE(out.e, csv_number(row, 6), TABLE_RTOL, 0.0, "outcome e from the collision routine");
    CHECK_CLOSE(out.dt_compression, csv_number(row, 7), TABLE_RTOL, 0.0, "outcome dt1");
    CHECK_CLOSE(out.jn, (1.0 + out.e) * m_eff * vn, 1e-14, 0.0, "J_n = (1+e) m_eff vn");
}

static void test_johnson_table(void)
{
    int rows = csv_for_each("contact_johnson.csv", check_johnson_row);
    CHECK(rows >= 24, "contact_johnson.csv rows: %d, expected at least 24", rows);
}

/* Below V_lim the impact is elastic; just above it Eq. (18) exceeds 1 and is capped; at high speed
 * e falls as v^(-1/4). */
static void test_johnson_branches(void)
{
    struct dem_material particle = table_particle(), target = table_target();
    struct dem_contact_law law = {DEM_RESTITUTION_JOHNSON, 0.0, 1e-6};
    double radius = 2e-5, m = sphere_mass(radius, particle.density);
    double e_star = dem_material_effective_modulus(&particle, &target), y = particle.yield_stress;
    struct restitution slow = dem_contact_restitution(&law, m, radius, e_star, y, 1e-3);
    CHECK(slow.e == 1.0, "elastic branch e = %g", slow.e);
    struct restitution above = dem_contact_restitution(&law, m, radius, e_star, y, 1.01 * slow.v_lim);
    CHECK(above.e == 1.0, "just above V_lim Eq. 18 gives > 1 and is capped: e = %g", above.e);
    struct restitution v100 = dem_contact_restitution(&law, m, radius, e_star, y, 100.0);
    struct restitution v1600 = dem_contact_restitution(&law, m, radius, e_star, y, 1600.0);
    CHECK_CLOSE(v1600.e / v100.e, 0.5, 1e-12, 0.0, "plastic e ~ v^(-1/4)");
    double expected = 3.74 * sqrt(y / e_star) * pow(0.5 * m * 100.0 * 100.0 / (y * pow(radius, 3)), -0.125);
    CHECK_CLOSE(v100.e, expected, 1e-12, 0.0, "Eq. 18 at 100 m/s");
    CHECK_CLOSE(v100.dt_compression, v1600.dt_compression, 1e-15, 0.0, "dt1 independent of speed");

    struct dem_contact_law constant = {DEM_RESTITUTION_CONSTANT, 0.37, 1e-6};
    struct restitution c = dem_contact_restitution(&constant, m, radius, e_star, y, 100.0);
    CHECK(c.e == 0.37, "constant e returned: %g", c.e);
    CHECK_CLOSE(c.dt_compression, v100.dt_compression, 1e-15, 0.0, "constant mode still gives dt1");
    CHECK_CLOSE(c.dt_elastic, v100.dt_elastic, 1e-15, 0.0, "constant mode still gives the Hertz duration");
}

/* Hertz durations of Chung & Ooi (2011) tests 1 and 2 (docs/references.md): glass pair at 20 m/s relative,
 * tc = 40.3 us (docs/references.md; Eq. 16 gives 40.36 us and the digitized Kratos force curve ends at 40.48 us,
 * hence the 0.2 us tolerance); Al alloy sphere on a rigid wall at 0.2 m/s, tc = 732 us. */
static void test_hertz_duration_chung_ooi(void)
{
    struct dem_contact_law law = {DEM_RESTITUTION_CONSTANT, 1.0, 1e-6};
    struct dem_material glass = material_from_e_nu(48e9, 0.2, 2800.0, 0.0);
    double m_glass = sphere_mass(0.01, glass.density);
    struct restitution pair =
        dem_contact_restitution(&law, 0.5 * m_glass, 0.005, dem_material_effective_modulus(&glass, &glass), 1e9, 20.0);
    CHECK_CLOSE(pair.dt_elastic, 40.3e-6, 0.0, 0.2e-6, "glass pair Hertz duration");
    double e_al = 70e9, nu_al = 0.3;
    double m_al = sphere_mass(0.1, 2699.0);
    struct restitution wall = dem_contact_restitution(&law, m_al, 0.1, e_al / (1.0 - nu_al * nu_al), 1e9, 0.2);
    CHECK_CLOSE(wall.dt_elastic, 732e-6, 0.0, 0.5e-6, "Al sphere on rigid wall Hertz duration");
}

/* ---- adhesion capture speed, Eq. (34) ---- */

static void check_adhesion_row(const struct csv_row *row)
{
    double radius = csv_number(row, 0), alpha = csv_number(row, 1);
    double mass = sphere_mass(radius, 5680.0);
    double v = dem_contact_adhesion_capture_speed(alpha, 1.1, 0.046, mass, radius, 690e6);
    CHECK_CLOSE(v, csv_number(row, 5), TABLE_RTOL, 0.0, "adhesion capture speed (Eq. 34)");
}

static void test_adhesion_table(void)
{
    int rows = csv_for_each("adhesion_threshold.csv", check_adhesion_row);
    CHECK(rows >= 20, "adhesion_threshold.csv rows: %d, expected at least 20", rows);
}

/* ---- normal impacts with a prescribed restitution ---- */

static const double test_restitutions[] = {0.0, 0.3, 0.7, 0.98, 1.0};
#define N_TEST_RESTITUTIONS (sizeof test_restitutions / sizeof test_restitutions[0])

static void test_normal_wall_impact(void)
{
    struct dem_material alumina = material_from_e_nu(380e9, 0.23, 4000.0, 0.092);
    for (size_t i = 0; i < N_TEST_RESTITUTIONS; i++) {
        struct dem_contact_law law = {DEM_RESTITUTION_CONSTANT, test_restitutions[i], 1e-8};
        struct sphere_state a = sphere_at_rest(2.5e-3, &alumina);
        a.v[2] = -3.9;
        double before = kinetic_energy(&a), down[3] = {0.0, 0.0, -1.0};
        struct contact_outcome out;
        CHECK(dem_contact_fixed(&law, &a, &alumina, INFINITY, down, &out) == 1, "impact applied");
        CHECK_CLOSE(a.v[2] / 3.9, test_restitutions[i], 1e-12, 1e-12, "wall rebound ratio = e");
        CHECK_CLOSE((before - kinetic_energy(&a)) / before, 1.0 - test_restitutions[i] * test_restitutions[i], 1e-12,
                    1e-12, "wall energy loss fraction 1 - e^2");
        CHECK(a.v[0] == 0.0 && a.v[1] == 0.0 && norm3(a.w) == 0.0, "no tangential motion from a normal impact");
    }
}

static void test_normal_pair_impact(void)
{
    struct dem_material steel = material_from_e_nu(200e9, 0.3, 7800.0, 0.3);
    double n[3] = {1.0 / 3.0, 2.0 / 3.0, 2.0 / 3.0}, drift[3] = {0.4, -0.2, 0.0};
    for (size_t i = 0; i < N_TEST_RESTITUTIONS; i++) {
        struct dem_contact_law law = {DEM_RESTITUTION_CONSTANT, test_restitutions[i], 1e-8};
        struct sphere_state a = sphere_at_rest(1e-4, &steel), b = sphere_at_rest(2.3e-4, &steel);
        for (int k = 0; k < 3; k++) {
            a.v[k] = 3.0 * n[k] + drift[k];
            b.v[k] = -1.5 * n[k] + drift[k];
        }
        double total_mass = a.mass + b.mass, v_cm[3];
        for (int k = 0; k < 3; k++)
            v_cm[k] = (a.mass * a.v[k] + b.mass * b.v[k]) / total_mass;
        double cm_energy_before = 0.5 * a.mass * b.mass / total_mass * 4.5 * 4.5;
        struct contact_outcome out;
        CHECK(dem_contact_pair(&law, &a, &b, n, &out) == 1, "pair impact applied");
        double rel_after[3], cm_energy_after = 0.0;
        for (int k = 0; k < 3; k++) {
            rel_after[k] = b.v[k] - a.v[k];
            double da = a.v[k] - v_cm[k], db = b.v[k] - v_cm[k];
            cm_energy_after += 0.5 * (a.mass * da * da + b.mass * db * db);
        }
        CHECK_CLOSE(dot3(rel_after, n) / 4.5, test_restitutions[i], 1e-12, 1e-12, "pair rebound ratio = e");
        CHECK_CLOSE(1.0 - cm_energy_after / cm_energy_before, 1.0 - test_restitutions[i] * test_restitutions[i], 1e-12,
                    1e-12, "pair centre-of-mass energy loss fraction 1 - e^2");
        CHECK(norm3(a.w) == 0.0 && norm3(b.w) == 0.0, "no spin from a normal impact");
    }
}

/* ---- random oblique pair collisions: conservation laws ---- */

static uint64_t test_random_state = 0x9e3779b97f4a7c15ULL;

/* splitmix64 mapped to [lo, hi): only to make test cases, not the solver's RNG. */
static double random_uniform(double lo, double hi)
{
    uint64_t z = (test_random_state += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    z ^= z >> 31;
    return lo + (hi - lo) * (double)(z >> 11) * (1.0 / 9007199254740992.0);
}

static void random_vector(double scale, double out[3])
{
    for (int k = 0; k < 3; k++)
        out[k] = random_uniform(-scale, scale);
}

/* Sum of m r x v + I w about the origin, and a scale for its round-off. */
static void angular_momentum(const struct sphere_state *s, const double r[3], double total[3], double *scale)
{
    double rxv[3];
    cross3(r, s->v, rxv);
    double inertia = sphere_inertia(s);
    for (int k = 0; k < 3; k++)
        total[k] += s->mass * rxv[k] + inertia * s->w[k];
    *scale += s->mass * norm3(r) * norm3(s->v) + inertia * norm3(s->w);
}

static void test_random_pair_conservation(void)
{
    struct dem_material soft = table_particle(), hard = table_target();
    soft.friction = 0.15;
    hard.friction = 0.6;
    hard.density = 7800.0;
    hard.yield_stress = 300e6;
    for (int trial = 0; trial < 2000; trial++) {
        struct dem_contact_law law = {trial % 2 ? DEM_RESTITUTION_JOHNSON : DEM_RESTITUTION_CONSTANT, 0.6,
                                      trial % 3 ? 1e-3 : 10.0};
        struct sphere_state a = sphere_at_rest(random_uniform(5e-6, 8e-5), &soft);
        struct sphere_state b = sphere_at_rest(random_uniform(5e-6, 8e-5), &hard);
        double n[3], ra[3], rb[3];
        random_vector(1.0, n);
        double len = norm3(n);
        for (int k = 0; k < 3; k++)
            n[k] /= len;
        random_vector(50.0, a.v);
        random_vector(50.0, b.v);
        random_vector(2e6, a.w);
        random_vector(2e6, b.w);
        random_vector(1e-3, ra);
        for (int k = 0; k < 3; k++)
            rb[k] = ra[k] + (a.radius + b.radius) * n[k]; /* touching: one contact point */
        double approach = dot3(a.v, n) - dot3(b.v, n);
        if (approach <= 0.0)
            for (int k = 0; k < 3; k++) {
                a.v[k] -= 1.5 * approach * n[k];
                b.v[k] += 1.5 * approach * n[k];
            }

        double p_before[3], l_before[3] = {0}, l_after[3] = {0}, l_scale = 0.0, slip_before[3], slip_after[3];
        for (int k = 0; k < 3; k++)
            p_before[k] = a.mass * a.v[k] + b.mass * b.v[k];
        double p_scale = a.mass * norm3(a.v) + b.mass * norm3(b.v);
        angular_momentum(&a, ra, l_before, &l_scale);
        angular_momentum(&b, rb, l_before, &l_scale);
        double energy_before = kinetic_energy(&a) + kinetic_energy(&b);
        pair_slip(&a, &b, n, slip_before);

        struct contact_outcome out;
        CHECK(dem_contact_pair(&law, &a, &b, n, &out) == 1, "trial %d: approaching pair collides", trial);
        angular_momentum(&a, ra, l_after, &l_scale);
        angular_momentum(&b, rb, l_after, &l_scale);
        pair_slip(&a, &b, n, slip_after);
        for (int k = 0; k < 3; k++) {
            double p_after = a.mass * a.v[k] + b.mass * b.v[k];
            CHECK_CLOSE(p_after, p_before[k], 0.0, 2e-15 * p_scale, "linear momentum component");
            CHECK_CLOSE(l_after[k], l_before[k], 0.0, 1e-14 * l_scale, "angular momentum component");
        }
        CHECK(kinetic_energy(&a) + kinetic_energy(&b) <= energy_before * (1.0 + 1e-12),
              "trial %d: energy must not grow", trial);
        double s0 = norm3(slip_before);
        CHECK(dot3(slip_after, slip_before) >= -1e-12 * s0 * s0, "trial %d: friction reversed the slip", trial);
        CHECK(norm3(slip_after) <= s0 * (1.0 + 1e-12), "trial %d: friction increased the slip", trial);
        double mu = 0.5 * (soft.friction + hard.friction);
        double regularised = mu * fmin(s0 / law.friction_regularization, 1.0) * out.jn;
        double m_eff = a.mass * b.mass / (a.mass + b.mass);
        CHECK_CLOSE(out.jt, fmin(regularised, 2.0 / 7.0 * m_eff * s0), 1e-12, 0.0, "J_t law");
    }
}

/* ---- Chung & Ooi (2011) test 4: oblique impacts on a rigid wall ---- */

/* Rigid-body solution for a solid sphere without initial spin: the friction impulse stops the slip when
 * mu (1+e) v_n >= (2/7) v_t; otherwise the sphere slides throughout. */
static void oblique_rigid_body(double theta, double speed, double mu, double e, double radius, double *e_t,
                               double *omega_s)
{
    double vn = speed * cos(theta), vt = speed * sin(theta);
    if (vt > 3.5 * mu * (1.0 + e) * vn) {
        *e_t = 1.0 - mu * (1.0 + e) / tan(theta);
        *omega_s = -2.5 * mu * (1.0 + e) * vn / radius;
    } else {
        *e_t = 5.0 / 7.0;
        *omega_s = -5.0 / 7.0 * vt / radius;
    }
}

/* Sphere above the wall (n = -z), sliding along +x: the triad t = x, s = n x t = -y, omega_s = w.s. */
static void oblique_wall_impact(double theta_deg, double *e_t, double *omega_s, double *slip_after, double *vn_after)
{
    struct dem_material alumina = material_from_e_nu(380e9, 0.23, 4000.0, 0.092);
    struct dem_contact_law law = {DEM_RESTITUTION_CONSTANT, 0.98, 1e-8};
    struct sphere_state a = sphere_at_rest(2.5e-3, &alumina);
    double theta = theta_deg * PI / 180.0, down[3] = {0.0, 0.0, -1.0}, contact_v[3];
    double vt = 3.9 * sin(theta), vn = 3.9 * cos(theta);
    a.v[0] = vt;
    a.v[2] = -vn;
    dem_contact_fixed(&law, &a, &alumina, INFINITY, down, NULL);
    point_velocity(&a, down, contact_v);
    *e_t = a.v[0] / vt;
    *omega_s = -a.w[1];
    *slip_after = contact_v[0];
    *vn_after = a.v[2] / vn;
}

static void test_chung_ooi_oblique_wall(void)
{
    for (int deg = 5; deg <= 85; deg += 5) {
        double e_t, omega_s, slip_after, vn_ratio, expected_e_t, expected_omega;
        oblique_wall_impact(deg, &e_t, &omega_s, &slip_after, &vn_ratio);
        oblique_rigid_body(deg * PI / 180.0, 3.9, 0.092, 0.98, 2.5e-3, &expected_e_t, &expected_omega);
        CHECK_CLOSE(e_t, expected_e_t, 1e-9, 0.0, "tangential CoR e_t");
        CHECK_CLOSE(omega_s, expected_omega, 1e-9, 0.0, "post-impact spin omega_s");
        CHECK_CLOSE(vn_ratio, 0.98, 1e-12, 0.0, "normal rebound ratio");
        CHECK(slip_after >= -1e-12, "%d deg: friction reversed the slip (%g m/s)", deg, slip_after);
        if (deg < 30)
            CHECK_CLOSE(slip_after, 0.0, 0.0, 1e-12, "rolling at the end of a steep impact");
    }
    double e_t, omega_s, slip_after, vn_ratio;
    oblique_wall_impact(50.0, &e_t, &omega_s, &slip_after, &vn_ratio);
    CHECK_CLOSE(e_t, 0.847, 0.0, 5e-4, "docs/references.md: e_t at 50 deg");
    CHECK_CLOSE(omega_s, -457.0, 0.0, 0.5, "docs/references.md: omega at 50 deg");
    oblique_wall_impact(70.0, &e_t, &omega_s, &slip_after, &vn_ratio);
    CHECK_CLOSE(e_t, 0.934, 0.0, 5e-4, "docs/references.md: e_t at 70 deg");
    CHECK_CLOSE(omega_s, -243.0, 0.0, 0.5, "docs/references.md: omega at 70 deg");
}

/* ---- Chung & Ooi (2011) test 7: two identical spheres, opposite spins ---- */

/* Sphere a below b (n = +z), approaching at 0.2 m/s each.  Spins w_a = (0, w0, 0) and w_b = -w_a: the
 * contact points of both move at w0 R along +x, so there is no slip, and by symmetry the centres keep no
 * tangential velocity and the spins are unchanged.  A sign error in Eq. (2) or (3) would make them slip. */
static void test_chung_ooi_opposite_spins(void)
{
    struct dem_material al = material_from_e_nu(70e9, 0.33, 2700.0, 0.4);
    struct dem_contact_law law = {DEM_RESTITUTION_CONSTANT, 0.5, 1e-8};
    double up[3] = {0.0, 0.0, 1.0}, spins[] = {0.175, 2.0, 21.0};
    for (int i = 0; i < 3; i++) {
        struct sphere_state a = sphere_at_rest(0.1, &al), b = sphere_at_rest(0.1, &al);
        a.v[2] = 0.2;
        b.v[2] = -0.2;
        a.w[1] = spins[i];
        b.w[1] = -spins[i];
        struct contact_outcome out;
        CHECK(dem_contact_pair(&law, &a, &b, up, &out) == 1, "spinning pair collides");
        double scale = spins[i] * 0.1;
        CHECK_CLOSE(a.v[0], 0.0, 0.0, 1e-15 * scale, "a tangential x");
        CHECK_CLOSE(b.v[0], 0.0, 0.0, 1e-15 * scale, "b tangential x");
        CHECK(a.v[1] == 0.0 && b.v[1] == 0.0, "no sideways velocity");
        CHECK_CLOSE(a.w[1], spins[i], 1e-15, 0.0, "a spin unchanged");
        CHECK_CLOSE(b.w[1], -spins[i], 1e-15, 0.0, "b spin unchanged");
        CHECK_CLOSE(a.v[2], -0.1, 1e-14, 0.0, "a normal rebound e 0.2");
        CHECK_CLOSE(out.jt, 0.0, 0.0, 1e-15 * out.jn, "no friction impulse");
    }
}

/* Same pair with equal spin vectors: the surfaces slip at 2 w0 R; the friction impulse
 * min(mu (1+e) m_eff v_rel, (2/7) m_eff s) pushes the centres apart sideways, equal and opposite. */
static void test_same_sense_spins(void)
{
    struct dem_material al = material_from_e_nu(70e9, 0.33, 2700.0, 0.4);
    struct dem_contact_law law = {DEM_RESTITUTION_CONSTANT, 0.5, 1e-8};
    double up[3] = {0.0, 0.0, 1.0}, spins[] = {1.0, 10.0};
    for (int i = 0; i < 2; i++) {
        struct sphere_state a = sphere_at_rest(0.1, &al), b = sphere_at_rest(0.1, &al);
        a.v[2] = 0.2;
        b.v[2] = -0.2;
        a.w[1] = b.w[1] = spins[i];
        double m_eff = 0.5 * a.mass, slip = 2.0 * spins[i] * 0.1;
        double jt = fmin(0.4 * 1.5 * m_eff * 0.4, 2.0 / 7.0 * m_eff * slip);
        dem_contact_pair(&law, &a, &b, up, NULL);
        CHECK_CLOSE(a.v[0], -jt / a.mass, 1e-12, 0.0, "a pushed against its slip");
        CHECK_CLOSE(b.v[0], jt / b.mass, 1e-12, 0.0, "b pushed the other way");
        CHECK_CLOSE(a.w[1], b.w[1], 1e-14, 0.0, "both spins braked alike");
        double slip_after[3];
        pair_slip(&a, &b, up, slip_after);
        CHECK(slip_after[0] >= -1e-12 * slip, "slip not reversed");
        if (i == 0)
            CHECK_CLOSE(slip_after[0], 0.0, 0.0, 1e-12 * slip, "stick limit stops the slip exactly");
    }
}

/* ---- friction regularisation and the stick cap ---- */

static void test_friction_regularization(void)
{
    double eps = 0.2;
    CHECK_CLOSE(dem_contact_friction_regularization(0.05, eps), 0.25, 1e-15, 0.0, "R inside");
    CHECK_CLOSE(dem_contact_friction_regularization(-0.1, eps), -0.5, 1e-15, 0.0, "R inside, negative");
    CHECK(dem_contact_friction_regularization(eps, eps) == 1.0, "R continuous at eps");
    CHECK_CLOSE(dem_contact_friction_regularization(eps * (1.0 - 1e-12), eps), 1.0, 0.0, 1e-11, "R just below eps");
    CHECK(dem_contact_friction_regularization(3.0, eps) == 1.0, "R outside");
    CHECK(dem_contact_friction_regularization(-3.0, eps) == -1.0, "R outside, negative");
    CHECK(dem_contact_friction_regularization(0.0, eps) == 0.0, "R(0)");

    /* Through a wall impact: slip 0.3 m/s below eps = 1 m/s gives J_t = mu J_n s / eps. */
    struct dem_material m = material_from_e_nu(200e9, 0.3, 7800.0, 0.1);
    struct dem_contact_law law = {DEM_RESTITUTION_CONSTANT, 0.5, 1.0};
    double down[3] = {0.0, 0.0, -1.0};
    double slips[] = {0.3, 1.0, 1.5};
    for (int i = 0; i < 3; i++) {
        struct sphere_state a = sphere_at_rest(1e-3, &m);
        a.v[0] = slips[i];
        a.v[2] = -1.0;
        struct contact_outcome out;
        dem_contact_fixed(&law, &a, &m, INFINITY, down, &out);
        double expected = 0.1 * 1.5 * a.mass * fmin(slips[i], 1.0);
        CHECK_CLOSE(out.jn, 1.5 * a.mass, 1e-14, 0.0, "J_n");
        CHECK_CLOSE(out.jt, expected, 1e-12, 0.0, "J_t = mu J_n min(s/eps, 1)");
        CHECK_CLOSE(a.v[0], slips[i] - expected / a.mass, 1e-12, 0.0, "tangential velocity after");
        CHECK_CLOSE(a.w[1], 2.5 * expected / (a.mass * a.radius), 1e-12, 0.0, "spin after (dw = r n x J / I)");
    }

    /* Large mu: the stick cap (2/7) m s stops the contact point exactly; the sphere leaves rolling. */
    struct dem_material grippy = material_from_e_nu(200e9, 0.3, 7800.0, 2.0);
    struct dem_contact_law sharp = {DEM_RESTITUTION_CONSTANT, 0.5, 1e-8};
    struct sphere_state a = sphere_at_rest(1e-3, &grippy);
    a.v[1] = 0.7;
    a.v[2] = -1.0;
    struct contact_outcome out;
    dem_contact_fixed(&sharp, &a, &grippy, INFINITY, down, &out);
    double contact_v[3];
    point_velocity(&a, down, contact_v);
    CHECK_CLOSE(out.jt, 2.0 / 7.0 * a.mass * 0.7, 1e-14, 0.0, "stick-limited J_t");
    CHECK_CLOSE(contact_v[1], 0.0, 0.0, 1e-14, "contact point at rest after a stick-limited impact");
    CHECK_CLOSE(a.v[1], 0.5, 1e-14, 0.0, "rolling: v_t' = 5/7 v_t");
}

/* A frozen deposited sphere as obstacle: R_eff = R_a R_b / (R_a + R_b) enters the Hertz duration and dt1. */
static void test_fixed_sphere_obstacle(void)
{
    struct dem_material particle = table_particle();
    struct dem_contact_law law = {DEM_RESTITUTION_JOHNSON, 0.0, 1e-6};
    double ra = 2e-5, rb = 6e-5, r_eff = ra * rb / (ra + rb);
    struct sphere_state a = sphere_at_rest(ra, &particle);
    double n[3] = {0.6, 0.0, -0.8};
    a.v[0] = 6.0;
    a.v[2] = -8.0;
    struct contact_outcome out;
    CHECK(dem_contact_fixed(&law, &a, &particle, rb, n, &out) == 1, "impact on a frozen sphere");
    struct restitution expected = dem_contact_restitution(
        &law, a.mass, r_eff, dem_material_effective_modulus(&particle, &particle), particle.yield_stress, 10.0);
    CHECK_CLOSE(out.vn, 10.0, 1e-14, 0.0, "approach speed along n");
    CHECK_CLOSE(out.e, expected.e, 1e-14, 0.0, "e with R_eff of two spheres");
    CHECK_CLOSE(out.dt_compression, sqrt(PI * a.mass / (24.0 * r_eff * particle.yield_stress)), 1e-14, 0.0,
                "dt1 with R_eff of two spheres");
    CHECK_CLOSE(dot3(a.v, n), -expected.e * 10.0, 1e-12, 0.0, "normal rebound");
}

/* Eq. (17): Y is the yield stress of the softer body, whichever of the two it is. */
static void test_softer_yield_used(void)
{
    struct dem_material soft = table_particle(), hard = table_particle();
    soft.yield_stress = 200e6;
    struct dem_contact_law law = {DEM_RESTITUTION_JOHNSON, 0.0, 1e-6};
    double n[3] = {0.0, 0.0, 1.0}, radius = 3e-5;
    for (int order = 0; order < 2; order++) {
        const struct dem_material *first = order ? &hard : &soft, *second = order ? &soft : &hard;
        struct sphere_state a = sphere_at_rest(radius, first), b = sphere_at_rest(radius, second);
        double m = sphere_mass(radius, soft.density), e_star = dem_material_effective_modulus(&soft, &hard);
        a.v[2] = 40.0;
        struct contact_outcome out;
        dem_contact_pair(&law, &a, &b, n, &out);
        struct restitution pair = dem_contact_restitution(&law, 0.5 * m, 0.5 * radius, e_star, 200e6, 40.0);
        CHECK_CLOSE(out.e, pair.e, 1e-14, 0.0, "pair e with the softer yield");
        CHECK_CLOSE(out.dt_compression, pair.dt_compression, 1e-14, 0.0, "pair dt1 with the softer yield");
        struct sphere_state c = sphere_at_rest(radius, first);
        c.v[2] = 40.0;
        dem_contact_fixed(&law, &c, second, INFINITY, n, &out);
        struct restitution wall = dem_contact_restitution(&law, m, radius, e_star, 200e6, 40.0);
        CHECK_CLOSE(out.e, wall.e, 1e-14, 0.0, "wall e with the softer yield");
        CHECK_CLOSE(out.dt_compression, wall.dt_compression, 1e-14, 0.0, "wall dt1 with the softer yield");
    }
}

/* ---- separating or grazing bodies are left alone ---- */

static void test_separating_untouched(void)
{
    struct dem_material m = table_particle();
    struct dem_contact_law law = {DEM_RESTITUTION_JOHNSON, 0.0, 1e-6};
    double n[3] = {0.0, 0.0, 1.0};
    struct sphere_state a = sphere_at_rest(1e-5, &m), b = sphere_at_rest(2e-5, &m);
    a.v[0] = 3.0;
    a.v[2] = -1.0; /* moving away from b */
    a.w[1] = 1e5;
    b.w[0] = -2e5;
    struct sphere_state a0 = a, b0 = b;
    struct contact_outcome out = {0};
    CHECK(dem_contact_pair(&law, &a, &b, n, &out) == 0, "separating pair: no impulse");
    CHECK(memcmp(&a, &a0, sizeof a) == 0 && memcmp(&b, &b0, sizeof b) == 0, "separating pair unchanged");
    a.v[2] = 0.0; /* grazing */
    a0 = a;
    CHECK(dem_contact_pair(&law, &a, &b, n, &out) == 0, "grazing pair: no impulse");
    CHECK(memcmp(&a, &a0, sizeof a) == 0, "grazing pair unchanged");
    double down[3] = {0.0, 0.0, -1.0};
    a.v[2] = 0.5; /* leaving the wall below */
    a0 = a;
    CHECK(dem_contact_fixed(&law, &a, &m, INFINITY, down, &out) == 0, "leaving the wall: no impulse");
    CHECK(memcmp(&a, &a0, sizeof a) == 0, "leaving the wall unchanged");
}

int main(void)
{
    RUN(test_johnson_table);
    RUN(test_johnson_branches);
    RUN(test_hertz_duration_chung_ooi);
    RUN(test_adhesion_table);
    RUN(test_normal_wall_impact);
    RUN(test_normal_pair_impact);
    RUN(test_random_pair_conservation);
    RUN(test_chung_ooi_oblique_wall);
    RUN(test_chung_ooi_opposite_spins);
    RUN(test_same_sense_spins);
    RUN(test_friction_regularization);
    RUN(test_fixed_sphere_obstacle);
    RUN(test_softer_yield_used);
    RUN(test_separating_untouched);
    return check_finish();
}
