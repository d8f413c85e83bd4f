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
 * The decisions, impulses and sweeps at one node are mpm/contact_node.h's, shared with the GPU step; this file
 * applies them over the grid, with the rigid wall, the fixed bottom and the mirror planes. */
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
                                  .bond_gap = cfg->bond_gap};
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

/* A rigid frictionless wall at the substrate's top, z = substrate_top.  A node at or below it whose updated
 * momentum heads into the wall is held there this step: its normal (z) momentum is 0 in the updated momenta
 * (the motion of the points), in the start momenta (the FLIP reference of the points' velocity change) and in
 * the re-projected momenta (the strain rate), the same projection in all three, as contact_scheme = consistent
 * does for a pair of bodies.  Clamping only the updated momenta, and the re-projected ones only where they head
 * into the wall, let the strain rate at a held node follow a motion the points did not make: an elastic sphere
 * dropped onto the wall from 2 um left it 23 % more energetic (at cfl 0.1; the gain grew with dt), against
 * 0.1 % now (tests/test_mpm_solver.c). */
static int below_wall(const struct mpm_solver *s, int k)
{
    const struct mpm_grid *g = &s->grid;
    return g->origin[2] + (double)k * g->h <= s->cfg.substrate_top + 1e-9 * g->h;
}

/* contact_scheme = once: whether body layer I's surface meets the wall at its node, the wall taken as a body
 * whose nodal centre of mass lies as far below the wall as the body's lies above it at touching: the body's
 * centre of mass at the node at most contact_gap / 2 cells above the wall (surfaces_meet). */
static int wall_meets(const struct mpm_solver *s, size_t I)
{
    const struct mpm_grid *g = &s->grid;
    if (!g->moments)
        return 1;
    return g->moment[3 * I + 2] / g->mass[I] - s->cfg.substrate_top <= 0.5 * s->cfg.contact_gap * g->h;
}

/* The nodal update's side of the wall: decide which layers of the node are held, and project. */
static void rigid_wall_hold(struct mpm_solver *s, size_t node, int k)
{
    struct mpm_grid *g = &s->grid;
    int at_wall = below_wall(s, k);
    for (int l = 0; l < g->layers; l++) {
        size_t I = (size_t)l * g->nodes + node;
        int held = at_wall && g->momentum_new[3 * I + 2] < 0.0 && wall_meets(s, I);
        g->wall_held[I] = (uint8_t)held;
        if (held)
            g->momentum_new[3 * I + 2] = g->momentum[3 * I + 2] = 0.0;
    }
}

/* The re-projection's side: the nodes held in this step's update, and only those, are held again. */
static void rigid_wall_reproject(const struct mpm_solver *s, size_t node, double *mom)
{
    const struct mpm_grid *g = &s->grid;
    for (int l = 0; l < g->layers; l++) {
        size_t I = (size_t)l * g->nodes + node;
        if (g->wall_held[I])
            mom[3 * I + 2] = 0.0;
    }
}

/* Tang Section 4.3.3: the substrate's "bottom surface is bound vertically by the computational grid": no
 * vertical nodal velocity at or below its bottom face.  Without it a thin substrate under a large particle is
 * pushed away as a whole and its residual stress makes it creep on the dashpots. */
static void fixed_bottom(const struct mpm_solver *s, size_t node, int k, double *mom)
{
    const struct mpm_grid *g = &s->grid;
    double z = g->origin[2] + (double)k * g->h;
    if (z > s->cfg.substrate_bottom + 1e-9 * g->h)
        return;
    for (int l = 0; l < g->layers; l++)
        mom[3 * ((size_t)l * g->nodes + node) + 2] = 0.0;
}

/* [impact] symmetry: at a node on a mirror plane the whole set-up's fields are those of the modelled side doubled,
 * with no component across the plane (the mirror images' cancel), and with trilinear weights no other node sees the
 * images (mpm/params.c load_symmetry): zeroing the component across the plane of each vector field, and leaving
 * the rest halved, gives the same velocities, normals and impulses (docs/physics.md "Mirror symmetry"). */
static void mirror_node(const struct mpm_solver *s, size_t node, double *const *fields, int count)
{
    const struct mpm_grid *g = &s->grid;
    size_t at[2] = {node % g->row, node / g->row % (size_t)g->n[1]};
    for (int d = 0; d < 2; d++) {
        if (!s->cfg.mirror[d] || (long)at[d] != g->mirror_plane[d])
            continue;
        for (int l = 0; l < g->layers; l++)
            for (int f = 0; f < count; f++)
                fields[f][3 * ((size_t)l * g->nodes + node) + (size_t)d] = 0.0;
    }
}

/* Steps 3-6 at one node (in z plane k): Eq. 3.28, the wall or the fixed bottom, contact and bonds (resolve_node);
 * returns whether a pair interacted, *bonded whether one was bonded. */
static int nodal_update(struct mpm_solver *s, const struct contact_nodes *c, size_t node, int k, double *start,
                        int *bonded)
{
    struct mpm_grid *g = &s->grid;
    double dt = s->dt;
    if (s->cfg.mirror[0] || s->cfg.mirror[1]) {
        double *fields[3] = {g->momentum, g->force, g->gradient};
        mirror_node(s, node, fields, 3);
    }
    for (int l = 0; l < g->layers; l++) { /* Eq. 3.28 */
        size_t I = (size_t)l * g->nodes + node;
        int heavy = g->mass[I] > g->mass_cutoff;
        for (int d = 0; d < 3; d++)
            g->momentum_new[3 * I + d] = heavy ? g->momentum[3 * I + d] + g->force[3 * I + d] * dt : 0.0;
    }
    if (s->cfg.substrate == MPM_SUBSTRATE_RIGID)
        rigid_wall_hold(s, node, k);
    else if (s->cfg.fixed_bottom)
        fixed_bottom(s, node, k, g->momentum_new);
    *bonded = 0;
    return g->layers > 1 && bodies_at(c, node) > 1 && resolve_node(c, node, start, g->momentum_new, bonded);
}

/* Over the nodes of this step's stencils (g->box): outside them every field is 0, and stays 0. */
void mpm_contact_nodal_update(struct mpm_solver *s)
{
    struct mpm_grid *g = &s->grid;
    long rows = (long)box_rows(&g->box);
    size_t length = box_row_length(&g->box);
    int64_t contacts = 0, bonds = 0;
    double *start = s->cfg.contact_scheme != MPM_CONTACT_THESIS ? g->momentum : NULL;
    if (s->cfg.bond_growth == MPM_GROWTH_APPROACH && s->cfg.contact_scheme == MPM_CONTACT_ONCE && g->layers > 1)
        body_velocities(s);
    struct contact_nodes c = nodes_of(s);
#pragma omp parallel for schedule(static) reduction(+ : contacts, bonds)
    for (long r = 0; r < rows; r++) {
        int k, bonded;
        size_t first = box_row_start(g, &g->box, (size_t)r, &k);
        for (size_t node = first; node < first + length; node++)
            if (nodal_update(s, &c, node, k, start, &bonded)) {
                contacts++;
                bonds += bonded;
            }
    }
    s->contact_node_steps += contacts;
    s->bonded_node_steps += bonds;
}

/* The pairs that meet at one node this step (both flagged in g->contact: in contact, bonded or touching) added to
 * their bodies' interface counts, and those bonded by Eq. 4.7 (pair_bonded) to their bonded counts. */
static void count_interface_pairs(const struct contact_nodes *c, size_t node, int64_t *interface, int64_t *bonded)
{
    int a = 0, b = 0;
    double n[3];
    while (next_pair(c, node, &a, &b, n)) {
        size_t Ia = (size_t)a * c->nodes + node, Ib = (size_t)b * c->nodes + node;
        if (!c->contact[Ia] || !c->contact[Ib])
            continue;
        int held = pair_bonded(c, Ia, Ib);
        interface[a]++, interface[b]++;
        bonded[a] += held, bonded[b] += held;
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

/* The re-projected momenta at one node (in z plane k). */
static void correct_node(struct mpm_solver *s, const struct contact_nodes *c, size_t node, int k, double *mom)
{
    struct mpm_grid *g = &s->grid;
    for (int l = 0; l < g->layers; l++) {
        size_t I = (size_t)l * g->nodes + node;
        if (!(g->mass[I] > g->mass_cutoff))
            mom[3 * I] = mom[3 * I + 1] = mom[3 * I + 2] = 0.0;
    }
    if (s->cfg.mirror[0] || s->cfg.mirror[1])
        mirror_node(s, node, &mom, 1);
    if (s->cfg.substrate == MPM_SUBSTRATE_RIGID)
        rigid_wall_reproject(s, node, mom);
    else if (s->cfg.fixed_bottom)
        fixed_bottom(s, node, k, mom);
    int bonded;
    if (g->layers < 2 || bodies_at(c, node) < 2)
        return;
    if (s->cfg.contact_scheme != MPM_CONTACT_THESIS)
        reproject_node(c, node, mom);
    else
        resolve_node(c, node, NULL, mom, &bonded);
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
            correct_node(s, &c, node, k, mom);
    }
}
