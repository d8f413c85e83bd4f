/* Impulse-momentum contact of rigid spheres, Mukherjee & Zohdi Sections 2.1-2.2 and Appendix A, with the
 * Errata (docs/physics.md): the friction regularisation of Eq. (11) is made continuous, and the friction impulse
 * is capped at the stick limit so that it never reverses the contact-point slip.
 *
 * Sign conventions: for each body the contact point sits at centre + radius * n_body, where n_body is the
 * unit vector from that body's centre to the contact point (Eqs. 2-3).  For a pair, n points from a to b,
 * so n_a = n and n_b = -n.  The slip is the tangential part of (contact-point velocity of a) minus
 * (contact-point velocity of b, or zero for an immovable obstacle), Eqs. (4) and (20).
 *
 * The smooth external forces <F^e> of Eqs. (7)-(9) and (22)-(23) are left out: drag is integrated by the
 * time integrator, collisions are instantaneous impulses (collide-and-stream, docs/physics.md). */
#include "dem/contact.h"

#include <math.h>

/* M_PI is not declared in strict C17 with _POSIX_C_SOURCE. */
#define PI 3.14159265358979323846

/* Johnson's fully plastic restitution prefactor, Eq. (18). */
#define JOHNSON_PLASTIC_COEFFICIENT 3.74
/* Energy balance constant of the elastic limit, Eq. (17). */
#define JOHNSON_ELASTIC_LIMIT_COEFFICIENT 53.0
/* Hertz contact duration prefactor, Eq. (16). */
#define HERTZ_DURATION_COEFFICIENT 2.87
/* Solid sphere: I = 2/5 m r^2. */
#define SOLID_SPHERE_INERTIA_FACTOR 0.4
/* The tangential impulse J that brings the contact-point slip s of two solid spheres to rest:
 * the slip changes by J (1/m + r^2/I) summed over both bodies = (7/2) J / m_eff, so J = (2/7) m_eff s. */
#define SOLID_SPHERE_STICK_FACTOR (2.0 / 7.0)

static double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void cross3(const double a[3], const double b[3], double out[3])
{
    double x = a[1] * b[2] - a[2] * b[1];
    double y = a[2] * b[0] - a[0] * b[2];
    double z = a[0] * b[1] - a[1] * b[0];
    out[0] = x;
    out[1] = y;
    out[2] = z;
}

/* Hertz elastic contact duration, Eq. (16): 2.87 (m^2 / (R v E*^2))^(1/5). */
static double hertz_contact_duration(double m_eff, double r_eff, double e_star, double vn)
{
    if (!(vn > 0.0))
        return INFINITY;
    return HERTZ_DURATION_COEFFICIENT * pow(m_eff * m_eff / (r_eff * vn * e_star * e_star), 0.2);
}

/* Compression time, Eq. (19): sqrt(pi m / (24 R Y)).  Fully plastic contact at mean pressure ~3Y, so it
 * does not depend on the impact speed. */
static double compression_duration(double m_eff, double r_eff, double yield)
{
    return sqrt(PI * m_eff / (24.0 * r_eff * yield));
}

/* Elastic limit speed, Eq. (17): 1/2 m V_lim^2 = 53 R^3 Y^5 / E*^4. */
static double elastic_limit_speed(double m_eff, double r_eff, double e_star, double yield)
{
    double yield_ratio = yield / e_star;
    double yield_ratio_sq = yield_ratio * yield_ratio;
    double energy = JOHNSON_ELASTIC_LIMIT_COEFFICIENT * r_eff * r_eff * r_eff * yield * yield_ratio_sq * yield_ratio_sq;
    return sqrt(2.0 * energy / m_eff);
}

/* Johnson's plastic restitution, Eq. (18): 3.74 sqrt(Y/E*) (1/2 m v^2 / (Y R^3))^(-1/8).
 * The power -1/8 is taken as three square roots (no pow() in the collision path). */
static double johnson_plastic_restitution(double m_eff, double r_eff, double e_star, double yield, double vn)
{
    double kinetic_over_yield = 0.5 * m_eff * vn * vn / (yield * r_eff * r_eff * r_eff);
    double eighth_root = sqrt(sqrt(sqrt(kinetic_over_yield)));
    return JOHNSON_PLASTIC_COEFFICIENT * sqrt(yield / e_star) / eighth_root;
}

/* Eqs. (16)-(19).  Below V_lim the impact is elastic (e = 1).  Above it Eq. (18) applies, capped at 1:
 * the two branches do not meet (Eq. 18 gives 3.74/53^(1/8) = 2.28 at V_lim and falls below 1 only past
 * about 27 V_lim, docs/references.md), and e > 1 would create energy. */
struct restitution dem_contact_restitution(const struct dem_contact_law *law, double m_eff, double r_eff, double e_star,
                                           double yield, double vn)
{
    struct restitution r;
    r.v_lim = elastic_limit_speed(m_eff, r_eff, e_star, yield);
    r.dt_compression = compression_duration(m_eff, r_eff, yield);
    r.dt_elastic = hertz_contact_duration(m_eff, r_eff, e_star, vn);
    if (law->model == DEM_RESTITUTION_CONSTANT) {
        r.e = law->restitution;
    } else if (vn <= r.v_lim) {
        r.e = 1.0;
    } else {
        r.e = fmin(1.0, johnson_plastic_restitution(m_eff, r_eff, e_star, yield, vn));
    }
    return r;
}

/* Eq. (11) with the erratum of docs/physics.md: the printed inner branch v/(2 eps) jumps at |v| = eps; v/eps
 * joins the outer branches continuously.  eps <= 0 gives the sharp Coulomb law. */
double dem_contact_friction_regularization(double slip_speed, double eps)
{
    if (eps > 0.0 && fabs(slip_speed) <= eps)
        return slip_speed / eps;
    if (slip_speed > 0.0)
        return 1.0;
    if (slip_speed < 0.0)
        return -1.0;
    return 0.0;
}

/* Velocity of a body's material point at centre + radius * n_body, Eqs. (2)-(3): v + w x (r n_body). */
static void contact_point_velocity(const struct sphere_state *s, const double n_body[3], double out[3])
{
    double arm[3] = {s->radius * n_body[0], s->radius * n_body[1], s->radius * n_body[2]};
    double spin_part[3];
    cross3(s->w, arm, spin_part);
    for (int k = 0; k < 3; k++)
        out[k] = s->v[k] + spin_part[k];
}

/* Apply impulse J at the contact point centre + radius * n_body: dv = J/m, dw = (r n_body x J)/I
 * (linear and angular momentum balance, Eqs. 5-6 and 14-15). */
static void apply_impulse(struct sphere_state *s, const double n_body[3], const double impulse[3])
{
    double inverse_mass = 1.0 / s->mass;
    double inverse_inertia = 1.0 / (SOLID_SPHERE_INERTIA_FACTOR * s->mass * s->radius * s->radius);
    double arm[3] = {s->radius * n_body[0], s->radius * n_body[1], s->radius * n_body[2]};
    double torque_impulse[3];
    cross3(arm, impulse, torque_impulse);
    for (int k = 0; k < 3; k++) {
        s->v[k] += impulse[k] * inverse_mass;
        s->w[k] += torque_impulse[k] * inverse_inertia;
    }
}

/* What both contact kinds share once the bodies' reduced quantities are known. */
struct contact_geometry {
    double m_eff;    /* reduced mass, kg */
    double r_eff;    /* effective radius, m */
    double e_star;   /* effective modulus, Pa */
    double yield;    /* yield stress of the softer body, Pa */
    double friction; /* Coulomb mu of the pair */
    double slip[3];  /* tangential relative contact-point velocity, a minus b, m/s */
    double vn;       /* normal approach speed, m/s */
};

/* Relative contact-point velocity (a minus b) split into the approach speed along n and the tangential
 * slip, Eqs. (4) and (20). */
static void split_relative_velocity(const double v_rel[3], const double n[3], struct contact_geometry *g)
{
    double normal_part = dot3(v_rel, n);
    g->vn = normal_part;
    for (int k = 0; k < 3; k++)
        g->slip[k] = v_rel[k] - normal_part * n[k];
}

/* Friction impulse vector acting on body a, Eq. (10) in impulse form: magnitude mu R(|slip|) J_n,
 * against the slip, capped at the stick limit (2/7) m_eff |slip| (docs/physics.md) so that it at most stops the
 * slip and never reverses it.  Returns the magnitude. */
static double friction_impulse_on_a(const struct dem_contact_law *law, const struct contact_geometry *g,
                                    double normal_impulse, double impulse[3])
{
    double slip_speed = sqrt(dot3(g->slip, g->slip));
    impulse[0] = impulse[1] = impulse[2] = 0.0;
    if (!(slip_speed > 0.0))
        return 0.0;
    double coulomb =
        g->friction * dem_contact_friction_regularization(slip_speed, law->friction_regularization) * normal_impulse;
    double stick = SOLID_SPHERE_STICK_FACTOR * g->m_eff * slip_speed;
    double magnitude = fmin(coulomb, stick);
    double scale = -magnitude / slip_speed;
    for (int k = 0; k < 3; k++)
        impulse[k] = scale * g->slip[k];
    return magnitude;
}

/* Normal impulse magnitude and restitution for an approaching contact, Eq. (7) / Eq. (22) without the
 * external-force terms: J_n = (1 + e) m_eff v_approach. */
static double normal_impulse(const struct dem_contact_law *law, const struct contact_geometry *g,
                             struct contact_outcome *out)
{
    struct restitution rest = dem_contact_restitution(law, g->m_eff, g->r_eff, g->e_star, g->yield, g->vn);
    double jn = (1.0 + rest.e) * g->m_eff * g->vn;
    if (out) {
        out->vn = g->vn;
        out->e = rest.e;
        out->jn = jn;
        out->dt_compression = rest.dt_compression;
    }
    return jn;
}

/* The pair's Coulomb coefficient.  The paper gives one mu per contact; with two materials we take the
 * arithmetic mean of the two coefficients (symmetric in a and b, and equal to mu when both are the same). */
static double pair_friction(const struct dem_material *a, const struct dem_material *b)
{
    return 0.5 * (a->friction + b->friction);
}

int dem_contact_pair(const struct dem_contact_law *law, struct sphere_state *a, struct sphere_state *b,
                     const double n[3], struct contact_outcome *out)
{
    double n_b[3] = {-n[0], -n[1], -n[2]};
    double va[3], vb[3], v_rel[3];
    struct contact_geometry g;
    contact_point_velocity(a, n, va);
    contact_point_velocity(b, n_b, vb);
    for (int k = 0; k < 3; k++)
        v_rel[k] = va[k] - vb[k];
    split_relative_velocity(v_rel, n, &g);
    if (!(g.vn > 0.0))
        return 0; /* separating or grazing: no impulse */

    g.m_eff = a->mass * b->mass / (a->mass + b->mass);
    g.r_eff = a->radius * b->radius / (a->radius + b->radius);
    g.e_star = dem_material_effective_modulus(a->material, b->material);
    g.yield = fmin(a->material->yield_stress, b->material->yield_stress);
    g.friction = pair_friction(a->material, b->material);

    double jn = normal_impulse(law, &g, out);
    double impulse_a[3], impulse_b[3];
    double jt = friction_impulse_on_a(law, &g, jn, impulse_a);
    for (int k = 0; k < 3; k++) {
        impulse_a[k] -= jn * n[k];    /* the normal impulse pushes a back along -n */
        impulse_b[k] = -impulse_a[k]; /* equal and opposite: momentum is conserved exactly */
    }
    apply_impulse(a, n, impulse_a);
    apply_impulse(b, n_b, impulse_b);
    if (out)
        out->jt = jt;
    return 1;
}

/* Effective radius against an obstacle: the plane (infinite radius) gives R_a, a frozen sphere
 * R_a R_b / (R_a + R_b). */
static double obstacle_effective_radius(double radius, double obstacle_radius)
{
    if (isinf(obstacle_radius))
        return radius;
    return radius * obstacle_radius / (radius + obstacle_radius);
}

/* Eqs. (22)-(23) with a motionless obstacle (v_surf = 0): the obstacle's mass is infinite, so m_eff = m_a. */
int dem_contact_fixed(const struct dem_contact_law *law, struct sphere_state *a, const struct dem_material *obstacle,
                      double obstacle_radius, const double n[3], struct contact_outcome *out)
{
    double v_contact[3];
    struct contact_geometry g;
    contact_point_velocity(a, n, v_contact);
    split_relative_velocity(v_contact, n, &g);
    if (!(g.vn > 0.0))
        return 0; /* separating or grazing: no impulse */

    g.m_eff = a->mass;
    g.r_eff = obstacle_effective_radius(a->radius, obstacle_radius);
    g.e_star = dem_material_effective_modulus(a->material, obstacle);
    g.yield = fmin(a->material->yield_stress, obstacle->yield_stress);
    g.friction = pair_friction(a->material, obstacle);

    double jn = normal_impulse(law, &g, out);
    double impulse[3];
    double jt = friction_impulse_on_a(law, &g, jn, impulse);
    for (int k = 0; k < 3; k++)
        impulse[k] -= jn * n[k];
    apply_impulse(a, n, impulse);
    if (out)
        out->jt = jt;
    return 1;
}

/* Eq. (34) with alpha_ADH: a particle sticks if v0 < 0.2 alpha F dt1 / m, F = 4 pi gamma12 R (Eq. 32),
 * gamma12 = 2 sqrt(gamma_a gamma_b) (dispersion forces dominant, Section 3), dt1 from Eq. (19). */
double dem_contact_adhesion_capture_speed(double alpha_adh, double gamma_a, double gamma_b, double mass, double r_eff,
                                          double yield)
{
    double interface_energy = 2.0 * sqrt(gamma_a * gamma_b);
    double adhesion_force = 4.0 * PI * interface_energy * r_eff;
    double dt1 = compression_duration(mass, r_eff, yield);
    return 0.2 * alpha_adh * adhesion_force * dt1 / mass;
}
