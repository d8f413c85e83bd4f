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
 * contact starts up to a cell before the surfaces meet. */
#include <math.h>
#include <string.h>

#include "mpm/mpm_impl.h"

static double norm3(const double *a)
{
    return sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
}

/* Nodal bonding parameter of one body, Eq. 4.6.  The equation weights the surface points' D_bond by N but
 * divides by their count, which makes D_bond(I) about D_bond/8 for equal values; the text calls it the
 * arithmetic average.  We take the partition-of-unity average sum(D N)/sum(N), which equals D for equal
 * values (docs/physics.md, "Bonding"). */
static double nodal_bond(const struct mpm_grid *g, size_t I)
{
    return g->bond_weight[I] > 0.0 ? g->bond_sum[I] / g->bond_weight[I] : 0.0;
}

/* Contact normal at a node between bodies a and b, pointing from a into b: the maximum-volume-gradient rule
 * (Section 3.5.4) takes the body whose volume gradient is larger.  sum_p V_p grad N_I(x_p) is minus the spatial
 * gradient of the body's volume field at the node: it points out of its body. */
int mpm_contact_normal(const struct mpm_grid *g, size_t Ia, size_t Ib, double n[3])
{
    const double *ga = g->gradient + 3 * Ia, *gb = g->gradient + 3 * Ib;
    double la = norm3(ga), lb = norm3(gb);
    if (la == 0.0 && lb == 0.0)
        return -1;
    for (int d = 0; d < 3; d++)
        n[d] = la >= lb ? ga[d] / la : -gb[d] / lb;
    return 0;
}

/* How a pair of bodies interacts at a node this step, the value stored in g->contact: the re-projection projects
 * CONTACT and BONDED pairs again; TOUCHING (contact_scheme = once: surfaces met, no impulse as the pair is not
 * approaching) is there for the bonding model only, whose surface points in contact (x_p in S, Section 4.1.1) are
 * those of nodes with any state but FREE and with g->bond_contact set (mark_bond_contact). */
enum pair_state { PAIR_FREE, PAIR_CONTACT, PAIR_BONDED, PAIR_TOUCHING };

static int pair_bonded(const struct mpm_solver *s, size_t Ia, size_t Ib)
{
    const struct mpm_grid *g = &s->grid;
    return s->cfg.bonding != MPM_BONDING_NONE && 0.5 * (nodal_bond(g, Ia) + nodal_bond(g, Ib)) >= 1.0;
}

/* The decision, on the updated momenta: bonded (Eq. 4.7), or approaching along the normal (Eq. 3.29). */
static enum pair_state pair_decide(const struct mpm_solver *s, size_t Ia, size_t Ib, const double *mom,
                                   const double n[3])
{
    const struct mpm_grid *g = &s->grid;
    if (pair_bonded(s, Ia, Ib))
        return PAIR_BONDED;
    const double *pa = mom + 3 * Ia, *pb = mom + 3 * Ib;
    double approach = 0.0; /* Eq. 3.29 divided by ma mb */
    for (int d = 0; d < 3; d++)
        approach += (pa[d] / g->mass[Ia] - pb[d] / g->mass[Ib]) * n[d];
    return approach > 0.0 ? PAIR_CONTACT : PAIR_FREE;
}

/* The separation of bodies a and b at the node (m): of their nodal centres of mass along the normal n (from
 * a into b).  Two half-spaces touching with 2 points per cell along n have centres 0.75 to 0.86 cells apart (the
 * surface on a node plane or half-way between), trilinear weights; Nairn's ContactPosition cutoff for uGIMP and 2
 * points a cell is 0.8. */
static double pair_separation(const struct mpm_grid *g, size_t Ia, size_t Ib, const double n[3])
{
    const double *xa = g->moment + 3 * Ia, *xb = g->moment + 3 * Ib;
    double separation = 0.0;
    for (int d = 0; d < 3; d++)
        separation += (xb[d] / g->mass[Ib] - xa[d] / g->mass[Ia]) * n[d];
    return separation;
}

/* Whether the surfaces of bodies a and b meet at the node (contact_scheme = once): their separation is at most
 * contact_gap cells. */
static int surfaces_meet(const struct mpm_solver *s, size_t Ia, size_t Ib, const double n[3])
{
    return pair_separation(&s->grid, Ia, Ib, n) <= s->cfg.contact_gap * s->grid.h;
}

/* Whether a bonded pair holds at the node (contact_scheme = once): bonded (Eq. 4.7) and, unless bond_gap is 0,
 * its surfaces still meet (separation at most bond_gap cells).  Without that test a bond pulls wherever both
 * bodies have mass at a node, up to a cell across a gap: a 14 um particle leaving the substrate at 20 m/s with
 * PBCP 1.4 % was pulled back over 130 ns by nodes it no longer touched and never settled (docs/physics.md,
 * "Contact"). */
static int bond_holds(const struct mpm_solver *s, size_t Ia, size_t Ib, const double n[3])
{
    if (!pair_bonded(s, Ia, Ib))
        return 0;
    return s->cfg.bond_gap == 0.0 || pair_separation(&s->grid, Ia, Ib, n) <= s->cfg.bond_gap * s->grid.h;
}

/* Whether the pair approaches in the momenta `mom` (contact_scheme = once): along the common normal n (Eq. 3.29)
 * and, with contact_approach = both, along each body's own normal as well, its volume gradient (a from a into b, b
 * from b into a: Bardenhagen et al. 2000 test each body on its own normal; a body without a gradient at the node
 * has no say).  The common normal is the steeper of the two gradients (mpm_contact_normal); where a body's corner
 * meets the other's face it is the corner's, tilted off the face, and motion along the face - the rim of a
 * flattened particle rising past the crater's wall, a block sliding on a block - approaches along it though not
 * along the face's own normal: a 30 um particle rebounding at 15 m/s without any bond was braked to rest by such
 * nodes at 10 cells across (docs/physics.md, "Contact"). */
static int approaching(const struct mpm_solver *s, size_t Ia, size_t Ib, const double *mom, const double n[3])
{
    const struct mpm_grid *g = &s->grid;
    const double *ga = g->gradient + 3 * Ia, *gb = g->gradient + 3 * Ib;
    double along_common = 0.0, along_a = 0.0, along_b = 0.0;
    for (int d = 0; d < 3; d++) {
        double dv = mom[3 * Ia + d] / g->mass[Ia] - mom[3 * Ib + d] / g->mass[Ib];
        along_common += dv * n[d];
        along_a += dv * ga[d];
        along_b -= dv * gb[d];
    }
    if (!(along_common > 0.0))
        return 0;
    if (s->cfg.contact_approach == MPM_APPROACH_COMMON)
        return 1;
    return (along_a > 0.0 || norm3(ga) == 0.0) && (along_b > 0.0 || norm3(gb) == 0.0);
}

/* The one decision of contact_scheme = once, on the updated momenta: bonded while not approaching with the surfaces
 * met, in contact while approaching with the surfaces met. */
static enum pair_state pair_decide_once(const struct mpm_solver *s, size_t Ia, size_t Ib, const double *mom,
                                        const double n[3])
{
    if (!approaching(s, Ia, Ib, mom, n))
        return bond_holds(s, Ia, Ib, n) ? PAIR_BONDED : PAIR_FREE;
    return surfaces_meet(s, Ia, Ib, n) ? PAIR_CONTACT : PAIR_FREE;
}

/* The impulse on body a (body b receives its opposite) that the contact rule gives for the momenta `mom`. */
static void pair_impulse(const struct mpm_solver *s, size_t Ia, size_t Ib, const double *mom, const double n[3],
                         enum pair_state state, double J[3])
{
    const struct mpm_grid *g = &s->grid;
    double ma = g->mass[Ia], mb = g->mass[Ib];
    const double *pa = mom + 3 * Ia, *pb = mom + 3 * Ib;
    for (int d = 0; d < 3; d++) /* Eq. 3.31 times dt: both bodies move with their common velocity */
        J[d] = (ma * pb[d] - mb * pa[d]) / (ma + mb);
    if (state == PAIR_BONDED || s->cfg.contact == MPM_CONTACT_STICK)
        return;
    double Jn = J[0] * n[0] + J[1] * n[1] + J[2] * n[2];
    double Jt[3], Jt_norm;
    for (int d = 0; d < 3; d++)
        Jt[d] = J[d] - Jn * n[d];
    Jt_norm = norm3(Jt);
    double scale = 0.0; /* frictionless: the normal part only */
    if (s->cfg.contact == MPM_CONTACT_FRICTION && Jt_norm > 0.0)
        scale = fmin(1.0, s->cfg.friction * fabs(Jn) / Jt_norm);
    for (int d = 0; d < 3; d++)
        J[d] = Jn * n[d] + scale * Jt[d];
}

static void apply_impulse(double *mom, size_t Ia, size_t Ib, const double J[3])
{
    for (int d = 0; d < 3; d++) {
        mom[3 * Ia + d] += J[d];
        mom[3 * Ib + d] -= J[d];
    }
}

/* Whether the surface points of a pair's node count as in contact for the bonding model (x_p in S, Tang 2021
 * Section 4.1.1; bond_growth): wherever the pair is in contact, touching or bonded, or, with bond_growth = approach
 * (contact_scheme = once), only while the two bodies' centres of mass approach each other along the node's normal n
 * (from a into b).  Bonds form during the impact: a particle that has turned and leaves keeps its surface within
 * contact_gap of the crater and its bonded nodes within bond_gap for tens of ns while it vibrates, and D_bond kept
 * growing there: a 14 um particle at 770 m/s turned at 18 ns with PBCP 4.4 % and left with 11.8 %
 * (docs/physics.md, "Bonds form during the impact"). */
static int bonds_grow(const struct mpm_solver *s, size_t Ia, size_t Ib, const double n[3])
{
    if (s->cfg.bond_growth == MPM_GROWTH_CONTACT || s->cfg.contact_scheme != MPM_CONTACT_ONCE)
        return 1;
    const struct mpm_grid *g = &s->grid;
    const double *va = g->body_velocity + 3 * (Ia / g->nodes), *vb = g->body_velocity + 3 * (Ib / g->nodes);
    double approach = 0.0;
    for (int d = 0; d < 3; d++)
        approach += (va[d] - vb[d]) * n[d];
    return approach > 0.0;
}

/* The pair interacts at its node: its surface points count for the bonding model where it is pressed together (a
 * contact impulse this step) or bonds_grow says so. */
static void mark_bond_contact(struct mpm_solver *s, size_t Ia, size_t Ib, const double n[3], int pressed)
{
    struct mpm_grid *g = &s->grid;
    if (pressed || bonds_grow(s, Ia, Ib, n))
        g->bond_contact[Ia] = g->bond_contact[Ib] = 1;
}

/* Mark a pair touching at its node (surfaces met, no impulse in the updated momenta: for the bonding model only)
 * unless it is marked already; pressed: the first correction gave it a contact impulse. */
static void mark_touching(struct mpm_solver *s, size_t Ia, size_t Ib, const double n[3], int pressed)
{
    struct mpm_grid *g = &s->grid;
    g->contact[Ia] = g->contact[Ia] ? g->contact[Ia] : PAIR_TOUCHING;
    g->contact[Ib] = g->contact[Ib] ? g->contact[Ib] : PAIR_TOUCHING;
    mark_bond_contact(s, Ia, Ib, n, pressed);
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

/* contact_scheme = once, the first of its two corrections (Nairn, Hammerquist & Smith 2020): on the start momenta,
 * where the pair approaches in them and the surfaces meet.  The updated momenta take the same impulse, as if
 * they had been computed from the corrected start momenta (end = start' + f dt).  The pair is marked touching
 * (for the bonding model) unless the second correction decides more.  Returns whether it projected, and J, the
 * impulse on body a (left unchanged where it did not project). */
static int first_correction(struct mpm_solver *s, size_t Ia, size_t Ib, double *start, double *end, const double n[3],
                            double J[3])
{
    if (pair_decide_once(s, Ia, Ib, start, n) != PAIR_CONTACT)
        return 0;
    pair_impulse(s, Ia, Ib, start, n, PAIR_CONTACT, J);
    apply_impulse(start, Ia, Ib, J);
    apply_impulse(end, Ia, Ib, J);
    mark_touching(s, Ia, Ib, n, 1);
    return 1;
}

/* The second decision of contact_scheme = once where the first correction put the pair in contact: the surfaces
 * met and the pair approached in the start momenta (along every normal, `approaching`), which now share their normal
 * velocity (all of it, stick).  The updated momenta then approach or separate only as they changed from those
 * start momenta: by the nodal forces (end = start' + f dt), and by what else acted on `end` alone at this node (the
 * rigid wall's hold, the fixed bottom, another pair's impulse where three bodies meet).  So the pair stays in contact
 * unless ((end_a - start'_a) / m_a - (end_b - start'_b) / m_b) . n < 0, and holds where it is bonded if that
 * separates it.  Deciding on the updated momenta themselves, as before, left the decision to the rounding of
 * velocities near 800 m/s wherever nothing acts: at the first touch, with the bodies stress-free and f = 0 (where
 * end and start' are the same bits and the change is exactly 0), whether the contact started at all (a 14 um particle
 * passed 0.17 cells into the substrate before it did, in one of two runs whose grids differed by 1e-8), and on the
 * axis of a normal impact which side of it (the particle's v_x reached 1 m/s); with this test the two runs agree to 6
 * digits and the impact stays mirror-symmetric to rounding (docs/physics.md, "Contact").  The sliding of a pair
 * along a body's own normal (contact_approach = both) is judged on the start momenta, by the first correction. */
static enum pair_state decide_after_correction(const struct mpm_solver *s, size_t Ia, size_t Ib, const double *start,
                                               const double *end, const double n[3])
{
    const struct mpm_grid *g = &s->grid;
    double along = 0.0;
    for (int d = 0; d < 3; d++)
        along += ((end[3 * Ia + d] - start[3 * Ia + d]) / g->mass[Ia] -
                  (end[3 * Ib + d] - start[3 * Ib + d]) / g->mass[Ib]) *
                 n[d];
    if (!(along < 0.0))
        return PAIR_CONTACT;
    return bond_holds(s, Ia, Ib, n) ? PAIR_BONDED : PAIR_FREE;
}

static int bodies_at(const struct mpm_grid *g, size_t node)
{
    int count = 0;
    for (int l = 0; l < g->layers; l++)
        count += g->mass[(size_t)l * g->nodes + node] > g->mass_cutoff;
    return count;
}

/* The pair (Ia, Ib) at its node, with normal n from a into b, decided on the momenta `end` and projected there.
 * The start momenta `start` (unless NULL): consistent applies the same impulse to them; once corrects them first
 * on their own decision (first_correction), and where it projected decides on how `end` changed from the corrected
 * start momenta (decide_after_correction).  The pair's bodies are flagged (g->contact) for the re-projection and
 * the bonding model.  Returns its state; *corrected whether the first correction projected; Js and Je the
 * impulses on body a of the first and the second correction (0 where none). */
static enum pair_state resolve_pair(struct mpm_solver *s, size_t Ia, size_t Ib, const double n[3], double *start,
                                    double *end, int *corrected, double Js[3], double Je[3])
{
    struct mpm_grid *g = &s->grid;
    int once = s->cfg.contact_scheme == MPM_CONTACT_ONCE;
    for (int d = 0; d < 3; d++)
        Js[d] = Je[d] = 0.0;
    *corrected = once && start && first_correction(s, Ia, Ib, start, end, n, Js);
    enum pair_state state = *corrected ? decide_after_correction(s, Ia, Ib, start, end, n)
                            : once     ? pair_decide_once(s, Ia, Ib, end, n)
                                       : pair_decide(s, Ia, Ib, end, n);
    if (state == PAIR_FREE) {
        if (once && surfaces_meet(s, Ia, Ib, n))
            mark_touching(s, Ia, Ib, n, 0);
        return PAIR_FREE;
    }
    pair_impulse(s, Ia, Ib, end, n, state, Je);
    apply_impulse(end, Ia, Ib, Je);
    if (start && !once) {
        double J[3];
        pair_impulse(s, Ia, Ib, start, n, state, J);
        apply_impulse(start, Ia, Ib, J);
    }
    g->contact[Ia] = g->contact[Ib] = (uint8_t)state;
    mark_bond_contact(s, Ia, Ib, n, state == PAIR_CONTACT);
    return state;
}

/* The pairs at a node in layer order: the next pair (a, b), b > a, after (*a, *b) (start from 0, 0) whose bodies both
 * have mass at the node and whose contact normal n is defined; 0 when none is left. */
static int next_pair(const struct mpm_grid *g, size_t node, int *a, int *b, double n[3])
{
    for (; *a < g->layers; (*a)++, *b = *a) {
        size_t Ia = (size_t)*a * g->nodes + node;
        if (!(g->mass[Ia] > g->mass_cutoff))
            continue;
        while (++*b < g->layers) {
            size_t Ib = (size_t)*b * g->nodes + node;
            if (g->mass[Ib] > g->mass_cutoff && mpm_contact_normal(g, Ia, Ib, n) == 0)
                return 1;
        }
    }
    return 0;
}

/* Every pair at the node once, one after the other in layer order (resolve_pair).  Returns whether any pair
 * interacted; *bonded whether one was bonded. */
static int sweep_pairs(struct mpm_solver *s, size_t node, double *start, double *end, int *bonded)
{
    const struct mpm_grid *g = &s->grid;
    int touched = 0;
    double n[3], Js[3], Je[3];
    for (int a = 0, b = 0; next_pair(g, node, &a, &b, n);) {
        int corrected;
        size_t Ia = (size_t)a * g->nodes + node, Ib = (size_t)b * g->nodes + node;
        enum pair_state state = resolve_pair(s, Ia, Ib, n, start, end, &corrected, Js, Je);
        touched |= corrected || state != PAIR_FREE;
        *bonded |= state == PAIR_BONDED;
    }
    return touched;
}

/* A pair at a node where three or more bodies meet (resolve_bodies): its state so far in this step's sweeps and
 * the impulses on body a summed over them, of the first correction (start and end momenta) and of the second (end). */
struct node_pair {
    size_t Ia, Ib;
    double n[3];
    enum pair_state state;
    int corrected;
    double start_impulse[3], end_impulse[3];
};

/* Pairs beyond this many at one node (twelve bodies) are resolved in one sweep, in layer order. */
#define MAX_NODE_PAIRS 66
/* The sweeps at a node stop once one's impulses add up to at most this fraction of the node's momentum, or after
 * MAX_SWEEPS (the decisions keep changing). */
#define SWEEP_TOLERANCE 1e-10
#define MAX_SWEEPS      200

/* The pairs at the node whose contact normal is defined, in layer order; returns their number, or -1 beyond
 * MAX_NODE_PAIRS. */
static int node_pairs(const struct mpm_grid *g, size_t node, struct node_pair *pairs)
{
    int count = 0;
    double n[3];
    for (int a = 0, b = 0; next_pair(g, node, &a, &b, n); count++) {
        if (count == MAX_NODE_PAIRS)
            return -1;
        pairs[count] = (struct node_pair){
            .Ia = (size_t)a * g->nodes + node, .Ib = (size_t)b * g->nodes + node, .state = PAIR_FREE};
        memcpy(pairs[count].n, n, sizeof n);
    }
    return count;
}

static void add3(double *sum, const double *v)
{
    for (int d = 0; d < 3; d++)
        sum[d] += v[d];
}

/* Projected Gauss-Seidel's clamp: a pair in contact only pushes.  J is the next impulse on body a, `sum` what the
 * pair has given a so far; where sum + J would pull a towards b along n (from a into b), J takes back all of it. */
static void only_push(const double sum[3], const double n[3], double J[3])
{
    if (!((sum[0] + J[0]) * n[0] + (sum[1] + J[1]) * n[1] + (sum[2] + J[2]) * n[2] > 0.0))
        return;
    for (int d = 0; d < 3; d++)
        J[d] = -sum[d];
}

/* The start half of project_again: the first correction projected again on the start momenta (and the end
 * momenta take the same impulse), held to pushing.  Returns the size of the impulse. */
static double correct_start_again(struct mpm_solver *s, struct node_pair *p, double *start, double *end)
{
    double J[3];
    pair_impulse(s, p->Ia, p->Ib, start, p->n, PAIR_CONTACT, J);
    only_push(p->start_impulse, p->n, J);
    apply_impulse(start, p->Ia, p->Ib, J);
    apply_impulse(end, p->Ia, p->Ib, J);
    add3(p->start_impulse, J);
    return norm3(J);
}

/* A pair that an earlier sweep of this node-step corrected or put in contact or bonded, projected again on momenta
 * other pairs have changed since: the start momenta where its first correction projected (correct_start_again);
 * a pair corrected but left free is decided again on how the end momenta changed from the corrected start ones
 * (decide_after_correction), as at a node of two bodies; the end momenta as its state says.  Each correction's
 * impulse summed over the sweeps is held to pushing where the pair is in contact (only_push; a bond may pull), as
 * at a node of two bodies, where the second correction is made only while the forces press the pair together.
 * Returns the size of the impulses applied; *bonded is set where the pair is bonded. */
static double project_again(struct mpm_solver *s, struct node_pair *p, double *start, double *end, int *bonded)
{
    double J[3], moved = p->corrected ? correct_start_again(s, p, start, end) : 0.0;
    if (p->state == PAIR_FREE) {
        p->state = decide_after_correction(s, p->Ia, p->Ib, start, end, p->n);
        if (p->state == PAIR_FREE)
            return moved;
        s->grid.contact[p->Ia] = s->grid.contact[p->Ib] = (uint8_t)p->state;
        mark_bond_contact(s, p->Ia, p->Ib, p->n, p->state == PAIR_CONTACT);
    }
    pair_impulse(s, p->Ia, p->Ib, end, p->n, p->state, J);
    if (p->state == PAIR_CONTACT)
        only_push(p->end_impulse, p->n, J);
    apply_impulse(end, p->Ia, p->Ib, J);
    add3(p->end_impulse, J);
    *bonded |= p->state == PAIR_BONDED;
    return moved + norm3(J);
}

/* The sum of the sizes of the node's momenta: the scale of the sweeps' stopping test. */
static double node_momentum(const struct mpm_grid *g, size_t node, const double *mom)
{
    double sum = 0.0;
    for (int l = 0; l < g->layers; l++)
        sum += norm3(mom + 3 * ((size_t)l * g->nodes + node));
    return sum;
}

/* contact_scheme = once where three or more bodies meet at the node.  One sweep in layer order favours the body
 * listed first: each pair's impulse changes the momenta the next pair is decided on, and a pair decided early is
 * not revisited (two elastic boxes side by side on an elastic block left at 12.61 and 12.28 m/s, and at 12.15 and
 * 12.59 with the bodies' rows swapped).  So the sweeps repeat until their impulses vanish, as the nonlinear
 * Gauss-Seidel of non-smooth contact dynamics does (Jean 1999): a pair not yet corrected or in contact is decided
 * afresh (resolve_pair); one that is, is projected again (project_again) with each correction's summed impulse held
 * to pushing.  The limit is the node's contact problem solved: every pair in contact moves with a common normal
 * velocity (all of it, stick) and pushes, whatever the order (docs/physics.md "Three or more bodies at a node").
 * MAX_SWEEPS ends a node whose decisions keep changing without a message (none did in the tests). */
static int resolve_bodies(struct mpm_solver *s, size_t node, double *start, double *end, int *bonded)
{
    struct node_pair pairs[MAX_NODE_PAIRS];
    int count = node_pairs(&s->grid, node, pairs), touched = 0;
    if (count < 0)
        return sweep_pairs(s, node, start, end, bonded);
    for (int k = 0; k < MAX_SWEEPS; k++) {
        double moved = 0.0;
        for (int i = 0; i < count; i++) {
            struct node_pair *p = pairs + i;
            if (p->state != PAIR_FREE || p->corrected) {
                moved += project_again(s, p, start, end, bonded);
                continue;
            }
            double Js[3], Je[3];
            int corrected;
            p->state = resolve_pair(s, p->Ia, p->Ib, p->n, start, end, &corrected, Js, Je);
            p->corrected = corrected;
            add3(p->start_impulse, Js);
            add3(p->end_impulse, Je);
            moved += norm3(Js) + norm3(Je);
            touched |= corrected || p->state != PAIR_FREE;
            *bonded |= p->state == PAIR_BONDED;
        }
        if (!(moved > SWEEP_TOLERANCE * node_momentum(&s->grid, node, end)))
            break;
    }
    return touched;
}

/* Contact and bond impulses at node `node`: one sweep over its pairs where two bodies meet (or with the schemes
 * kept for comparison), resolve_bodies where three or more do (contact_scheme = once).  Returns whether any pair
 * interacted; *bonded whether one was bonded. */
static int resolve_node(struct mpm_solver *s, size_t node, double *start, double *end, int *bonded)
{
    *bonded = 0;
    if (s->cfg.contact_scheme == MPM_CONTACT_ONCE && start && bodies_at(&s->grid, node) > 2)
        return resolve_bodies(s, node, start, end, bonded);
    return sweep_pairs(s, node, start, end, bonded);
}

/* How the re-projection treats the pair (Ia, Ib): as the nodal update decided it where both bodies were flagged
 * there (PAIR_BONDED or PAIR_CONTACT), PAIR_FREE (no impulse) where either was not or only touched. */
static enum pair_state reprojected_state(const struct mpm_solver *s, size_t Ia, size_t Ib)
{
    const struct mpm_grid *g = &s->grid;
    if (!g->contact[Ia] || !g->contact[Ib] || g->contact[Ia] == PAIR_TOUCHING || g->contact[Ib] == PAIR_TOUCHING)
        return PAIR_FREE;
    if (s->cfg.contact_scheme == MPM_CONTACT_ONCE)
        return g->contact[Ia] == PAIR_BONDED && g->contact[Ib] == PAIR_BONDED ? PAIR_BONDED : PAIR_CONTACT;
    return pair_bonded(s, Ia, Ib) ? PAIR_BONDED : PAIR_CONTACT;
}

/* contact_scheme = consistent or once, the MUSL re-projected momenta: the pairs in contact in this step's nodal
 * update (both bodies flagged) are projected again without a new test, so that the strain rate is that of the
 * motion the points made; once projects a pair as it was decided (bonded or in contact).  One sweep over the node's
 * pairs, as at a node of two bodies. */
static void reproject_sweep(const struct mpm_solver *s, size_t node, double *mom)
{
    const struct mpm_grid *g = &s->grid;
    for (int a = 0; a < g->layers; a++) {
        size_t Ia = (size_t)a * g->nodes + node;
        if (!(g->mass[Ia] > g->mass_cutoff) || !g->contact[Ia])
            continue;
        for (int b = a + 1; b < g->layers; b++) {
            size_t Ib = (size_t)b * g->nodes + node;
            double n[3], J[3];
            if (!(g->mass[Ib] > g->mass_cutoff) || !g->contact[Ib] || mpm_contact_normal(g, Ia, Ib, n) != 0)
                continue;
            enum pair_state state = reprojected_state(s, Ia, Ib);
            if (state == PAIR_FREE)
                continue; /* no impulse this step */
            pair_impulse(s, Ia, Ib, mom, n, state, J);
            apply_impulse(mom, Ia, Ib, J);
        }
    }
}

/* The re-projection where three or more bodies meet (contact_scheme = once).  The contact flags are the bodies',
 * not the pairs': two bodies that each touched a third are both flagged, in contact with each other or not.  So
 * only the flagged pairs whose surfaces meet (surfaces_meet) take part, and they are swept until the impulses
 * vanish with each pair's summed impulse held to pushing where it is in contact, as in the nodal update
 * (resolve_bodies): no order enters, and no pair that the update left apart is tied together. */
static void reproject_bodies(const struct mpm_solver *s, size_t node, double *mom)
{
    struct node_pair pairs[MAX_NODE_PAIRS];
    int count = node_pairs(&s->grid, node, pairs), kept = 0;
    if (count < 0) {
        reproject_sweep(s, node, mom);
        return;
    }
    for (int i = 0; i < count; i++) {
        struct node_pair p = pairs[i];
        p.state = reprojected_state(s, p.Ia, p.Ib);
        if (p.state != PAIR_FREE && surfaces_meet(s, p.Ia, p.Ib, p.n))
            pairs[kept++] = p;
    }
    for (int k = 0; k < MAX_SWEEPS; k++) {
        double moved = 0.0, J[3];
        for (int i = 0; i < kept; i++) {
            struct node_pair *p = pairs + i;
            pair_impulse(s, p->Ia, p->Ib, mom, p->n, p->state, J);
            if (p->state == PAIR_CONTACT)
                only_push(p->end_impulse, p->n, J);
            apply_impulse(mom, p->Ia, p->Ib, J);
            add3(p->end_impulse, J);
            moved += norm3(J);
        }
        if (!(moved > SWEEP_TOLERANCE * node_momentum(&s->grid, node, mom)))
            break;
    }
}

static void reproject_node(const struct mpm_solver *s, size_t node, double *mom)
{
    if (s->cfg.contact_scheme == MPM_CONTACT_ONCE && bodies_at(&s->grid, node) > 2)
        reproject_bodies(s, node, mom);
    else
        reproject_sweep(s, node, mom);
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
static int nodal_update(struct mpm_solver *s, size_t node, int k, double *start, int *bonded)
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
    return g->layers > 1 && bodies_at(g, node) > 1 && resolve_node(s, node, start, g->momentum_new, bonded);
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
#pragma omp parallel for schedule(static) reduction(+ : contacts, bonds)
    for (long r = 0; r < rows; r++) {
        int k, bonded;
        size_t first = box_row_start(g, &g->box, (size_t)r, &k);
        for (size_t node = first; node < first + length; node++)
            if (nodal_update(s, node, k, start, &bonded)) {
                contacts++;
                bonds += bonded;
            }
    }
    s->contact_node_steps += contacts;
    s->bonded_node_steps += bonds;
}

/* The pairs that meet at one node this step (both flagged in g->contact: in contact, bonded or touching) added to
 * their bodies' interface counts, and those bonded by Eq. 4.7 (pair_bonded) to their bonded counts. */
static void count_interface_pairs(const struct mpm_solver *s, size_t node, int64_t *interface, int64_t *bonded)
{
    const struct mpm_grid *g = &s->grid;
    int a = 0, b = 0;
    double n[3];
    while (next_pair(g, node, &a, &b, n)) {
        size_t Ia = (size_t)a * g->nodes + node, Ib = (size_t)b * g->nodes + node;
        if (!g->contact[Ia] || !g->contact[Ib])
            continue;
        int held = pair_bonded(s, Ia, Ib);
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
#pragma omp parallel for schedule(static) reduction(+ : interface[:nb], bonded[:nb])
    for (long r = 0; r < rows; r++) {
        int k;
        size_t first = box_row_start(g, &g->box, (size_t)r, &k);
        for (size_t node = first; node < first + length; node++)
            if (bodies_at(g, node) > 1)
                count_interface_pairs(s, node, interface, bonded);
    }
}

/* The re-projected momenta at one node (in z plane k). */
static void correct_node(struct mpm_solver *s, size_t node, int k, double *mom)
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
    if (g->layers < 2 || bodies_at(g, node) < 2)
        return;
    if (s->cfg.contact_scheme != MPM_CONTACT_THESIS)
        reproject_node(s, node, mom);
    else
        resolve_node(s, node, NULL, mom, &bonded);
}

/* Over the nodes of this step's stencils, as mpm_contact_nodal_update. */
void mpm_contact_correct_momentum(struct mpm_solver *s, double *mom, int count_nodes)
{
    (void)count_nodes;
    struct mpm_grid *g = &s->grid;
    long rows = (long)box_rows(&g->box);
    size_t length = box_row_length(&g->box);
#pragma omp parallel for schedule(static)
    for (long r = 0; r < rows; r++) {
        int k;
        size_t first = box_row_start(g, &g->box, (size_t)r, &k);
        for (size_t node = first; node < first + length; node++)
            correct_node(s, node, k, mom);
    }
}
