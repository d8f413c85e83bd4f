/* mpm internals shared by the files of the module (not part of the API). */
#ifndef SPRAYCOAT_MPM_IMPL_H
#define SPRAYCOAT_MPM_IMPL_H

#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>

#include "core/balance.h"
#include "mpm/boundary_point.h"
#include "mpm/material.h"
#include "mpm/mpm.h"

enum point_flags {
    POINT_ACTIVE = 1,   /* inside the grid box; removed points keep their slot with this bit cleared */
    POINT_SURFACE = 2,  /* on its body's surface at set-up (a lattice neighbour lies outside the body) */
    POINT_BOTTOM = 4,   /* substrate point on the bottom face: absorbing boundary */
    POINT_SIDE = 8,     /* substrate point on a side face: absorbing boundary, outward normal in `normal` */
    POINT_CONTACT = 16, /* surface point touching another body this step (x_p in S of Section 4.1.1) */
};

/* Material points, structure of arrays.  The arrays are stored in a spatial order (point_order.c) that changes
 * during a run; id[q] is the point's place in the set-up order (its identity: outputs, checkpoints and every
 * sum over points use that order) and slot[i] where point i is stored. */
struct mpm_points {
    size_t count;
    uint32_t *id, *slot;
    double *x, *v;  /* 3 per point */
    double *x_next; /* 3 per point: positions at the end of the step (swapped with x) */
    double *mass, *volume0, *volume;
    double *d_bond;       /* bonding parameter D_bond (Eq. 4.16a / 4.5) */
    double *plastic_work; /* J, accumulated: Eq. 4.15 times the volume */
    double *normal;       /* 3 per point: outward normal of a side face (POINT_SIDE) */
    struct mpm_point_state *state;
    int32_t *body;
    uint8_t *flags;
    double *affine; /* 9 per point: APIC's C_p, row-major (transfer = apic; NULL with flip) */
};

/* Shape-function stencil of one point: width nodes per direction from base. */
struct stencil {
    int base[3];
    int width;
    size_t node;             /* mpm_grid_node of base: node (a, b, c) of the stencil is node + a + b n0 + c n0 n1 */
    double w[3][3], g[3][3]; /* per-direction weights and their derivatives */
};

/* A box of grid nodes, lo[d] .. hi[d] inclusive (empty when lo[0] > hi[0]), walked in rows along x. */
struct node_box {
    int lo[3], hi[3];
};

/* calloc on a 64-byte boundary (cache line, AVX-512 vector): the point and node arrays' vector loads and stores
 * then never straddle two lines (free() releases it).  Arrays of 4 MB or more go on 2 MB boundaries, rounded up
 * to 2 MB, in transparent huge pages where the system offers them (madvise: the mode of Debian's kernels): the
 * transfers reach points and nodes all over such arrays, and with 4 kB pages the 1e6-point impact took 128,000
 * page faults and many TLB misses (about 34,000 faults with huge pages, wall time -25 %, memory +6 %). */
#define MPM_HUGE_PAGE ((size_t)2 << 20)
static inline void *mpm_calloc_lines(size_t count, size_t size)
{
    if (size > 0 && count > (SIZE_MAX - MPM_HUGE_PAGE) / size)
        return NULL; /* as calloc: no product that wraps around */
    size_t bytes = count * size;
    int huge = bytes >= 2 * MPM_HUGE_PAGE;
    size_t align = huge ? MPM_HUGE_PAGE : 64;
    bytes = (bytes + align - 1) / align * align;
    void *block = aligned_alloc(align, bytes ? bytes : 64);
    if (!block)
        return NULL;
#ifdef MADV_HUGEPAGE
    if (huge)
        madvise(block, bytes, MADV_HUGEPAGE); /* a hint: where it fails the pages stay small */
#endif
    memset(block, 0, bytes);
    return block;
}

/* The background grid: uniform, one layer of nodal fields per body (the multi-mesh of Ma et al.), and the
 * blocks of cells used for the fixed-order particle-to-grid transfer. */
struct mpm_grid {
    double origin[3], h;
    double inv_h;                        /* 1 / h: the trilinear weight gradient, +-1/h (divided once, same bits) */
    double inside_from[3], inside_to[3]; /* grid_contains: the offsets x - origin it accepts, [from, to) */
    int n[3];
    size_t row, plane; /* n[0] and n[0] n[1]: the index steps in y and z (stencil_node) */
    size_t nodes;
    int layers;
    double mass_cutoff;                                        /* nodes lighter than this carry no velocity */
    double *mass, *momentum, *momentum_new, *force, *gradient; /* per layer; vectors 3 per node */
    /* per layer, 3 per node: sum_p m_p N_Ip x_p, the first mass moment, whose quotient by the mass is the body's
     * centre of mass seen from the node (the contact gap test, contact.c); filled only where `moments` (several
     * layers or the rigid wall, with contact_scheme = once) */
    double *moment;
    int moments;
    double *velocity;               /* per layer, 3 per node: momentum_new / mass after the re-projection */
    double *bond_sum, *bond_weight; /* per layer: sum of D N and of N over surface points (Eq. 4.6) */
    uint8_t *contact;               /* per layer: 1 where a contact or bond force acted this step */
    uint64_t *pair_state;           /* per layer, with 3 to 32 bodies: each pair's state this step (contact_node.h
                                     * pair_state; NULL otherwise: a node of two bodies has one pair, its flags') */
    uint8_t *bond_contact;          /* per layer: 1 where the node's surface points count for D_bond (contact.c) */
    uint8_t *wall_held;             /* per layer, substrate = rigid: 1 where the wall held the node this step */
    double *body_velocity;          /* 3 per layer: the body's centre-of-mass velocity this step (contact.c) */
    long mirror_plane[2];           /* [impact] symmetry: the x and y node indices of the planes x = 0, y = 0 */
    /* The nodes of this step's stencils lie in `box` (all layers; mpm_grid_bin_points): the nodal loops run over it
     * alone, which leaves every nodal field 0 outside it, as a loop over the whole grid would; `held` is the box
     * of the fields' last step, the only nodes that mpm_grid_transfer_all has to clear (the whole grid at first). */
    struct node_box box, held;
    /* blocks of 2^block_shift cells a side (alloc_blocks); points sorted by block every step */
    int block_shift;
    int blocks[3];
    size_t block_count;
    size_t *block_start;      /* block_count + 1 */
    size_t *block_points;     /* point indices, by block, ascending within a block */
    size_t *block_cursor;     /* sort_threads x block_count: mpm_grid_bin_points' counts and write cursors */
    int sort_threads;         /* rows of block_cursor: the most threads mpm_grid_bin_points sorts with */
    size_t *colour_blocks[8]; /* the blocks of each colour, ascending */
    size_t colour_count[8];
    size_t *colour_points[8];            /* colour_count + 1 each: the points in the colour's blocks before each */
    struct balance colour_balance[2][8]; /* the threads' shares of each colour's points, per kind of transfer */
    int *point_block;                    /* block of each point this step (-1 inactive) */
    /* trilinear stencils of this step, cached by mpm_grid_bin_points (the positions stay until the step's end) */
    uint32_t *point_node;   /* base node of each active point (nodes < 2^31, mpm_grid_create) */
    double *point_fraction; /* 3 per point: x/h - base, the weights being 1 - f and f (Eq. 3.20) */
};

struct series_row;

struct mpm_solver {
    struct mpm_config cfg;
    struct mpm_points points;
    struct mpm_grid grid;
    struct mpm_conduction *conduction;                 /* [impact] conduction = on (conduction.c), else NULL */
    double wave_speed_max;                             /* largest longitudinal wave speed of the materials */
    struct mpm_material_constants *material_constants; /* one per material, for the stress update */
    double lp;                                         /* uGIMP half-width of a point's domain, dp/2 */
    /* time */
    int64_t step;
    double t, dt;
    double next_series, next_snapshot;
    int64_t snapshot_count;
    int snapshot_pending;
    /* accounting */
    int64_t removed_points, point_updates, contact_node_steps, bonded_node_steps;
    /* what grid_to_points found of this step's new positions and velocities, for remove_escaped: the points
     * whose stencil leaves the grid, and the smallest id of a point gone non-finite (point count: none) */
    int64_t leaving_points;
    long nonfinite_id;
    /* the largest squared speed of the points that stay active, found with them for the next step's time step;
     * vmax2_known: the last step found it (0 after set-up and after reading a checkpoint: choose_time_step
     * computes it itself) */
    double vmax2;
    int vmax2_known;
    double removed_mass, energy_absorbed, energy_removed, energy_initial;
    /* bodies: initial speed and whether each is the substrate */
    double *body_speed;
    double *body_dashpot;    /* 2 per body: rho0 Vp A and rho0 Vs A of a boundary point (Eq. 3.46) */
    double *body_bond_scale; /* per body: the factor of eps_c or G_c for its start temperature (bonding_preheat) */
    size_t *boundary_points; /* ids of the points flagged POINT_BOTTOM or POINT_SIDE at set-up, ascending */
    size_t boundary_count;
    double *boundary_work;         /* per boundary point: the dashpot's work of the step (mpm_book_absorbed_energy) */
    struct balance update_balance; /* the threads' shares of the point update (update_points) */
    /* series rows recorded so far: SERIES_FIXED + body_count * SERIES_PER_BODY doubles each */
    size_t series_rows, series_capacity;
    double *series;
    /* verdicts (verdict.c), judged at every series row: per body the time its verdict settled (NaN: not
     * settled), the last row's judgement (1 bonded) and the window means it was made on (NaN: none yet);
     * whether every particle is settled */
    double *settled_at;
    int *bonded_now;
    double *judged_vrest, *judged_vcom_z;
    int all_settled;
    /* scratch for diagnostics */
    struct mpm_diagnostics diagnostics;
    struct mpm_body_diagnostics *body_diagnostics;
    struct mpm_gpu *gpu; /* [run] device = gpu: the points on the device (mpm/gpu.h), else NULL */
    /* viscous-spring boundary (cfg spring_bottom, spring_sides), else NULL: per body k A of the bottom's normal and
     * tangential and the sides' normal and tangential springs (4 doubles); per point id its index into
     * boundary_points; per boundary point the spring's anchor, the point's set-up position (3 doubles) */
    double *body_spring;
    uint32_t *boundary_rank;
    double *boundary_anchor;
};

#define SERIES_FIXED 4 /* t, energy_total, energy_absorbed, energy_removed */
#define SERIES_PER_BODY                                                                                                \
    15 /* v_com[3], ke, internal, plastic_work, mean_eps_p, ped, pbcp, v_rest, mean_d_bond,                            \
          contacted, bonded, interface_nodes, bonded_nodes */

/* bodies.c */
int mpm_points_create(const struct mpm_config *cfg, struct mpm_points *points);
/* 0 when every body is centred on the mirror planes ([impact] symmetry) with no velocity across them, else -1 and
 * the first that is not in why. */
int mpm_mirror_check(const struct mpm_config *cfg, char *why, size_t size);
void mpm_points_free(struct mpm_points *points);

/* point_order.c */
/* Store the points in the order the particle-to-grid transfer visits them (after mpm_grid_bin_points; the caller
 * bins again).  Results do not depend on the storage order. */
int mpm_points_reorder(struct mpm_solver *s);
/* Storage in set-up order (id = slot = index), e.g. after reading a checkpoint. */
void mpm_points_order_reset(struct mpm_points *p);

/* grid.c */
int mpm_grid_create(const struct mpm_config *cfg, const struct mpm_points *points, struct mpm_grid *grid);
/* The box that holds every body of cfg (and so every point seeded in them), a point spacing wider. */
void mpm_bodies_bounds(const struct mpm_config *cfg, double lo[3], double hi[3]);
void mpm_grid_free(struct mpm_grid *grid);
/* Stencil of a point at x; 0, or -1 when the stencil leaves the grid. */
int mpm_grid_stencil(const struct mpm_grid *grid, enum mpm_shape_function kind, double lp, const double x[3],
                     struct stencil *st);
size_t mpm_grid_node(const struct mpm_grid *grid, int i, int j, int k);
/* Whether mpm_grid_stencil would succeed at x (the point's stencil lies inside the grid; boundary_point.h
 * grid_interior).  Inline: grid_to_points asks for every point and step. */
static inline int grid_contains(const struct mpm_grid *g, const double x[3])
{
    return grid_interior(g->origin, g->inside_from, g->inside_to, x);
}
/* The stencil of point q at its position of this step, after mpm_grid_bin_points: trilinear stencils are rebuilt
 * from the cache, with the weights of mpm_grid_stencil (1 - f, f; gradients -1/h, 1/h). */
static inline void grid_point_stencil(const struct mpm_solver *s, size_t q, struct stencil *st)
{
    const struct mpm_grid *g = &s->grid;
    if (s->cfg.shape_function != MPM_LINEAR) {
        mpm_grid_stencil(g, s->cfg.shape_function, s->lp, s->points.x + 3 * q, st);
        return;
    }
    /* into locals first: the stores to st->w may alias g's doubles, so g->inv_h and the fractions would
     * otherwise be loaded again after every store */
    double inv_h = g->inv_h, f[3];
    const double *fraction = g->point_fraction + 3 * q;
    f[0] = fraction[0], f[1] = fraction[1], f[2] = fraction[2];
    st->width = 2;
    st->node = g->point_node[q];
    for (int d = 0; d < 3; d++) {
        st->w[d][0] = 1.0 - f[d];
        st->w[d][1] = f[d];
        st->g[d][0] = -inv_h; /* -(1/h) == -1/h exactly: rounding is symmetric in the sign */
        st->g[d][1] = inv_h;
    }
}
/* Trilinear stencils in runs (grid.c, solver.c): consecutive points with the same stencil base node in the same
 * body share their 8 nodes, whose fields are then read into vector lanes once per run, node a + 2b + 4c of the
 * stencil in lane a + 2b + 4c.  Only with AVX-512 (grid.c says why); other builds go point by point. */
#if defined(__AVX512F__)
#define TRILINEAR_RUNS 1
#else
#define TRILINEAR_RUNS 0
#endif
typedef double lanes8 __attribute__((vector_size(8 * sizeof(double))));
/* The node of the stencil base of point q in its body's layer, after mpm_grid_bin_points: points with the same one
 * form a run. */
static inline size_t run_key(const struct mpm_solver *s, size_t q)
{
    return (size_t)s->points.body[q] * s->grid.nodes + s->grid.point_node[q];
}
/* Point q's trilinear weights along x, y and z in the lanes of its stencil's nodes: lane a + 2b + 4c holds
 * w_0[a], w_1[b] and w_2[c] (1 - f and f, grid_point_stencil's).  Vectors by pointer (see vec3pad below). */
static inline void run_weights(const struct mpm_grid *g, size_t q, lanes8 w[3])
{
    const double *f = g->point_fraction + 3 * q;
    double u0 = 1.0 - f[0], u1 = 1.0 - f[1], u2 = 1.0 - f[2];
    w[0] = (lanes8){u0, f[0], u0, f[0], u0, f[0], u0, f[0]};
    w[1] = (lanes8){u1, u1, f[1], f[1], u1, u1, f[1], f[1]};
    w[2] = (lanes8){u2, u2, u2, u2, f[2], f[2], f[2], f[2]};
}
/* The 8 nodes are 4 pairs of x neighbours, pair p = b + 2c at node pair[p] (lanes 2p and 2p + 1): a pair's
 * doubles are contiguous in every field.  A field with one double per node into the lanes. */
static inline void lanes_load(lanes8 *v, const double *f, const size_t pair[4])
{
    *v = (lanes8){f[pair[0]], f[pair[0] + 1], f[pair[1]], f[pair[1] + 1],
                  f[pair[2]], f[pair[2] + 1], f[pair[3]], f[pair[3] + 1]};
}
/* A function over a stencil's nodes is written once with the width as a parameter and inlined into a caller
 * that passes a literal 2 for trilinear stencils: the loops over 2 x 2 x 2 nodes are then unrolled and the node
 * offsets folded, with the same arithmetic in the same order (the same bits). */
#define STENCIL_INLINE static inline __attribute__((always_inline))
/* The transfers read the stencil in place, from the caller's local struct: its address does not escape, so the
 * stores to the grid cannot alias it.  A copy into a second local (done before, so that such stores could not
 * alias it) was compiled as vector loads of doubles just stored one by one, which stalled on store forwarding:
 * about a quarter of the particle-to-grid transfer's samples. */
/* Node a, b, c of a stencil. */
static inline size_t stencil_node(const struct mpm_grid *g, const struct stencil *st, int a, int b, int c)
{
    return st->node + (size_t)a + g->row * (size_t)b + g->plane * (size_t)c;
}
/* A 3-vector and a pad lane in one 4-lane register (the GNU C vector extension, which gcc and clang compile to
 * AVX): the per-node loops of grid-to-points and the velocity gradient then add a node's x, y and z with one
 * instruction each.  Every lane does the scalar loop's operations in the same order (C17 mode: no contraction
 * into FMA), so the bits are those of the scalar code; the pad lane is never used (set to a copy of lane 2 where
 * a 0 would need an extra instruction: gcc's vmovq for it is one valgrind 3.19 cannot run). */
typedef double vec3pad __attribute__((vector_size(4 * sizeof(double))));
/* Node I of a field with 3 doubles per node into *v, with the first double of node I + 1 as the pad lane (the
 * fields are allocated with one double to spare, alloc_layers).  The helpers take vectors by pointer: a vector
 * passed by value has another ABI with AVX than without (gcc's -Wpsabi, an error in the x86-64-v2 build). */
static inline void node_vector(vec3pad *v, const double *field, size_t I)
{
    memcpy(v, field + 3 * I, sizeof *v);
}
/* Adds the first three lanes of *a to node I of a field with 3 doubles per node (the pad lane is not stored). */
static inline void node_add(double *field, size_t I, const vec3pad *a)
{
    double *f = field + 3 * I;
    f[0] += (*a)[0];
    f[1] += (*a)[1];
    f[2] += (*a)[2];
}
/* The rows of a box: row r (0 <= r < box_rows) runs from node box_row_start(r) over box_row_length nodes along
 * x, at the z index *k. */
static inline size_t box_rows(const struct node_box *b)
{
    return b->lo[0] > b->hi[0] ? 0 : (size_t)(b->hi[1] - b->lo[1] + 1) * (size_t)(b->hi[2] - b->lo[2] + 1);
}
static inline size_t box_row_length(const struct node_box *b)
{
    return b->lo[0] > b->hi[0] ? 0 : (size_t)(b->hi[0] - b->lo[0] + 1);
}
static inline size_t box_row_start(const struct mpm_grid *g, const struct node_box *b, size_t r, int *k)
{
    size_t rows_y = (size_t)(b->hi[1] - b->lo[1] + 1);
    size_t j = (size_t)b->lo[1] + r % rows_y;
    *k = b->lo[2] + (int)(r / rows_y);
    return (size_t)b->lo[0] + g->row * j + g->plane * (size_t)*k;
}
/* Sort the active points into blocks (fixed order for the transfers) and find the box of their stencils. */
void mpm_grid_bin_points(struct mpm_solver *s);
/* Particle-to-grid: mass, momentum, internal and external force, volume gradient, bond sums (step 1-2). */
void mpm_grid_transfer_all(struct mpm_solver *s);
/* MUSL re-projection: momentum only, into momentum_new (step 8). */
void mpm_grid_transfer_momentum(struct mpm_solver *s);
/* Absorbing-boundary (dashpot) force on a point, Eqs. 3.45-3.46.  Inline: the particle-to-grid transfer and the
 * absorbed-energy booking ask for it at every boundary point and step, and out of line the force went through
 * memory. */
static inline void boundary_dashpot_force(const struct mpm_solver *s, size_t q, double f[3])
{
    const struct mpm_points *p = &s->points;
    const double *coef = s->body_dashpot + 2 * p->body[q];
    f[0] = f[1] = f[2] = 0.0; /* Eq. 3.46: a primary (normal) and secondary (tangential) dashpot per face */
    boundary_face_force(p->flags[q] & POINT_BOTTOM, p->flags[q] & POINT_SIDE, p->normal + 3 * q, p->v + 3 * q, coef,
                        coef, f);
}

/* The viscous-spring boundary's spring on a point (Deeks & Randolph 1994; docs/physics.md "Substrate bottom"),
 * added to f: -k A u per boundary face, u the point's displacement from its anchor, normal and tangential parts
 * with their own k.  Only where s->boundary_rank is set (springs on) and for listed boundary points. */
static inline void boundary_spring_vector(const struct mpm_solver *s, size_t q, const double u[3], double f[3])
{
    const struct mpm_points *p = &s->points;
    const double *k = s->body_spring + 4 * p->body[q];
    boundary_face_force(p->flags[q] & POINT_BOTTOM, p->flags[q] & POINT_SIDE, p->normal + 3 * q, u, k, k + 2, f);
}
static inline void boundary_displacement(const struct mpm_solver *s, size_t q, double u[3])
{
    const double *x = s->points.x + 3 * q, *x0 = s->boundary_anchor + 3 * (size_t)s->boundary_rank[s->points.id[q]];
    u[0] = x[0] - x0[0], u[1] = x[1] - x0[1], u[2] = x[2] - x0[2];
}
/* The whole boundary force on a boundary point: dashpot, and spring where the springs are on. */
static inline void boundary_force(const struct mpm_solver *s, size_t q, double f[3])
{
    boundary_dashpot_force(s, q, f);
    if (s->boundary_rank) {
        double u[3];
        boundary_displacement(s, q, u);
        boundary_spring_vector(s, q, u, f);
    }
}

/* solver.c: list the points flagged POINT_BOTTOM or POINT_SIDE now (by id, in any storage order) as the boundary
 * points, and with springs on anchor each at its present position (mpm_create calls it at set-up; a white-box test
 * may call it again after changing flags).  The elastic energy the springs hold (in energy_total). */
int mpm_list_boundary_points(struct mpm_solver *s);
double mpm_boundary_spring_energy(const struct mpm_solver *s);

/* contact.c: nodal update, contact and bond forces, rigid wall (steps 3-6, 8). */
void mpm_contact_nodal_update(struct mpm_solver *s);
void mpm_contact_correct_momentum(struct mpm_solver *s, double *momentum, int count_nodes);
/* Each body's interface nodes now (after a step): nodes where it meets another body (the pair in contact, bonded
 * or touching), one count per pair, and of those the nodes where the pair is bonded by Eq. 4.7 (the mean of the two
 * bodies' nodal D_bond at least 1).  interface and bonded have body_count entries. */
void mpm_contact_interface_nodes(const struct mpm_solver *s, int64_t *interface, int64_t *bonded);
/* Contact normal between the bodies of layer entries Ia and Ib (same node), from a into b; -1 if undefined. */
int mpm_contact_normal(const struct mpm_grid *g, size_t Ia, size_t Ib, double n[3]);

/* bonding.c: D_bond of point p grows (bonding_update) where it is a surface point in contact and a model is on;
 * the test inline, since it is all that most points need at every step. */
void mpm_bonding_grow(struct mpm_solver *s, size_t p, double eps_p_increment, double von_mises);
/* The increment of D_bond for a plastic strain increment at a von Mises stress over a step dt (the model of cfg;
 * exposed for the tests), and the bounded rate factor max(1 - ln r, floor) of Eqs. 4.4 and 4.16b. */
double mpm_bonding_increment(const struct mpm_config *cfg, double eps_p_increment, double von_mises, double dt,
                             double scale);
/* The factor of eps_c or G_c for body b of cfg at its start temperature T0 (bonding_preheat = melt_heat):
 * q / (2 - q), q = ((Tm - T0) / (Tm - bonding_T_reference))^bonding_preheat_exponent, the factor whose harmonic
 * mean with a body at the reference (Eq. 4.7's average of the two bodies' D_bond) is q; held within
 * [MPM_PREHEAT_SCALE_MIN, MPM_PREHEAT_SCALE_MAX]; 1 with bonding_preheat = none or bonding = none. */
#define MPM_PREHEAT_SCALE_MIN 0.01
#define MPM_PREHEAT_SCALE_MAX 100.0
double mpm_bonding_preheat_scale(const struct mpm_config *cfg, int b);
double mpm_bonding_rate_factor(double r, double floor);
static inline void bonding_update(struct mpm_solver *s, size_t p, double eps_p_increment, double von_mises)
{
    if (s->cfg.bonding != MPM_BONDING_NONE && (s->points.flags[p] & POINT_CONTACT))
        mpm_bonding_grow(s, p, eps_p_increment, von_mises);
}

/* conduction.c: heat conduction inside each body ([impact] conduction = on): the exchange's state, made by create
 * (nothing when off), the heat of every multiple of its interval that the time crossed from t_before to t_after
 * exchanged (advance), and one exchange over dt (exposed for the tests). */
struct mpm_conduction;
int mpm_conduction_create(struct mpm_solver *s);
void mpm_conduction_free(struct mpm_solver *s);
double mpm_conduction_interval(const struct mpm_solver *s);
void mpm_conduction_exchange(struct mpm_solver *s, double dt);
void mpm_conduction_advance(struct mpm_solver *s, double t_before, double t_after);
/* How many exchanges a step from t_before to t_after makes (the multiples of the interval it crossed); the kernel's
 * squared radius (m^2) and the Laplacian's factor 6 / M2 (1/m^5), for the GPU step. */
int mpm_conduction_exchanges(const struct mpm_solver *s, double t_before, double t_after);
void mpm_conduction_kernel(const struct mpm_solver *s, double *eps2, double *laplacian);

/* verdict.c: the verdict state made from the series recorded so far (mpm_verdict_replay), judged again after
 * each new series row (mpm_verdict_record). */
int mpm_verdict_create(struct mpm_solver *s);
void mpm_verdict_free(struct mpm_solver *s);
void mpm_verdict_record(struct mpm_solver *s);
void mpm_verdict_replay(struct mpm_solver *s);

/* solver.c: the time after t at which a clock of period `every` (series_every, snapshot_every) is next due: the first
 * multiple of every beyond t, or, for an every too small to step past t in doubles, the next double (exposed for
 * the tests: it cannot spin, whatever every > 0). */
double mpm_clock_next(double t, double every);

/* diagnostics.c */
int mpm_series_record(struct mpm_solver *s);
/* Work of the absorbing boundaries this step, on the start momenta (after mpm_contact_nodal_update). */
void mpm_book_absorbed_energy(struct mpm_solver *s);

/* gpu.c: the step on the GPU ([run] device = gpu; mpm/gpu.h).  attach makes the device state after set-up, reload
 * copies the host's points to it (after a checkpoint), sync brings the host's copy up to date when it is older
 * (before the host reads the points: snapshots and checkpoints; a no-op on the CPU).  The diagnostics are summed
 * on the device. */
struct mpm_gpu;
int mpm_gpu_attach(struct mpm_solver *s);
void mpm_gpu_detach(struct mpm_solver *s);
int mpm_gpu_reload(struct mpm_solver *s);
int mpm_gpu_sync(const struct mpm_solver *s);
int mpm_gpu_step(struct mpm_solver *s);
/* mpm_contact_interface_nodes on the device's grid; -1 each when the device fails. */
void mpm_gpu_count_interface(const struct mpm_solver *s, int64_t *interface, int64_t *bonded);
/* Each body's sums over its active points (diagnostics.c body_sums), summed on the device. */
struct point_sums;
int mpm_gpu_body_sums(const struct mpm_solver *s, struct point_sums *sums);

#endif
