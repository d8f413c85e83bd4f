/* Heat conduction inside each body ([impact] conduction = on; docs/physics.md "Heat conduction").
 *
 * The thesis's impacts are adiabatic (Eq. 3.44 heats a point by its own plastic work alone).  Then nothing but the
 * grid bounds the interface's temperature, which grows with every refinement (docs/physics.md "Why the calibration
 * moves with the grid").  In 20 ns heat diffuses about a micrometre in Al, the width of the interface's band
 * (Dodd & Bai 1985: 2 sqrt(k T / (tau gamma_dot))), and conduction holds the temperature there; the plastic
 * strain's concentration it does not change (measured there).
 *
 * The Laplacian is taken by particle strength exchange (Degond & Mas-Gallic 1989; Eldredge, Leonard & Colonius
 * 2002) over the points of the same body within a radius eps = 2 spacing:
 *     dE_p = dt k (6 / M2) sum_q V0_p V0_q (T_q - T_p) eta(|x_q - x_p| / eps),   eta(s) = (1 - s^2)^3,
 * M2 = sum over the lattice offsets r != 0 of spacing^3 r^2 eta: the kernel's second moment on the points' cubic
 * lattice, so that the sum is exactly the Laplacian of a quadratic field on that lattice.  Each pair's heat is
 * antisymmetric, so the bodies' heat is conserved to rounding; a surface point has no neighbours outside, so no heat
 * leaves a body (adiabatic surfaces), and none crosses between bodies (no contact conductance is known: the
 * choice that keeps the interface's heat where it was made).  The heat dE_p enters the point's temperature
 * (dE_p / (m_p c_p)) and its internal energy, which the energy balance counts.
 *
 * Explicit in time: the step is held at half the largest one that keeps every new temperature a weighted mean of
 * the old ones (max principle), dt_heat = 0.5 / (kappa A), A = (6 / M2) sum spacing^3 eta; with mechanical steps
 * 10-20 times shorter, the heat is exchanged whenever the time crosses a multiple of dt_heat (restart-exact:
 * decided by the time alone). */
#include <math.h>
#include <stdlib.h>

#include "core/error.h"
#include "core/log.h"
#include "mpm/mpm_impl.h"

#define KERNEL_RADIUS 2.0 /* eps / spacing */

struct mpm_conduction {
    double eps, eps2; /* kernel radius and its square, m */
    double laplacian; /* 6 / M2, 1/m^5 */
    double interval;  /* dt_heat, s */
    double cell;      /* cell-list edge (= eps), m */
    double origin[3]; /* cell-list origin: the grid's */
    int n[3];         /* cells per direction */
    size_t cells;
    size_t *cell_start; /* cells + 1 */
    size_t *cell_points;
    size_t *point_cell; /* per point slot: its cell, or SIZE_MAX if inactive */
    double *heat;       /* per point slot: dE of this exchange, J */
};

static double kernel(double r2_over_eps2)
{
    double u = 1.0 - r2_over_eps2;
    return u > 0.0 ? u * u * u : 0.0;
}

/* The kernel's zeroth and second moments on the cubic lattice of unit spacing (times spacing^3 and spacing^5). */
static void lattice_moments(double *m0, double *m2)
{
    int reach = (int)KERNEL_RADIUS;
    *m0 = *m2 = 0.0;
    for (int i = -reach; i <= reach; i++)
        for (int j = -reach; j <= reach; j++)
            for (int k = -reach; k <= reach; k++) {
                double r2 = (double)(i * i + j * j + k * k);
                if (r2 == 0.0)
                    continue; /* the point itself exchanges nothing */
                double eta = kernel(r2 / (KERNEL_RADIUS * KERNEL_RADIUS));
                *m0 += eta;
                *m2 += r2 * eta;
            }
}

/* The largest thermal diffusivity k / (rho c) of the bodies' materials, m^2/s. */
static double largest_diffusivity(const struct mpm_config *cfg)
{
    double kappa = 0.0;
    for (int b = 0; b < cfg->body_count; b++) {
        const struct mpm_material *m = &cfg->materials[cfg->bodies[b].material];
        kappa = fmax(kappa, m->conductivity / (m->density * m->specific_heat));
    }
    return kappa;
}

int mpm_conduction_create(struct mpm_solver *s)
{
    const struct mpm_config *cfg = &s->cfg;
    if (!cfg->conduction)
        return SC_OK;
    struct mpm_conduction *c = calloc(1, sizeof *c);
    s->conduction = c;
    if (!c)
        SC_FAIL_OOM(sizeof *c, "the heat conduction");
    double h = cfg->spacing, m0, m2;
    lattice_moments(&m0, &m2);
    c->eps = KERNEL_RADIUS * h;
    c->eps2 = c->eps * c->eps;
    c->laplacian = 6.0 / (m2 * pow(h, 5));
    double kappa = largest_diffusivity(cfg);
    c->interval = kappa > 0.0 ? 0.5 / (kappa * c->laplacian * m0 * h * h * h) : INFINITY;
    c->cell = c->eps;
    c->cells = 1;
    for (int d = 0; d < 3; d++) {
        c->origin[d] = s->grid.origin[d];
        c->n[d] = (int)ceil((s->grid.n[d] - 1) * s->grid.h / c->cell) + 1;
        c->cells *= (size_t)c->n[d];
    }
    size_t count = s->points.count;
    c->cell_start = calloc(c->cells + 1, sizeof *c->cell_start);
    c->cell_points = malloc((count + 1) * sizeof *c->cell_points);
    c->point_cell = malloc((count + 1) * sizeof *c->point_cell);
    c->heat = calloc(count + 1, sizeof *c->heat);
    if (!c->cell_start || !c->cell_points || !c->point_cell || !c->heat)
        SC_FAIL_OOM((c->cells + 1 + 4 * (count + 1)) * sizeof(size_t), "the heat conduction's cell list");
    log_info("impact: heat conduction within %g m (2 spacings), exchanged every %.3g s (largest diffusivity %.3g "
             "m2/s)",
             c->eps, c->interval, kappa);
    return SC_OK;
}

void mpm_conduction_free(struct mpm_solver *s)
{
    struct mpm_conduction *c = s->conduction;
    if (!c)
        return;
    free(c->cell_start);
    free(c->cell_points);
    free(c->point_cell);
    free(c->heat);
    free(c);
    s->conduction = NULL;
}

double mpm_conduction_interval(const struct mpm_solver *s)
{
    return s->conduction ? s->conduction->interval : INFINITY;
}

static size_t cell_of(const struct mpm_conduction *c, const double x[3])
{
    size_t index = 0, stride = 1;
    for (int d = 0; d < 3; d++) {
        double f = floor((x[d] - c->origin[d]) / c->cell); /* clamped as a double: no overflow in the cast */
        int i = f > 0.0 ? (f < c->n[d] - 1 ? (int)f : c->n[d] - 1) : 0;
        index += (size_t)i * stride;
        stride *= (size_t)c->n[d];
    }
    return index;
}

/* The active points sorted by cell (counting sort), by id within a cell: a point's sum then runs in the same order
 * for any storage order (point_order.c reorders the storage; a run resumed from a checkpoint has another), and a
 * resumed run repeats the uninterrupted one to the bit. */
static void build_cell_list(struct mpm_conduction *c, const struct mpm_points *p)
{
    for (size_t k = 0; k <= c->cells; k++)
        c->cell_start[k] = 0;
    for (size_t q = 0; q < p->count; q++) {
        c->point_cell[q] = (p->flags[q] & POINT_ACTIVE) ? cell_of(c, p->x + 3 * q) : SIZE_MAX;
        if (c->point_cell[q] != SIZE_MAX)
            c->cell_start[c->point_cell[q] + 1]++;
    }
    for (size_t k = 0; k < c->cells; k++)
        c->cell_start[k + 1] += c->cell_start[k];
    for (size_t i = 0; i < p->count; i++) {
        size_t q = p->slot[i];
        if (c->point_cell[q] != SIZE_MAX)
            c->cell_points[c->cell_start[c->point_cell[q]]++] = q;
    }
    for (size_t k = c->cells; k > 0; k--) /* the fill advanced each start to the next cell's */
        c->cell_start[k] = c->cell_start[k - 1];
    c->cell_start[0] = 0;
}

/* sum_o V0_o (T_o - T_q) eta over the points o of q's body within eps of the position x (the 27 cells around x's). */
static double exchange_sum_at(const struct mpm_conduction *c, const struct mpm_points *p, size_t q, const double x[3])
{
    size_t home = cell_of(c, x);
    int i[3] = {(int)(home % (size_t)c->n[0]), (int)(home / (size_t)c->n[0] % (size_t)c->n[1]),
                (int)(home / ((size_t)c->n[0] * (size_t)c->n[1]))};
    double T = p->state[q].T, sum = 0.0;
    for (int dz = -1; dz <= 1; dz++)
        for (int dy = -1; dy <= 1; dy++)
            for (int dx = -1; dx <= 1; dx++) {
                int j[3] = {i[0] + dx, i[1] + dy, i[2] + dz};
                if (j[0] < 0 || j[1] < 0 || j[2] < 0 || j[0] >= c->n[0] || j[1] >= c->n[1] || j[2] >= c->n[2])
                    continue;
                size_t cell = (size_t)j[0] + (size_t)c->n[0] * ((size_t)j[1] + (size_t)c->n[1] * (size_t)j[2]);
                for (size_t k = c->cell_start[cell]; k < c->cell_start[cell + 1]; k++) {
                    size_t o = c->cell_points[k];
                    if (p->body[o] != p->body[q])
                        continue;
                    const double *y = p->x + 3 * o;
                    double r2 =
                        (y[0] - x[0]) * (y[0] - x[0]) + (y[1] - x[1]) * (y[1] - x[1]) + (y[2] - x[2]) * (y[2] - x[2]);
                    if (r2 < c->eps2) /* the point itself (r2 = 0 unmirrored, T_o = T_q mirrored) adds nothing */
                        sum += p->volume0[o] * (p->state[o].T - T) * kernel(r2 / c->eps2);
                }
            }
    return sum;
}

/* q's sum over its neighbours and, with [impact] symmetry, over their mirror images across the planes x = 0 and
 * y = 0 (the set-up's unmodelled copies, at the same temperatures): the image of o is as far from q as o from q's
 * image, so each image's sum is the one at q mirrored.  Each pair's heat stays antisymmetric (a reflection keeps
 * distances), so the modelled part conserves its heat, and none crosses a plane (the whole set-up's symmetry). */
static double exchange_sum(const struct mpm_conduction *c, const int mirror[2], const struct mpm_points *p, size_t q)
{
    const double *x = p->x + 3 * q;
    double sum = 0.0;
    for (int image = 0; image < 4; image++) { /* bit d: mirrored across the plane of axis d */
        double at[3] = {x[0], x[1], x[2]};
        int reaches = 1;
        for (int d = 0; d < 2; d++)
            if (image & (1 << d)) {
                reaches = reaches && mirror[d] && fabs(x[d]) < c->eps; /* an image farther than eps adds nothing */
                at[d] = -x[d];
            }
        if (reaches)
            sum += exchange_sum_at(c, p, q, at);
    }
    return sum;
}

static const struct mpm_material *material_of(const struct mpm_solver *s, size_t q)
{
    return &s->cfg.materials[s->cfg.bodies[s->points.body[q]].material];
}

/* One exchange over dt on the cell list built for the points' current positions: every point's heat from the
 * temperatures before the exchange, then the temperatures and energies (two passes: a point's sum must not see
 * a neighbour already updated). */
static void exchange(struct mpm_solver *s, double dt)
{
    struct mpm_conduction *c = s->conduction;
    struct mpm_points *p = &s->points;
    long count = (long)p->count;
#pragma omp parallel for schedule(static)
    for (long i = 0; i < count; i++)
        if (c->point_cell[i] != SIZE_MAX)
            c->heat[i] = dt * material_of(s, (size_t)i)->conductivity * c->laplacian * p->volume0[i] *
                         exchange_sum(c, s->cfg.mirror, p, (size_t)i);
#pragma omp parallel for schedule(static)
    for (long i = 0; i < count; i++)
        if (c->point_cell[i] != SIZE_MAX) {
            p->state[i].T += c->heat[i] / (p->mass[i] * material_of(s, (size_t)i)->specific_heat);
            p->state[i].energy += c->heat[i];
        }
}

void mpm_conduction_exchange(struct mpm_solver *s, double dt)
{
    build_cell_list(s->conduction, &s->points);
    exchange(s, dt);
}

int mpm_conduction_exchanges(const struct mpm_solver *s, double t_before, double t_after)
{
    if (!s->conduction)
        return 0;
    double interval = s->conduction->interval;
    return (int)(floor(t_after / interval) - floor(t_before / interval));
}

void mpm_conduction_kernel(const struct mpm_solver *s, double *eps2, double *laplacian)
{
    *eps2 = s->conduction ? s->conduction->eps2 : 0.0;
    *laplacian = s->conduction ? s->conduction->laplacian : 0.0;
}

void mpm_conduction_advance(struct mpm_solver *s, double t_before, double t_after)
{
    int crossed = mpm_conduction_exchanges(s, t_before, t_after);
    if (crossed > 0) /* the points do not move between the exchanges of one step: one cell list */
        build_cell_list(s->conduction, &s->points);
    for (int k = 0; k < crossed; k++)
        exchange(s, s->conduction->interval);
}
