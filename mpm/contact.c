/* Nodal update, multi-body contact and bonding forces (thesis Section 3.4 steps 3-6 and 8, Section 3.5.4,
 * Section 4.1.1).  Every body has its own nodal fields (the multi-velocity-field contact of Bardenhagen et al.
 * 2000, 2001); where two bodies have mass at a node and are in contact there, or are bonded there (nodal
 * D_bond >= 1, Eqs. 4.6-4.7), equal and opposite nodal impulses bring them to a common velocity (sticking,
 * Eq. 3.31), to a common normal velocity (frictionless), or limit the tangential part by Coulomb's law.
 *
 * contact_scheme = once (the default) corrects twice per node and step, as Nairn, Hammerquist & Smith (2020) do:
 * first on the start momenta of particle-to-grid, then on the updated momenta computed from the corrected start
 * ones (end = start' + f dt).  Each correction puts a pair in contact where it approaches along the normal
 * (Eq. 3.29) in those momenta and its surfaces meet (where the first projected, the second keeps the contact unless
 * the updated momenta's change from the corrected start ones separates the pair: decide_after_correction), i.e. the
 * separation of the bodies' nodal centres of mass along the normal is at most contact_gap cells (Nairn's position-based
 * contact detection: Lemiale et al. 2010, Nairn 2013); the second also bonds pairs that separate with nodal D_bond >= 1
 * while their surfaces still meet (Tang 2021, Section 4.1.1: the bond resists separation; an approaching bonded pair is
 * in ordinary contact; bond_gap: a bond does not reach across a gap).  The points' FLIP velocity change is end'' -
 * start': the second correction (the contact force of the step) reaches them, the first (the approach that
 * particle-to-grid rebuilds from the points each step) does not, so it is not dissipated every step.  The MUSL
 * re-projected momenta (the strain rate) are projected as the second correction decided.  Two elastic spheres keep
 * their energy within 2 % and start touching when their surfaces meet (tests/test_mpm_contact.c).  Deciding the
 * second correction on start + f dt instead (one decision for both, before this) let the approach kept in the
 * points hold a particle on the substrate without any bond.  The rigid wall (rigid_wall_hold) keeps that single
 * decision, with the wall as the second body.  docs/physics.md, "Contact".
 *
 * Where three or more bodies meet at a node (once), the pairs are swept until their impulses vanish, each contact's
 * summed impulse held to pushing (resolve_bodies, reproject_bodies; docs/physics.md "Three or more bodies at a
 * node"); one sweep in layer order favoured the body listed first.
 *
 * contact_scheme = thesis decides and projects on the updated momenta, and decides and projects again on the
 * MUSL re-projected momenta: every step it hands the points the perfectly inelastic collision of the two
 * fields' start velocities, and the re-projection may decide otherwise than the update (two elastic spheres
 * lose 10 % of their energy).  contact_scheme = consistent takes one decision on start + f dt for the start,
 * updated and re-projected momenta, without the gap test, with bonded nodes sticking also while approaching:
 * contact starts up to a cell before the surfaces meet.
 *
 * The nodal update at one node, with the rigid wall, the fixed bottom and the mirror planes, and the contact's
 * decisions, impulses and sweeps there are mpm/contact_node.h's, shared with the GPU step; this file applies them
 * over the grid. */
#include <math.h>

#include "mpm/contact_node.h"
#include "mpm/mpm_impl.h"

/* The grid and the configuration as the node functions of contact_node.h read them. */
static struct contact_nodes nodes_of(const struct mpm_solver *s)
{
    const struct mpm_grid *g = &s->grid;
    const struct mpm_config *cfg = &s->cfg;
    return (struct contact_nodes){.mass = g->mass,
                                  .gradient = g->gradient,
                                  .moment = g->moment,
                                  .bond_sum = g->bond_sum,
                                  .bond_weight = g->bond_weight,
                                  .body_velocity = g->body_velocity,
                                  .contact = g->contact,
                                  .pair_state = g->pair_state,
                                  .bond_contact = g->bond_contact,
                                  .nodes = g->nodes,
                                  .layers = g->layers,
                                  .mass_cutoff = g->mass_cutoff,
                                  .h = g->h,
                                  .bonding = (int)cfg->bonding,
                                  .law = (int)cfg->contact,
                                  .scheme = (int)cfg->contact_scheme,
                                  .approach = (int)cfg->contact_approach,
                                  .growth = (int)cfg->bond_growth,
                                  .friction = cfg->friction,
                                  .contact_gap = cfg->contact_gap,
                                  .bond_gap = cfg->bond_gap,
                                  .momentum = g->momentum,
                                  .force = g->force,
                                  .momentum_new = g->momentum_new,
                                  .wall_held = g->wall_held,
                                  .moments = g->moments,
                                  .row = g->row,
                                  .plane = g->plane,
                                  .origin_z = g->origin[2],
                                  .rigid_wall = cfg->substrate == MPM_SUBSTRATE_RIGID,
                                  .fixed_bottom = cfg->fixed_bottom,
                                  .substrate_top = cfg->substrate_top,
                                  .substrate_bottom = cfg->substrate_bottom,
                                  .mirror = {cfg->mirror[0], cfg->mirror[1]},
                                  .mirror_plane = {g->mirror_plane[0], g->mirror_plane[1]}};
}

/* Contact normal at a node between bodies a and b, from a into b (contact_node.h contact_normal). */
int mpm_contact_normal(const struct mpm_grid *g, size_t Ia, size_t Ib, double n[3])
{
    struct contact_nodes c = {.gradient = g->gradient};
    return contact_normal(&c, Ia, Ib, n);
}

/* Each body's centre-of-mass velocity from the start momenta (particle-to-grid conserves momentum: the sums over a
 * layer's nodes are those of m_p and m_p v_p over the body's points), summed over the box's nodes in a fixed order
 * so that the bits do not depend on the number of threads.  Only bonds_grow reads them. */
static void body_velocities(struct mpm_solver *s)
{
    struct mpm_grid *g = &s->grid;
    size_t rows = box_rows(&g->box), length = box_row_length(&g->box);
    for (int l = 0; l < g->layers; l++) {
        double mass = 0.0, p[3] = {0.0, 0.0, 0.0};
        for (size_t r = 0; r < rows; r++) {
            int k;
            size_t first = (size_t)l * g->nodes + box_row_start(g, &g->box, r, &k);
            for (size_t I = first; I < first + length; I++) {
                mass += g->mass[I];
                for (int d = 0; d < 3; d++)
                    p[d] += g->momentum[3 * I + d];
            }
        }
        for (int d = 0; d < 3; d++) /* the whole body's: none across a mirror plane */
            g->body_velocity[3 * l + d] = mass > 0.0 && !(d < 2 && s->cfg.mirror[d]) ? p[d] / mass : 0.0;
    }
}

/* Over the nodes of this step's stencils (g->box): outside them every field is 0, and stays 0. */
void mpm_contact_nodal_update(struct mpm_solver *s)
{
    struct mpm_grid *g = &s->grid;
    long rows = (long)box_rows(&g->box);
    size_t length = box_row_length(&g->box);
    int64_t contacts = 0, bonds = 0;
    if (s->cfg.bond_growth == MPM_GROWTH_APPROACH && s->cfg.contact_scheme == MPM_CONTACT_ONCE && g->layers > 1)
        body_velocities(s);
    struct contact_nodes c = nodes_of(s);
#pragma omp parallel for schedule(static) reduction(+ : contacts, bonds)
    for (long r = 0; r < rows; r++) {
        int k, bonded;
        size_t first = box_row_start(g, &g->box, (size_t)r, &k);
        for (size_t node = first; node < first + length; node++)
            if (node_update(&c, node, k, s->dt, &bonded)) {
                contacts++;
                bonds += bonded;
            }
    }
    s->contact_node_steps += contacts;
    s->bonded_node_steps += bonds;
}

/* The pairs that meet at one node this step (in contact, bonded or touching: pair_state_recorded) added to
 * their bodies' interface counts, and those bonded by Eq. 4.7 (pair_bonded) to their bonded counts: the whole
 * set-up's, each node counted for itself and its mirror images (mirror_node_copies). */
static void count_interface_pairs(const struct contact_nodes *c, size_t node, int64_t *interface, int64_t *bonded)
{
    int a = 0, b = 0, copies = mirror_node_copies(c, node);
    double n[3];
    while (next_pair(c, node, &a, &b, n)) {
        size_t Ia = (size_t)a * c->nodes + node, Ib = (size_t)b * c->nodes + node;
        if (pair_state_recorded(c, Ia, Ib) == PAIR_FREE)
            continue;
        int held = pair_bonded(c, Ia, Ib);
        interface[a] += copies, interface[b] += copies;
        bonded[a] += copies * held, bonded[b] += copies * held;
    }
}

/* Over the nodes of this step's stencils, after the step (g->contact and the nodal D_bond are this step's). */
void mpm_contact_interface_nodes(const struct mpm_solver *s, int64_t *interface, int64_t *bonded)
{
    const struct mpm_grid *g = &s->grid;
    int nb = s->cfg.body_count;
    for (int b = 0; b < nb; b++)
        interface[b] = bonded[b] = 0;
    if (g->layers < 2)
        return;
    long rows = (long)box_rows(&g->box);
    size_t length = box_row_length(&g->box);
    struct contact_nodes c = nodes_of(s);
#pragma omp parallel for schedule(static) reduction(+ : interface[:nb], bonded[:nb])
    for (long r = 0; r < rows; r++) {
        int k;
        size_t first = box_row_start(g, &g->box, (size_t)r, &k);
        for (size_t node = first; node < first + length; node++)
            if (bodies_at(&c, node) > 1)
                count_interface_pairs(&c, node, interface, bonded);
    }
}

/* Over the nodes of this step's stencils, as mpm_contact_nodal_update. */
void mpm_contact_correct_momentum(struct mpm_solver *s, double *mom, int count_nodes)
{
    (void)count_nodes;
    struct mpm_grid *g = &s->grid;
    long rows = (long)box_rows(&g->box);
    size_t length = box_row_length(&g->box);
    struct contact_nodes c = nodes_of(s);
#pragma omp parallel for schedule(static)
    for (long r = 0; r < rows; r++) {
        int k;
        size_t first = box_row_start(g, &g->box, (size_t)r, &k);
        for (size_t node = first; node < first + length; node++)
            node_correct(&c, node, k, mom);
    }
}
