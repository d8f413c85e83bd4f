/* Injection at the nozzle, Mukherjee & Zohdi Section 4.1 (Eq. 35) and 4.2.
 *
 * Every feed_every steps, feed_count particles are placed in the nozzle disc (z = 0) by random sequential
 * addition: a uniformly random position in the disc, retried until it overlaps neither the particles of
 * this batch nor those still near the nozzle.  All draws come from the counter-based generator keyed by
 * (seed, stream, particle id, attempt), so injection does not depend on threads or restarts. */
#include <math.h>
#include <stdlib.h>

#include "core/log.h"
#include "core/rng.h"
#include "dem/dem_impl.h"

#define PLACEMENT_ATTEMPTS 1000

static double sample_diameter(const struct dem_solver *s, int64_t id)
{
    double u[2];
    rng_uniform2(s->cfg.seed, RNG_STREAM_SIZE, (uint64_t)id, 0, 0, u);
    return dem_sizes_sample(&s->cfg.sizes, u[0]);
}

/* The particle's temperature at release and, with [nozzle], its speed at the nozzle exit (dem/nozzle.c's table,
 * interpolated in diameter); without [nozzle] the [powder] temperature and speed 0 (sample_velocity draws it). */
static double release_state(const struct dem_config *cfg, double d, double *nozzle_speed)
{
    double temperature = cfg->powder_temperature;
    *nozzle_speed = 0.0;
    if (cfg->nozzle)
        dem_nozzle_lookup(cfg->nozzle, d, nozzle_speed, &temperature);
    return temperature;
}

/* Release velocity: speed uniform in [min, max] (with [nozzle]: the nozzle's exit speed of the particle's diameter),
 * direction uniform in solid angle inside the cone. */
static void sample_velocity(const struct dem_solver *s, int64_t id, double d, double v[3])
{
    double u[4];
    rng_uniform2(s->cfg.seed, RNG_STREAM_INJECT_VELOCITY, (uint64_t)id, 0, 0, u);
    rng_uniform2(s->cfg.seed, RNG_STREAM_INJECT_VELOCITY, (uint64_t)id, 0, 1, u + 2);
    const struct dem_config *cfg = &s->cfg;
    double speed = cfg->release_speed_min + (cfg->release_speed_max - cfg->release_speed_min) * u[0];
    if (cfg->nozzle)
        release_state(cfg, d, &speed);
    double cos_polar = 1.0 - u[1] * (1.0 - cos(cfg->release_cone));
    double sin_polar = sqrt(fmax(0.0, 1.0 - cos_polar * cos_polar));
    double azimuth = 2.0 * M_PI * u[2];
    v[0] = speed * sin_polar * cos(azimuth);
    v[1] = speed * sin_polar * sin(azimuth);
    v[2] = speed * cos_polar;
}

/* The particles near the nozzle binned in square cells of the disc's plane, at least `reach` (the largest diameter
 * there) across: a new particle can touch only those of its own and the 8 cells around it.  Testing every
 * particle near the nozzle made a batch cost feed_count^2 tests (minutes in step 0 for 50,000 particles); the
 * decisions are the same.  Particles outside the grid count in its edge cells, which keeps them among the
 * neighbours of any position within reach of them. */
#define MAX_CELLS_PER_SIDE 2048
struct placement_grid {
    double x0, y0, cell;
    int side;
    int64_t *head; /* first entry of each cell, -1: none */
    int64_t *next; /* the next entry of the same cell, by entry (the order of `near`) */
    const size_t *near;
};

static int64_t cell_of(const struct placement_grid *g, double x, double y)
{
    long i = lround(floor((x - g->x0) / g->cell)), j = lround(floor((y - g->y0) / g->cell));
    i = i < 0 ? 0 : i >= g->side ? g->side - 1 : i;
    j = j < 0 ? 0 : j >= g->side ? g->side - 1 : j;
    return (int64_t)j * g->side + i;
}

static void grid_add(struct placement_grid *g, const struct dem_particles *p, size_t entry)
{
    int64_t c = cell_of(g, p->x[3 * g->near[entry]], p->x[3 * g->near[entry] + 1]);
    g->next[entry] = g->head[c];
    g->head[c] = (int64_t)entry;
}

/* The grid over the disc (centre cx, cy, radius r) and one cell around it, for `capacity` entries of `near`. */
static void grid_build(struct placement_grid *g, double cx, double cy, double r, double reach, const size_t *near,
                       size_t capacity)
{
    g->cell = fmax(reach, 2.0 * r / (MAX_CELLS_PER_SIDE - 2));
    g->side = (int)ceil(2.0 * r / g->cell) + 2;
    g->x0 = cx - r - g->cell, g->y0 = cy - r - g->cell;
    g->near = near;
    g->head = dem_realloc_or_die(NULL, (size_t)g->side * (size_t)g->side * sizeof *g->head);
    g->next = dem_realloc_or_die(NULL, (capacity + 1) * sizeof *g->next);
    for (size_t c = 0; c < (size_t)g->side * (size_t)g->side; c++)
        g->head[c] = -1;
}

static int overlaps(const struct placement_grid *g, const struct dem_particles *p, const double x[3], double d)
{
    int64_t c = cell_of(g, x[0], x[1]);
    long ci = (long)(c % g->side), cj = (long)(c / g->side);
    for (long j = cj - 1; j <= cj + 1; j++)
        for (long i = ci - 1; i <= ci + 1; i++) {
            if (i < 0 || j < 0 || i >= g->side || j >= g->side)
                continue;
            for (int64_t e = g->head[j * g->side + i]; e >= 0; e = g->next[e]) {
                size_t k = g->near[e];
                double dx = p->x[3 * k] - x[0], dy = p->x[3 * k + 1] - x[1], dz = p->x[3 * k + 2] - x[2];
                double contact = 0.5 * (p->d[k] + d);
                if (dx * dx + dy * dy + dz * dz < contact * contact)
                    return 1;
            }
        }
    return 0;
}

/* A free position in the disc for particle `id`, or 0 if none was found. */
static int place_in_disc(const struct dem_solver *s, int64_t id, double d, const struct placement_grid *grid,
                         double x[3])
{
    double usable_radius = s->cfg.nozzle_radius - 0.5 * d;
    for (uint32_t attempt = 0; attempt < PLACEMENT_ATTEMPTS; attempt++) {
        double u[2];
        rng_uniform2(s->cfg.seed, RNG_STREAM_INJECT_POSITION, (uint64_t)id, attempt, 0, u);
        double r = usable_radius * sqrt(u[0]), angle = 2.0 * M_PI * u[1];
        x[0] = s->cfg.gas.axis_x + r * cos(angle); /* the disc's centre: the nozzle's position now (dem_step) */
        x[1] = s->cfg.gas.axis_y + r * sin(angle);
        x[2] = 0.0;
        if (!overlaps(grid, &s->p, x, d))
            return 1;
    }
    return 0;
}

/* Indices of the particles that could touch a new particle in the disc (their z below the largest diameter,
 * *reach). */
static size_t *particles_near_nozzle(const struct dem_solver *s, size_t extra, size_t *count, double *reach)
{
    size_t *near = dem_realloc_or_die(NULL, (s->p.count + extra + 1) * sizeof *near);
    *reach = 0.0;
    for (size_t i = 0; i < s->p.count; i++)
        *reach = fmax(*reach, s->p.d[i]);
    *reach = fmax(*reach, s->cfg.sizes.d_max < INFINITY ? s->cfg.sizes.d_max : 10 * s->cfg.sizes.median_diameter);
    *count = 0;
    for (size_t i = 0; i < s->p.count; i++)
        if (s->p.x[3 * i + 2] < *reach)
            near[(*count)++] = i;
    return near;
}

static void inject_stream(struct dem_solver *s)
{
    const struct dem_config *cfg = &s->cfg;
    int64_t batch = cfg->feed_count;
    if (s->injected + batch > cfg->max_injected)
        batch = cfg->max_injected - s->injected;
    if (batch <= 0)
        return;
    size_t near_count;
    double reach;
    size_t *near = particles_near_nozzle(s, (size_t)batch, &near_count, &reach);
    struct placement_grid grid;
    grid_build(&grid, cfg->gas.axis_x, cfg->gas.axis_y, cfg->nozzle_radius, reach, near, near_count + (size_t)batch);
    for (size_t e = 0; e < near_count; e++)
        grid_add(&grid, &s->p, e);
    const double spin[3] = {0, 0, 0};
    for (int64_t k = 0; k < batch; k++) {
        int64_t id = s->injected + s->injection_deferred;
        double d = sample_diameter(s, id), x[3], v[3];
        if (!place_in_disc(s, id, d, &grid, x)) {
            if (s->injection_deferred++ == 0)
                log_warn("spray: step %lld: no free place for particle %lld in the nozzle disc after %d attempts; "
                         "it is skipped (feed_count too high for nozzle_radius?)",
                         (long long)s->step, (long long)id, PLACEMENT_ATTEMPTS);
            continue;
        }
        sample_velocity(s, id, d, v);
        size_t i = dem_particles_append(&s->p, id, x, v, spin, d, cfg->powder.density);
        double unused;
        s->p.temperature[i] = release_state(cfg, d, &unused);
        near[near_count] = i;
        grid_add(&grid, &s->p, near_count++);
        s->injected++;
    }
    free(grid.head);
    free(grid.next);
    free(near);
}

void dem_inject_file(struct dem_solver *s)
{
    const struct dem_config *cfg = &s->cfg;
    dem_particles_reserve(&s->p, s->p.count + cfg->file_particle_count); /* at once, not by doubling */
    for (size_t i = 0; i < cfg->file_particle_count; i++) {
        const double *row = cfg->file_particles + 10 * i;
        size_t k = dem_particles_append(&s->p, (int64_t)i, row, row + 3, row + 6, row[9], cfg->powder.density);
        double unused; /* the file gives the velocity; the temperature is the release state's of the diameter */
        s->p.temperature[k] = release_state(cfg, row[9], &unused);
        s->injected++;
    }
}

void dem_inject(struct dem_solver *s)
{
    /* particles from a file exist from t = 0 (dem_create); a stream feeds every feed_every steps */
    if (s->cfg.injection == DEM_INJECT_STREAM && s->step % s->cfg.feed_every == 0)
        inject_stream(s);
}
