/* Module-private (dem/): impulse-momentum contact of rigid spheres, Mukherjee & Zohdi Section 2.1-2.2,
 * Eqs. (1)-(23), with the errata of docs/physics.md (continuous friction regularisation, friction impulse capped
 * at the stick limit so that it never reverses the contact-point slip).
 *
 * Collisions are instantaneous impulses applied to velocities and spins; the smooth external forces
 * (drag) are integrated separately by the time integrator, so the <F^e> terms of Eqs. (7)-(9), (22)-(23)
 * are not part of the impulse (collide-and-stream, docs/physics.md). */
#ifndef SPRAYCOAT_DEM_CONTACT_H
#define SPRAYCOAT_DEM_CONTACT_H

#include "dem/dem.h" /* struct dem_contact_law */
#include "dem/material.h"

/* Johnson's restitution and phase durations, Eqs. (16)-(19). */
struct restitution {
    double e;              /* restitution coefficient, <= 1 */
    double v_lim;          /* elastic limit speed, Eq. (17), m/s */
    double dt_compression; /* dt1 of Eq. (19), s */
    double dt_elastic;     /* Hertz duration, Eq. (16), s */
};

/* m_eff reduced mass, r_eff effective radius, e_star effective modulus, yield of the softer body,
 * vn > 0 the normal approach speed. */
struct restitution dem_contact_restitution(const struct dem_contact_law *law, double m_eff, double r_eff, double e_star,
                                           double yield, double vn);

/* The regularised Coulomb factor R(v) of Eq. (11), made continuous: v/eps inside [-eps, eps], sign(v) outside. */
double dem_contact_friction_regularization(double slip_speed, double eps);

/* A solid sphere taking part in a contact (moment of inertia 2/5 m r^2). */
struct sphere_state {
    double mass;   /* kg */
    double radius; /* m */
    double v[3];   /* centre velocity, m/s */
    double w[3];   /* spin, rad/s */
    const struct dem_material *material;
};

struct contact_outcome {
    double vn;             /* normal approach speed before the impulse, m/s (> 0 when approaching) */
    double e;              /* restitution used */
    double jn;             /* normal impulse magnitude, N s */
    double jt;             /* tangential impulse magnitude, N s */
    double dt_compression; /* dt1, s */
};

/* Two free spheres; n is the unit vector from a's centre to b's centre.  Equal and opposite impulses act
 * at the contact point.  Returns 1 if they were approaching and an impulse was applied, else 0 (nothing
 * changed). */
int dem_contact_pair(const struct dem_contact_law *law, struct sphere_state *a, struct sphere_state *b,
                     const double n[3], struct contact_outcome *out);

/* Sphere a against an immovable body: the target plane (obstacle_radius = INFINITY) or a frozen deposited
 * particle of radius obstacle_radius, made of `obstacle`.  n is the unit vector from a's centre to the
 * contact point.  Returns 1 if approaching and an impulse was applied, else 0. */
int dem_contact_fixed(const struct dem_contact_law *law, struct sphere_state *a, const struct dem_material *obstacle,
                      double obstacle_radius, const double n[3], struct contact_outcome *out);

/* Adhesion capture speed of Eq. (34) with the factor alpha_ADH: 0.2 alpha F dt1 / m, F = 4 pi gamma12 R_eff
 * (Eq. 32), gamma12 = 2 sqrt(gamma_a gamma_b) (dispersion-dominated interface), dt1 from Eq. (19) with the
 * particle's mass m and the effective radius r_eff, yield the softer body's.  A particle whose normal
 * approach speed is below this value sticks. */
double dem_contact_adhesion_capture_speed(double alpha_adh, double gamma_a, double gamma_b, double mass, double r_eff,
                                          double yield);

#endif
