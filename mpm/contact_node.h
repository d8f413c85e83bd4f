/* Module-private (mpm/): the nodal update at one node of the multi-velocity grid (thesis Section 3.4 steps 3-6 and
 * 8: Eq. 3.28, the rigid wall, the fixed bottom, the mirror planes) and its contact and bond decisions and impulses,
 * inline for the host (mpm/contact.c, which has the scheme's notes) and the device (mpm/cuda/step.cu): one copy,
 * as bonding_law.h is one copy of the bonding law.  Every function reads the grid through a struct contact_nodes,
 * the arrays and settings each side fills from its own (contact.c from the solver's grid and configuration,
 * step.cu from the device's arrays); the contact's functions take the momenta they correct as arguments. */
#ifndef SPRAYCOAT_MPM_CONTACT_NODE_H
#define SPRAYCOAT_MPM_CONTACT_NODE_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>

#include "core/fastmath.h" /* SC_HD */
#include "mpm/mpm.h"       /* the schemes' enums */

/* The grid as the contact reads it: per layer entry I = layer * nodes + node (vectors 3 per entry). */
struct contact_nodes {
    const double *mass;          /* nodal mass (Eq. 3.23) */
    double *gradient;            /* sum_p V_p grad N_I(x_p), pointing out of the body (mirror_node zeroes a part) */
    const double *moment;        /* sum_p m_p N_I x_p, the first mass moment (contact_scheme = once) */
    const double *bond_sum;      /* sum of D_bond N over surface points (Eq. 4.6) */
    const double *bond_weight;   /* sum of N over surface points */
    const double *body_velocity; /* 3 per layer: each body's centre-of-mass velocity (bond_growth = approach) */
    uint8_t *contact;            /* per layer entry: the state of its body's last pair at the node (enum pair_state;
                                  * any but FREE: its surface points are in contact for the bonding model) */
    uint64_t *pair_state;        /* per layer entry: 2 bits per partner body b (bits 2b, 2b + 1), the pair's state this
                                  * step (enum pair_state), where layers <= PAIR_STATE_LAYERS (pair_states_kept) */
    uint8_t *bond_contact;       /* 1 where the entry's surface points count as in contact for the bonding model */
    size_t nodes;                /* nodes of a layer */
    int layers;                  /* bodies */
    double mass_cutoff;          /* a layer entry takes part above this mass */
    double h;                    /* cell size */
    int bonding;                 /* enum mpm_bonding */
    int law;                     /* enum mpm_contact_law */
    int scheme;                  /* enum mpm_contact_scheme */
    int approach;                /* enum mpm_contact_approach */
    int growth;                  /* enum mpm_bond_growth */
    double friction, contact_gap, bond_gap;
    /* the nodal update (node_update, node_correct) */
    double *momentum;     /* the start momenta (Eq. 3.25), which the mirror planes and the wall project too */
    double *force;        /* the nodal forces (Eq. 3.27) */
    double *momentum_new; /* the updated momenta (Eq. 3.28) */
    uint8_t *wall_held;   /* per layer entry: held by the rigid wall in this step's update */
    int moments;          /* `moment` is summed (contact_scheme = once with several layers, or the wall) */
    size_t row, plane;    /* nodes along x, and in a z plane: node = i + j row + k plane */
    double origin_z;      /* z of the grid's nodes of plane k = 0 */
    int rigid_wall;       /* [impact] substrate = rigid: a frictionless wall at z = substrate_top */
    int fixed_bottom;     /* no vertical motion at or below z = substrate_bottom (Tang Section 4.3.3) */
    double substrate_top, substrate_bottom;
    int mirror[2];        /* [impact] symmetry: mirror planes x = 0 and y = 0 */
    long mirror_plane[2]; /* their node indices */
};

SC_HD static inline double norm3(const double *a)
{
    return sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
}

/* Nodal bonding parameter of one body, Eq. 4.6.  The equation weights the surface points' D_bond by N but
 * divides by their count, which makes D_bond(I) about D_bond/8 for equal values; the text calls it the
 * arithmetic average.  We take the partition-of-unity average sum(D N)/sum(N), which equals D for equal
 * values (docs/physics.md, "Bonding"). */
SC_HD static inline double nodal_bond(const struct contact_nodes *c, size_t I)
{
    return c->bond_weight[I] > 0.0 ? c->bond_sum[I] / c->bond_weight[I] : 0.0;
}

/* Contact normal at a node between bodies a and b, pointing from a into b: the maximum-volume-gradient rule
 * (Section 3.5.4) takes the body whose volume gradient is larger.  sum_p V_p grad N_I(x_p) is minus the spatial
 * gradient of the body's volume field at the node: it points out of its body. */
SC_HD static inline int contact_normal(const struct contact_nodes *c, size_t Ia, size_t Ib, double n[3])
{
    const double *ga = c->gradient + 3 * Ia, *gb = c->gradient + 3 * Ib;
    double la = norm3(ga), lb = norm3(gb);
    if (la == 0.0 && lb == 0.0)
        return -1;
    for (int d = 0; d < 3; d++)
        n[d] = la >= lb ? ga[d] / la : -gb[d] / lb;
    return 0;
}

/* How a pair of bodies interacts at a node this step, the value stored in c->contact: the re-projection projects
 * CONTACT and BONDED pairs again; TOUCHING (contact_scheme = once: surfaces met, no impulse as the pair is not
 * approaching) is there for the bonding model only, whose surface points in contact (x_p in S, Section 4.1.1) are
 * those of nodes with any state but FREE and with c->bond_contact set (mark_bond_contact). */
enum pair_state { PAIR_FREE, PAIR_CONTACT, PAIR_BONDED, PAIR_TOUCHING };

/* The bodies whose pairs' states fit a layer entry's pair_state bits.  Beyond, a pair is judged by its bodies' flags
 * (c->contact), which at a node of three or more bodies can carry another pair's state. */
#define PAIR_STATE_LAYERS 32

SC_HD static inline int pair_states_kept(const struct contact_nodes *c)
{
    return c->pair_state && c->layers <= PAIR_STATE_LAYERS;
}

SC_HD static inline enum pair_state pair_state_of(const struct contact_nodes *c, size_t Ia, size_t Ib)
{
    return (enum pair_state)((c->pair_state[Ia] >> (2 * (Ib / c->nodes))) & 3u);
}

/* The pair's state at its node, in both entries (Ia / nodes is a's layer). */
SC_HD static inline void pair_state_set(const struct contact_nodes *c, size_t Ia, size_t Ib, enum pair_state state)
{
    if (!pair_states_kept(c))
        return;
    unsigned a = (unsigned)(Ia / c->nodes), b = (unsigned)(Ib / c->nodes);
    c->pair_state[Ia] = (c->pair_state[Ia] & ~((uint64_t)3 << (2 * b))) | ((uint64_t)state << (2 * b));
    c->pair_state[Ib] = (c->pair_state[Ib] & ~((uint64_t)3 << (2 * a))) | ((uint64_t)state << (2 * a));
}

/* The pair's state this step: its own where kept, else as its bodies' flags say (both flagged: the first one's). */
SC_HD static inline enum pair_state pair_state_recorded(const struct contact_nodes *c, size_t Ia, size_t Ib)
{
    if (pair_states_kept(c))
        return pair_state_of(c, Ia, Ib);
    if (!c->contact[Ia] || !c->contact[Ib])
        return PAIR_FREE;
    if (c->contact[Ia] == PAIR_TOUCHING || c->contact[Ib] == PAIR_TOUCHING)
        return PAIR_TOUCHING;
    return c->contact[Ia] == PAIR_BONDED && c->contact[Ib] == PAIR_BONDED ? PAIR_BONDED : PAIR_CONTACT;
}

/* Record the pair's state: the pair's bits, and its bodies' flags. */
SC_HD static inline void record_pair_state(const struct contact_nodes *c, size_t Ia, size_t Ib, enum pair_state state)
{
    c->contact[Ia] = c->contact[Ib] = (uint8_t)state;
    pair_state_set(c, Ia, Ib, state);
}

SC_HD static inline int pair_bonded(const struct contact_nodes *c, size_t Ia, size_t Ib)
{
    return c->bonding != MPM_BONDING_NONE && 0.5 * (nodal_bond(c, Ia) + nodal_bond(c, Ib)) >= 1.0;
}

/* The decision, on the updated momenta: bonded (Eq. 4.7), or approaching along the normal (Eq. 3.29). */
SC_HD static inline enum pair_state pair_decide(const struct contact_nodes *c, size_t Ia, size_t Ib, const double *mom,
                                                const double n[3])
{
    if (pair_bonded(c, Ia, Ib))
        return PAIR_BONDED;
    const double *pa = mom + 3 * Ia, *pb = mom + 3 * Ib;
    double approach = 0.0; /* Eq. 3.29 divided by ma mb */
    for (int d = 0; d < 3; d++)
        approach += (pa[d] / c->mass[Ia] - pb[d] / c->mass[Ib]) * n[d];
    return approach > 0.0 ? PAIR_CONTACT : PAIR_FREE;
}

/* The separation of bodies a and b at the node (m): of their nodal centres of mass along the normal n (from
 * a into b).  Two half-spaces touching with 2 points per cell along n have centres 0.75 to 0.86 cells apart (the
 * surface on a node plane or half-way between), trilinear weights; Nairn's ContactPosition cutoff for uGIMP and 2
 * points a cell is 0.8. */
SC_HD static inline double pair_separation(const struct contact_nodes *c, size_t Ia, size_t Ib, const double n[3])
{
    const double *xa = c->moment + 3 * Ia, *xb = c->moment + 3 * Ib;
    double separation = 0.0;
    for (int d = 0; d < 3; d++)
        separation += (xb[d] / c->mass[Ib] - xa[d] / c->mass[Ia]) * n[d];
    return separation;
}

/* Whether the surfaces of bodies a and b meet at the node (contact_scheme = once): their separation is at most
 * contact_gap cells. */
SC_HD static inline int surfaces_meet(const struct contact_nodes *c, size_t Ia, size_t Ib, const double n[3])
{
    return pair_separation(c, Ia, Ib, n) <= c->contact_gap * c->h;
}

/* Whether a bonded pair holds at the node (contact_scheme = once): bonded (Eq. 4.7) and, unless bond_gap is 0,
 * its surfaces still meet (separation at most bond_gap cells).  Without that test a bond pulls wherever both
 * bodies have mass at a node, up to a cell across a gap: a 14 um particle leaving the substrate at 20 m/s with
 * PBCP 1.4 % was pulled back over 130 ns by nodes it no longer touched and never settled (docs/physics.md,
 * "Contact"). */
SC_HD static inline int bond_holds(const struct contact_nodes *c, size_t Ia, size_t Ib, const double n[3])
{
    if (!pair_bonded(c, Ia, Ib))
        return 0;
    return c->bond_gap == 0.0 || pair_separation(c, Ia, Ib, n) <= c->bond_gap * c->h;
}

/* Whether the pair approaches in the momenta `mom` (contact_scheme = once): along the common normal n (Eq. 3.29)
 * and, with contact_approach = both, along each body's own normal as well, its volume gradient (a from a into b, b
 * from b into a: Bardenhagen et al. 2000 test each body on its own normal; a body without a gradient at the node
 * has no say).  The common normal is the steeper of the two gradients (mpm_contact_normal); where a body's corner
 * meets the other's face it is the corner's, tilted off the face, and motion along the face - the rim of a
 * flattened particle rising past the crater's wall, a block sliding on a block - approaches along it though not
 * along the face's own normal: a 30 um particle rebounding at 15 m/s without any bond was braked to rest by such
 * nodes at 10 cells across (docs/physics.md, "Contact"). */
SC_HD static inline int approaching(const struct contact_nodes *c, size_t Ia, size_t Ib, const double *mom,
                                    const double n[3])
{
    const double *ga = c->gradient + 3 * Ia, *gb = c->gradient + 3 * Ib;
    double along_common = 0.0, along_a = 0.0, along_b = 0.0;
    for (int d = 0; d < 3; d++) {
        double dv = mom[3 * Ia + d] / c->mass[Ia] - mom[3 * Ib + d] / c->mass[Ib];
        along_common += dv * n[d];
        along_a += dv * ga[d];
        along_b -= dv * gb[d];
    }
    if (!(along_common > 0.0))
        return 0;
    if (c->approach == MPM_APPROACH_COMMON)
        return 1;
    return (along_a > 0.0 || norm3(ga) == 0.0) && (along_b > 0.0 || norm3(gb) == 0.0);
}

/* The one decision of contact_scheme = once, on the updated momenta: bonded while not approaching with the surfaces
 * met, in contact while approaching with the surfaces met. */
SC_HD static inline enum pair_state pair_decide_once(const struct contact_nodes *c, size_t Ia, size_t Ib,
                                                     const double *mom, const double n[3])
{
    if (!approaching(c, Ia, Ib, mom, n))
        return bond_holds(c, Ia, Ib, n) ? PAIR_BONDED : PAIR_FREE;
    return surfaces_meet(c, Ia, Ib, n) ? PAIR_CONTACT : PAIR_FREE;
}

/* The impulse on body a (body b receives its opposite) that the contact rule gives for the momenta `mom`. */
SC_HD static inline void pair_impulse(const struct contact_nodes *c, size_t Ia, size_t Ib, const double *mom,
                                      const double n[3], enum pair_state state, double J[3])
{
    double ma = c->mass[Ia], mb = c->mass[Ib];
    const double *pa = mom + 3 * Ia, *pb = mom + 3 * Ib;
    for (int d = 0; d < 3; d++) /* Eq. 3.31 times dt: both bodies move with their common velocity */
        J[d] = (ma * pb[d] - mb * pa[d]) / (ma + mb);
    if (state == PAIR_BONDED || c->law == MPM_CONTACT_STICK)
        return;
    double Jn = J[0] * n[0] + J[1] * n[1] + J[2] * n[2];
    double Jt[3], Jt_norm;
    for (int d = 0; d < 3; d++)
        Jt[d] = J[d] - Jn * n[d];
    Jt_norm = norm3(Jt);
    double scale = 0.0; /* frictionless: the normal part only */
    if (c->law == MPM_CONTACT_FRICTION && Jt_norm > 0.0)
        scale = fmin(1.0, c->friction * fabs(Jn) / Jt_norm);
    for (int d = 0; d < 3; d++)
        J[d] = Jn * n[d] + scale * Jt[d];
}

SC_HD static inline void apply_impulse(double *mom, size_t Ia, size_t Ib, const double J[3])
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
SC_HD static inline int bonds_grow(const struct contact_nodes *c, size_t Ia, size_t Ib, const double n[3])
{
    if (c->growth == MPM_GROWTH_CONTACT || c->scheme != MPM_CONTACT_ONCE)
        return 1;
    const double *va = c->body_velocity + 3 * (Ia / c->nodes), *vb = c->body_velocity + 3 * (Ib / c->nodes);
    double approach = 0.0;
    for (int d = 0; d < 3; d++)
        approach += (va[d] - vb[d]) * n[d];
    return approach > 0.0;
}

/* The pair interacts at its node: its surface points count for the bonding model where it is pressed together (a
 * contact impulse this step) or bonds_grow says so. */
SC_HD static inline void mark_bond_contact(const struct contact_nodes *c, size_t Ia, size_t Ib, const double n[3],
                                           int pressed)
{
    if (pressed || bonds_grow(c, Ia, Ib, n))
        c->bond_contact[Ia] = c->bond_contact[Ib] = 1;
}

/* Mark a pair touching at its node (surfaces met, no impulse in the updated momenta: for the bonding model only)
 * unless it is marked already; pressed: the first correction gave it a contact impulse. */
SC_HD static inline void mark_touching(const struct contact_nodes *c, size_t Ia, size_t Ib, const double n[3],
                                       int pressed)
{
    c->contact[Ia] = c->contact[Ia] ? c->contact[Ia] : (uint8_t)PAIR_TOUCHING;
    c->contact[Ib] = c->contact[Ib] ? c->contact[Ib] : (uint8_t)PAIR_TOUCHING;
    if (pair_states_kept(c) && pair_state_of(c, Ia, Ib) == PAIR_FREE)
        pair_state_set(c, Ia, Ib, PAIR_TOUCHING);
    mark_bond_contact(c, Ia, Ib, n, pressed);
}

/* contact_scheme = once, the first of its two corrections (Nairn, Hammerquist & Smith 2020): on the start momenta,
 * where the pair approaches in them and the surfaces meet.  The updated momenta take the same impulse, as if
 * they had been computed from the corrected start momenta (end = start' + f dt).  The pair is marked touching
 * (for the bonding model) unless the second correction decides more.  Returns whether it projected, and J, the
 * impulse on body a (left unchanged where it did not project). */
SC_HD static inline int first_correction(const struct contact_nodes *c, size_t Ia, size_t Ib, double *start,
                                         double *end, const double n[3], double J[3])
{
    if (pair_decide_once(c, Ia, Ib, start, n) != PAIR_CONTACT)
        return 0;
    pair_impulse(c, Ia, Ib, start, n, PAIR_CONTACT, J);
    apply_impulse(start, Ia, Ib, J);
    apply_impulse(end, Ia, Ib, J);
    mark_touching(c, Ia, Ib, n, 1);
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
SC_HD static inline enum pair_state decide_after_correction(const struct contact_nodes *c, size_t Ia, size_t Ib,
                                                            const double *start, const double *end, const double n[3])
{
    double along = 0.0;
    for (int d = 0; d < 3; d++)
        along += ((end[3 * Ia + d] - start[3 * Ia + d]) / c->mass[Ia] -
                  (end[3 * Ib + d] - start[3 * Ib + d]) / c->mass[Ib]) *
                 n[d];
    if (!(along < 0.0))
        return PAIR_CONTACT;
    return bond_holds(c, Ia, Ib, n) ? PAIR_BONDED : PAIR_FREE;
}

SC_HD static inline int bodies_at(const struct contact_nodes *c, size_t node)
{
    int count = 0;
    for (int l = 0; l < c->layers; l++)
        count += c->mass[(size_t)l * c->nodes + node] > c->mass_cutoff;
    return count;
}

/* The pair (Ia, Ib) at its node, with normal n from a into b, decided on the momenta `end` and projected there.
 * The start momenta `start` (unless NULL): consistent applies the same impulse to them; once corrects them first
 * on their own decision (first_correction), and where it projected decides on how `end` changed from the corrected
 * start momenta (decide_after_correction).  The pair's bodies are flagged (c->contact) for the re-projection and
 * the bonding model.  Returns its state; *corrected whether the first correction projected; Js and Je the
 * impulses on body a of the first and the second correction (0 where none). */
SC_HD static inline enum pair_state resolve_pair(const struct contact_nodes *c, size_t Ia, size_t Ib, const double n[3],
                                                 double *start, double *end, int *corrected, double Js[3], double Je[3])
{
    int once = c->scheme == MPM_CONTACT_ONCE;
    for (int d = 0; d < 3; d++)
        Js[d] = Je[d] = 0.0;
    *corrected = once && start && first_correction(c, Ia, Ib, start, end, n, Js);
    enum pair_state state = *corrected ? decide_after_correction(c, Ia, Ib, start, end, n)
                            : once     ? pair_decide_once(c, Ia, Ib, end, n)
                                       : pair_decide(c, Ia, Ib, end, n);
    if (state == PAIR_FREE) {
        if (once && surfaces_meet(c, Ia, Ib, n))
            mark_touching(c, Ia, Ib, n, 0);
        return PAIR_FREE;
    }
    pair_impulse(c, Ia, Ib, end, n, state, Je);
    apply_impulse(end, Ia, Ib, Je);
    if (start && !once) {
        double J[3];
        pair_impulse(c, Ia, Ib, start, n, state, J);
        apply_impulse(start, Ia, Ib, J);
    }
    record_pair_state(c, Ia, Ib, state);
    mark_bond_contact(c, Ia, Ib, n, state == PAIR_CONTACT);
    return state;
}

/* The pairs at a node in layer order: the next pair (a, b), b > a, after (*a, *b) (start from 0, 0) whose bodies both
 * have mass at the node and whose contact normal n is defined; 0 when none is left. */
SC_HD static inline int next_pair(const struct contact_nodes *c, size_t node, int *a, int *b, double n[3])
{
    for (; *a < c->layers; (*a)++, *b = *a) {
        size_t Ia = (size_t)*a * c->nodes + node;
        if (!(c->mass[Ia] > c->mass_cutoff))
            continue;
        while (++*b < c->layers) {
            size_t Ib = (size_t)*b * c->nodes + node;
            if (c->mass[Ib] > c->mass_cutoff && contact_normal(c, Ia, Ib, n) == 0)
                return 1;
        }
    }
    return 0;
}

/* Every pair at the node once, one after the other in layer order (resolve_pair).  Returns whether any pair
 * interacted; *bonded whether one was bonded. */
SC_HD static inline int sweep_pairs(const struct contact_nodes *c, size_t node, double *start, double *end, int *bonded)
{
    int touched = 0;
    double n[3], Js[3], Je[3];
    for (int a = 0, b = 0; next_pair(c, node, &a, &b, n);) {
        int corrected;
        size_t Ia = (size_t)a * c->nodes + node, Ib = (size_t)b * c->nodes + node;
        enum pair_state state = resolve_pair(c, Ia, Ib, n, start, end, &corrected, Js, Je);
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
SC_HD static inline int node_pairs(const struct contact_nodes *c, size_t node, struct node_pair *pairs)
{
    int count = 0;
    double n[3];
    for (int a = 0, b = 0; next_pair(c, node, &a, &b, n); count++) {
        if (count == MAX_NODE_PAIRS)
            return -1;
        struct node_pair *p = pairs + count;
        p->Ia = (size_t)a * c->nodes + node, p->Ib = (size_t)b * c->nodes + node;
        p->state = PAIR_FREE, p->corrected = 0;
        for (int d = 0; d < 3; d++)
            p->n[d] = n[d], p->start_impulse[d] = p->end_impulse[d] = 0.0;
    }
    return count;
}

SC_HD static inline void add3(double *sum, const double *v)
{
    for (int d = 0; d < 3; d++)
        sum[d] += v[d];
}

/* Projected Gauss-Seidel's clamp: a pair in contact only pushes, and with friction its tangential impulse stays
 * within the Coulomb cone.  J is the next impulse on body a, `sum` what the pair has given a so far; where sum + J
 * would pull a towards b along n (from a into b), J takes back all of it; where its tangential part exceeds friction
 * times its normal part (each sweep's impulse is within the cone, but normal parts of the sweeps can cancel where
 * tangential ones add up), the sum's tangential part is scaled to the cone. */
SC_HD static inline void only_push(const struct contact_nodes *c, const double sum[3], const double n[3], double J[3])
{
    double total[3], normal = 0.0;
    for (int d = 0; d < 3; d++)
        total[d] = sum[d] + J[d], normal += total[d] * n[d];
    if (normal > 0.0) {
        for (int d = 0; d < 3; d++)
            J[d] = -sum[d];
        return;
    }
    if (c->law != MPM_CONTACT_FRICTION) /* frictionless: normal impulses alone; stick: no limit */
        return;
    double tangential[3];
    for (int d = 0; d < 3; d++)
        tangential[d] = total[d] - normal * n[d];
    double size = norm3(tangential), limit = c->friction * -normal;
    if (!(size > limit))
        return;
    for (int d = 0; d < 3; d++)
        J[d] = normal * n[d] + tangential[d] * (limit / size) - sum[d];
}

/* The start half of project_again: the first correction projected again on the start momenta (and the end
 * momenta take the same impulse), held to pushing.  Returns the size of the impulse. */
SC_HD static inline double correct_start_again(const struct contact_nodes *c, struct node_pair *p, double *start,
                                               double *end)
{
    double J[3];
    pair_impulse(c, p->Ia, p->Ib, start, p->n, PAIR_CONTACT, J);
    only_push(c, p->start_impulse, p->n, J);
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
SC_HD static inline double project_again(const struct contact_nodes *c, struct node_pair *p, double *start, double *end,
                                         int *bonded)
{
    double J[3], moved = p->corrected ? correct_start_again(c, p, start, end) : 0.0;
    if (p->state == PAIR_FREE) {
        p->state = decide_after_correction(c, p->Ia, p->Ib, start, end, p->n);
        if (p->state == PAIR_FREE)
            return moved;
        record_pair_state(c, p->Ia, p->Ib, p->state);
        mark_bond_contact(c, p->Ia, p->Ib, p->n, p->state == PAIR_CONTACT);
    }
    pair_impulse(c, p->Ia, p->Ib, end, p->n, p->state, J);
    if (p->state == PAIR_CONTACT)
        only_push(c, p->end_impulse, p->n, J);
    apply_impulse(end, p->Ia, p->Ib, J);
    add3(p->end_impulse, J);
    *bonded |= p->state == PAIR_BONDED;
    return moved + norm3(J);
}

/* The sum of the sizes of the node's momenta: the scale of the sweeps' stopping test. */
SC_HD static inline double node_momentum(const struct contact_nodes *c, size_t node, const double *mom)
{
    double sum = 0.0;
    for (int l = 0; l < c->layers; l++)
        sum += norm3(mom + 3 * ((size_t)l * c->nodes + node));
    return sum;
}

/* contact_scheme = once where three or more bodies meet at the node.  One sweep in layer order favours the body
 * listed first: each pair's impulse changes the momenta the next pair is decided on, and a pair decided early is
 * not revisited (two elastic boxes side by side on an elastic block left at 12.61 and 12.28 m/s, and at 12.15 and
 * 12.59 with the bodies' rows swapped).  So the sweeps repeat until their impulses vanish, as the nonlinear
 * Gauss-Seidel of non-smooth contact dynamics does (Jean 1999): a pair not yet corrected or in contact is decided
 * afresh (resolve_pair); one that is, is projected again (project_again) with each correction's summed impulse held
 * to pushing.  The limit is the node's contact problem solved: every pair in contact moves with a common normal
 * velocity (all of it, stick) and pushes, its tangential impulse within the Coulomb cone with friction, whatever the
 * order (docs/physics.md "Three or more bodies at a node").  The pairs and their summed impulses are left in
 * pairs[*pair_count].  MAX_SWEEPS ends a node whose decisions keep changing without a message (none did in the tests).
 */
SC_HD static inline int resolve_bodies_pairs(const struct contact_nodes *c, size_t node, double *start, double *end,
                                             int *bonded, struct node_pair *pairs, int *pair_count)
{
    int count = node_pairs(c, node, pairs), touched = 0;
    *pair_count = count;
    if (count < 0)
        return sweep_pairs(c, node, start, end, bonded);
    for (int k = 0; k < MAX_SWEEPS; k++) {
        double moved = 0.0;
        for (int i = 0; i < count; i++) {
            struct node_pair *p = pairs + i;
            if (p->state != PAIR_FREE || p->corrected) {
                moved += project_again(c, p, start, end, bonded);
                continue;
            }
            double Js[3], Je[3];
            int corrected;
            p->state = resolve_pair(c, p->Ia, p->Ib, p->n, start, end, &corrected, Js, Je);
            p->corrected = corrected;
            add3(p->start_impulse, Js);
            add3(p->end_impulse, Je);
            moved += norm3(Js) + norm3(Je);
            touched |= corrected || p->state != PAIR_FREE;
            *bonded |= p->state == PAIR_BONDED;
        }
        if (!(moved > SWEEP_TOLERANCE * node_momentum(c, node, end)))
            break;
    }
    return touched;
}

/* resolve_bodies_pairs, its pairs (their summed impulses: tests/test_mpm_contact.c) not kept. */
SC_HD static inline int resolve_bodies(const struct contact_nodes *c, size_t node, double *start, double *end,
                                       int *bonded)
{
    struct node_pair pairs[MAX_NODE_PAIRS];
    int count;
    return resolve_bodies_pairs(c, node, start, end, bonded, pairs, &count);
}

/* Contact and bond impulses at node `node`: one sweep over its pairs where two bodies meet (or with the schemes
 * kept for comparison), resolve_bodies where three or more do (contact_scheme = once).  Returns whether any pair
 * interacted; *bonded whether one was bonded. */
SC_HD static inline int resolve_node(const struct contact_nodes *c, size_t node, double *start, double *end,
                                     int *bonded)
{
    *bonded = 0;
    if (c->scheme == MPM_CONTACT_ONCE && start && bodies_at(c, node) > 2)
        return resolve_bodies(c, node, start, end, bonded);
    return sweep_pairs(c, node, start, end, bonded);
}

/* How the re-projection treats the pair (Ia, Ib): as the nodal update decided it where both bodies were flagged
 * there (PAIR_BONDED or PAIR_CONTACT), PAIR_FREE (no impulse) where either was not or only touched. */
SC_HD static inline enum pair_state reprojected_state(const struct contact_nodes *c, size_t Ia, size_t Ib)
{
    enum pair_state state = pair_state_recorded(c, Ia, Ib);
    if (state == PAIR_FREE || state == PAIR_TOUCHING)
        return PAIR_FREE;
    if (c->scheme == MPM_CONTACT_ONCE)
        return state;
    return pair_bonded(c, Ia, Ib) ? PAIR_BONDED : PAIR_CONTACT;
}

/* contact_scheme = consistent or once, the MUSL re-projected momenta: the pairs in contact in this step's nodal
 * update (both bodies flagged) are projected again without a new test, so that the strain rate is that of the
 * motion the points made; once projects a pair as it was decided (bonded or in contact).  One sweep over the node's
 * pairs, as at a node of two bodies. */
SC_HD static inline void reproject_sweep(const struct contact_nodes *c, size_t node, double *mom)
{
    for (int a = 0; a < c->layers; a++) {
        size_t Ia = (size_t)a * c->nodes + node;
        if (!(c->mass[Ia] > c->mass_cutoff) || !c->contact[Ia])
            continue;
        for (int b = a + 1; b < c->layers; b++) {
            size_t Ib = (size_t)b * c->nodes + node;
            double n[3], J[3];
            if (!(c->mass[Ib] > c->mass_cutoff) || !c->contact[Ib] || contact_normal(c, Ia, Ib, n) != 0)
                continue;
            enum pair_state state = reprojected_state(c, Ia, Ib);
            if (state == PAIR_FREE)
                continue; /* no impulse this step */
            pair_impulse(c, Ia, Ib, mom, n, state, J);
            apply_impulse(mom, Ia, Ib, J);
        }
    }
}

/* The re-projection where three or more bodies meet (contact_scheme = once): each pair as the nodal update decided
 * it (its pair_state bits), swept until the impulses vanish with each pair's summed impulse held to pushing where it
 * is in contact, as in the nodal update (resolve_bodies): no order enters, and no pair that the update left apart is
 * tied together.  Beyond PAIR_STATE_LAYERS bodies the flags are the bodies', not the pairs' (two bodies that each
 * touched a third are both flagged, in contact with each other or not): only the flagged pairs whose surfaces meet
 * (surfaces_meet) take part there. */
SC_HD static inline void reproject_bodies(const struct contact_nodes *c, size_t node, double *mom)
{
    struct node_pair pairs[MAX_NODE_PAIRS];
    int count = node_pairs(c, node, pairs), kept = 0;
    if (count < 0) {
        reproject_sweep(c, node, mom);
        return;
    }
    for (int i = 0; i < count; i++) {
        struct node_pair p = pairs[i];
        p.state = reprojected_state(c, p.Ia, p.Ib);
        /* as the update decided the pair; from its bodies' flags, only where its surfaces meet */
        if (p.state != PAIR_FREE && (pair_states_kept(c) || surfaces_meet(c, p.Ia, p.Ib, p.n)))
            pairs[kept++] = p;
    }
    for (int k = 0; k < MAX_SWEEPS; k++) {
        double moved = 0.0, J[3];
        for (int i = 0; i < kept; i++) {
            struct node_pair *p = pairs + i;
            pair_impulse(c, p->Ia, p->Ib, mom, p->n, p->state, J);
            if (p->state == PAIR_CONTACT)
                only_push(c, p->end_impulse, p->n, J);
            apply_impulse(mom, p->Ia, p->Ib, J);
            add3(p->end_impulse, J);
            moved += norm3(J);
        }
        if (!(moved > SWEEP_TOLERANCE * node_momentum(c, node, mom)))
            break;
    }
}

SC_HD static inline void reproject_node(const struct contact_nodes *c, size_t node, double *mom)
{
    if (c->scheme == MPM_CONTACT_ONCE && bodies_at(c, node) > 2)
        reproject_bodies(c, node, mom);
    else
        reproject_sweep(c, node, mom);
}

/* ---- the nodal update at one node: Eq. 3.28 and the boundaries around the contact ---- */

SC_HD static inline int heavy_entry(const struct contact_nodes *c, size_t I)
{
    return c->mass[I] > c->mass_cutoff;
}

/* A rigid frictionless wall at the substrate's top, z = substrate_top.  A node at or below it whose updated
 * momentum heads into the wall is held there this step: its normal (z) momentum is 0 in the updated momenta (the
 * motion of the points), in the start momenta (the FLIP reference of the points' velocity change) and in the
 * re-projected momenta (the strain rate), the same projection in all three, as contact_scheme = consistent does
 * for a pair of bodies.  Clamping only the updated momenta, and the re-projected ones only where they head into
 * the wall, let the strain rate at a held node follow a motion the points did not make: an elastic sphere dropped
 * onto the wall from 2 um left it 23 % more energetic (at cfl 0.1; the gain grew with dt), against 0.1 % now
 * (tests/test_mpm_solver.c). */
SC_HD static inline int below_wall(const struct contact_nodes *c, int k)
{
    return c->origin_z + (double)k * c->h <= c->substrate_top + 1e-9 * c->h;
}

/* contact_scheme = once: whether body layer I's surface meets the wall at its node, the wall taken as a body whose
 * nodal centre of mass lies as far below the wall as the body's lies above it at touching: the body's centre of
 * mass at the node at most contact_gap / 2 cells above the wall (surfaces_meet). */
SC_HD static inline int wall_meets(const struct contact_nodes *c, size_t I)
{
    if (!c->moments)
        return 1;
    return c->moment[3 * I + 2] / c->mass[I] - c->substrate_top <= 0.5 * c->contact_gap * c->h;
}

/* The nodal update's side of the wall: decide which layers of the node are held, and project. */
SC_HD static inline void rigid_wall_hold(const struct contact_nodes *c, size_t node, int k)
{
    int at_wall = below_wall(c, k);
    for (int l = 0; l < c->layers; l++) {
        size_t I = (size_t)l * c->nodes + node;
        int held = at_wall && c->momentum_new[3 * I + 2] < 0.0 && wall_meets(c, I);
        c->wall_held[I] = (uint8_t)held;
        if (held)
            c->momentum_new[3 * I + 2] = c->momentum[3 * I + 2] = 0.0;
    }
}

/* The re-projection's side: the nodes held in this step's update, and only those, are held again. */
SC_HD static inline void rigid_wall_reproject(const struct contact_nodes *c, size_t node, double *mom)
{
    for (int l = 0; l < c->layers; l++) {
        size_t I = (size_t)l * c->nodes + node;
        if (c->wall_held[I])
            mom[3 * I + 2] = 0.0;
    }
}

/* Tang Section 4.3.3: the substrate's "bottom surface is bound vertically by the computational grid": no vertical
 * nodal velocity at or below its bottom face.  Without it a thin substrate under a large particle is pushed away
 * as a whole and its residual stress makes it creep on the dashpots. */
SC_HD static inline void fixed_bottom(const struct contact_nodes *c, size_t node, int k, double *mom)
{
    double z = c->origin_z + (double)k * c->h;
    if (z > c->substrate_bottom + 1e-9 * c->h)
        return;
    for (int l = 0; l < c->layers; l++)
        mom[3 * ((size_t)l * c->nodes + node) + 2] = 0.0;
}

/* [impact] symmetry: at a node on a mirror plane the whole set-up's fields are those of the modelled side doubled,
 * with no component across the plane (the mirror images' cancel), and with trilinear weights no other node sees the
 * images (mpm/params.c load_symmetry): zeroing the component across the plane of each vector field, and leaving
 * the rest halved, gives the same velocities, normals and impulses (docs/physics.md "Mirror symmetry"). */
SC_HD static inline void mirror_node(const struct contact_nodes *c, size_t node, double *const *fields, int count)
{
    long at[2] = {(long)(node % c->row), (long)(node % c->plane / c->row)};
    for (int d = 0; d < 2; d++) {
        if (!c->mirror[d] || at[d] != c->mirror_plane[d])
            continue;
        for (int l = 0; l < c->layers; l++)
            for (int f = 0; f < count; f++)
                fields[f][3 * ((size_t)l * c->nodes + node) + (size_t)d] = 0.0;
    }
}

/* [impact] symmetry: the nodes of the whole set-up that this node of the modelled part stands for: itself and its
 * image across each mirror plane it is not on (1, 2 or 4).  Counts of nodes (the bonded interface) are weighted by
 * it; counts of points need no weight (no point lies on a plane, each stands for `copies` points). */
SC_HD static inline int mirror_node_copies(const struct contact_nodes *c, size_t node)
{
    long at[2] = {(long)(node % c->row), (long)(node % c->plane / c->row)};
    int copies = 1;
    for (int d = 0; d < 2; d++)
        if (c->mirror[d] && at[d] != c->mirror_plane[d])
            copies *= 2;
    return copies;
}

/* Steps 3-6 at one node (in z plane k): the mirror planes, Eq. 3.28, the wall or the fixed bottom, contact and
 * bonds (resolve_node, on the start momenta too but with contact_scheme = thesis).  Returns whether a pair
 * interacted, *bonded whether one was bonded. */
SC_HD static inline int node_update(const struct contact_nodes *c, size_t node, int k, double dt, int *bonded)
{
    if (c->mirror[0] || c->mirror[1]) {
        double *fields[3] = {c->momentum, c->force, c->gradient};
        mirror_node(c, node, fields, 3);
    }
    for (int l = 0; l < c->layers; l++) { /* Eq. 3.28 */
        size_t I = (size_t)l * c->nodes + node;
        int heavy = heavy_entry(c, I);
        for (int d = 0; d < 3; d++)
            c->momentum_new[3 * I + d] = heavy ? c->momentum[3 * I + d] + c->force[3 * I + d] * dt : 0.0;
    }
    if (c->rigid_wall)
        rigid_wall_hold(c, node, k);
    else if (c->fixed_bottom)
        fixed_bottom(c, node, k, c->momentum_new);
    *bonded = 0;
    if (c->layers < 2 || bodies_at(c, node) < 2)
        return 0;
    double *start = c->scheme != MPM_CONTACT_THESIS ? c->momentum : NULL;
    return resolve_node(c, node, start, c->momentum_new, bonded);
}

/* Step 8 at one node (in z plane k): the re-projected momenta `mom` with the light entries emptied, the mirror
 * planes, the wall's hold or the fixed bottom, and the contact again (reproject_node; contact_scheme = thesis
 * decides anew). */
SC_HD static inline void node_correct(const struct contact_nodes *c, size_t node, int k, double *mom)
{
    for (int l = 0; l < c->layers; l++) {
        size_t I = (size_t)l * c->nodes + node;
        if (!heavy_entry(c, I))
            mom[3 * I] = mom[3 * I + 1] = mom[3 * I + 2] = 0.0;
    }
    if (c->mirror[0] || c->mirror[1])
        mirror_node(c, node, &mom, 1);
    if (c->rigid_wall)
        rigid_wall_reproject(c, node, mom);
    else if (c->fixed_bottom)
        fixed_bottom(c, node, k, mom);
    if (c->layers < 2 || bodies_at(c, node) < 2)
        return;
    int bonded;
    if (c->scheme != MPM_CONTACT_THESIS)
        reproject_node(c, node, mom);
    else
        resolve_node(c, node, NULL, mom, &bonded);
}

#endif
