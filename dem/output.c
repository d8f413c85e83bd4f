/* Deposit metrics, Mukherjee & Zohdi Section 5.2 (unnumbered there): deposit fraction N_dep/N_inj, volume
 * fraction, mean spread mu and scatter sigma of |x_p - x_0|, maximum deposit thickness; and the deposition
 * rate.  Also the spray's checkpoints and the spray.h5 datasets. */
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/h5io.h"
#include "dem/dem_impl.h"

/* ---------------------------------------------------------------- metrics */

/* Section 5.2.  x0 is the centre of the target (on the spray axis), s = +z the streamwise direction.
 * The paper's "volume of the deposit-target" has no stated thickness: we take the disc of radius
 * deposit_radius and thickness D_median, so the volume fraction is the deposited particle volume in that
 * region per monolayer-thick disc (docs/physics.md, "Metrics"). */
struct dem_metrics dem_compute_metrics(const struct dem_solver *s)
{
    const struct dem_particles *p = &s->p;
    const struct dem_config *cfg = &s->cfg;
    struct dem_metrics m = {
        .t = (double)s->step * cfg->dt, .injected = s->injected, .deposited = s->deposited, .escaped = s->escaped};
    m.resting = s->resting;
    m.first_impact_deposits = s->first_impact_deposits;
    m.in_flight = s->injected - s->deposited - s->escaped - s->resting;
    m.deposit_fraction = s->injected ? (double)s->deposited / (double)s->injected : 0.0;
    m.first_impact_share = s->deposited ? (double)s->first_impact_deposits / (double)s->deposited : 0.0;
    double region2 = cfg->deposit_radius * cfg->deposit_radius, volume = 0.0, spread_sum = 0.0;
    double z_min = INFINITY, z_max = -INFINITY;
    for (size_t i = 0; i < p->count; i++) {
        if (p->state[i] != DEM_DEPOSITED)
            continue;
        const double *x = p->x + 3 * i;
        double lateral2 = x[0] * x[0] + x[1] * x[1];
        if (lateral2 <= region2)
            volume += M_PI * p->d[i] * p->d[i] * p->d[i] / 6.0;
        spread_sum += sqrt(lateral2 + (x[2] - cfg->standoff) * (x[2] - cfg->standoff));
        z_min = fmin(z_min, x[2]);
        z_max = fmax(z_max, x[2]);
    }
    m.volume_fraction = volume / (M_PI * region2 * cfg->sizes.median_diameter);
    if (s->deposited > 0) {
        m.mean_spread = spread_sum / (double)s->deposited;
        double square_sum = 0.0;
        for (size_t i = 0; i < p->count; i++) {
            if (p->state[i] != DEM_DEPOSITED)
                continue;
            const double *x = p->x + 3 * i;
            double spread = sqrt(x[0] * x[0] + x[1] * x[1] + (x[2] - cfg->standoff) * (x[2] - cfg->standoff));
            square_sum += (spread - m.mean_spread) * (spread - m.mean_spread);
        }
        m.scatter = sqrt(square_sum / (double)s->deposited);
        m.max_thickness = z_max - z_min;
    }
    return m;
}

uint32_t *dem_contacts_of(struct dem_solver *s, int64_t id)
{
    size_t need = (size_t)id + 1;
    if (need > s->contacts_of_capacity) {
        size_t capacity = s->contacts_of_capacity ? s->contacts_of_capacity : 1024;
        while (capacity < need)
            capacity *= 2;
        s->contacts_of = dem_realloc_or_die(s->contacts_of, capacity * sizeof *s->contacts_of);
        memset(s->contacts_of + s->contacts_of_capacity, 0,
               (capacity - s->contacts_of_capacity) * sizeof *s->contacts_of);
        s->contacts_of_capacity = capacity;
    }
    return &s->contacts_of[id];
}

void dem_sample_metrics(struct dem_solver *s)
{
    struct dem_metrics now = dem_compute_metrics(s);
    if (s->metric_count > 0) {
        const struct dem_metrics *last = &s->metrics[s->metric_count - 1];
        if (now.t <= last->t)
            return; /* already sampled at this time */
        now.deposition_rate = (double)(now.deposited - last->deposited) / (now.t - last->t);
    } else if (now.t > 0) {
        now.deposition_rate = (double)now.deposited / now.t;
    }
    struct dem_metrics *row = dem_grow((void **)&s->metrics, &s->metric_count, &s->metric_capacity, sizeof *row);
    *row = now;
}

/* ---------------------------------------------------------------- column writers */

static int write_column(hid_t group, const char *name, const void *rows, size_t count, size_t stride, size_t offset,
                        int width, const char *units, int is_int)
{
    hsize_t dims[2] = {count, (hsize_t)width};
    int rank = width == 1 ? 1 : 2;
    size_t n = count * (size_t)width;
    void *column = malloc((n ? n : 1) * 8);
    if (!column)
        SC_FAIL_OOM((n ? n : 1) * 8, name);
    for (size_t i = 0; i < count; i++)
        memcpy((char *)column + i * (size_t)width * 8, (const char *)rows + i * stride + offset, (size_t)width * 8);
    int status = is_int ? h5_write_int64s(group, name, rank, dims, column, units, 0)
                        : h5_write_doubles(group, name, rank, dims, column, units, 0);
    free(column);
    SC_TRY(status);
    return SC_OK;
}

/* in a function with `int status` and a cleanup label `done` that closes the group */
#define COLUMN(group, rows, count, type, field, width, units, is_int)                                                  \
    SC_CHECK(status,                                                                                                   \
             write_column(group, #field, rows, count, sizeof(type), offsetof(type, field), width, units, is_int),      \
             done)

static int write_impacts(hid_t file, const struct dem_solver *s)
{
    hid_t g;
    SC_TRY(h5_create_group(file, "impacts", &g));
    int status = SC_OK;
    const struct dem_impact *r = s->impacts;
    size_t n = s->impact_count;
    COLUMN(g, r, n, struct dem_impact, t, 1, "s", 0);
    COLUMN(g, r, n, struct dem_impact, particle_id, 1, "", 1);
    COLUMN(g, r, n, struct dem_impact, x, 3, "m", 0);
    COLUMN(g, r, n, struct dem_impact, v_in, 3, "m/s", 0);
    COLUMN(g, r, n, struct dem_impact, v_out, 3, "m/s", 0);
    COLUMN(g, r, n, struct dem_impact, w_in, 3, "rad/s", 0);
    COLUMN(g, r, n, struct dem_impact, w_out, 3, "rad/s", 0);
    COLUMN(g, r, n, struct dem_impact, d, 1, "m", 0);
    COLUMN(g, r, n, struct dem_impact, m, 1, "kg", 0);
    COLUMN(g, r, n, struct dem_impact, outcome, 1, "0 rebound, 1 deposited, 2 came to rest", 1);
    COLUMN(g, r, n, struct dem_impact, partner, 1, "-1 target, else particle id", 1);
    COLUMN(g, r, n, struct dem_impact, contact_index, 1, "0 first contact of the particle", 1);
    COLUMN(g, r, n, struct dem_impact, temperature, 1, "K", 0);
done:
    H5Gclose(g);
    return status;
}

static int write_handoffs(hid_t file, const struct dem_solver *s)
{
    hid_t g;
    SC_TRY(h5_create_group(file, "handoff", &g));
    int status = SC_OK;
    const struct dem_handoff *r = s->handoffs;
    size_t n = s->handoff_count;
    COLUMN(g, r, n, struct dem_handoff, t, 1, "s", 0);
    COLUMN(g, r, n, struct dem_handoff, particle_id, 1, "", 1);
    COLUMN(g, r, n, struct dem_handoff, x, 3, "m", 0);
    COLUMN(g, r, n, struct dem_handoff, v, 3, "m/s", 0);
    COLUMN(g, r, n, struct dem_handoff, w, 3, "rad/s", 0);
    COLUMN(g, r, n, struct dem_handoff, d, 1, "m", 0);
    COLUMN(g, r, n, struct dem_handoff, temperature, 1, "K", 0);
    COLUMN(g, r, n, struct dem_handoff, axis, 2, "m", 0);
    SC_CHECK(status, h5_attr_write_double(g, "plane_z", s->cfg.standoff - s->cfg.handoff_height), done);
done:
    H5Gclose(g);
    return status;
}

static int write_escapes(hid_t file, const struct dem_solver *s)
{
    hid_t g;
    SC_TRY(h5_create_group(file, "escapes", &g));
    int status = SC_OK;
    const struct dem_escape *r = s->escapes;
    size_t n = s->escape_count;
    COLUMN(g, r, n, struct dem_escape, t, 1, "s", 0);
    COLUMN(g, r, n, struct dem_escape, particle_id, 1, "", 1);
    COLUMN(g, r, n, struct dem_escape, d, 1, "m", 0);
    COLUMN(g, r, n, struct dem_escape, m, 1, "kg", 0);
done:
    H5Gclose(g);
    return status;
}

static int write_deposition_efficiency(hid_t file, const struct dem_solver *s)
{
    struct dem_deposition_efficiency de;
    SC_TRY(dem_deposition_efficiency(s, &de));
    int status = dem_deposition_efficiency_write(&de, file);
    dem_deposition_efficiency_free(&de);
    SC_TRY(status);
    return SC_OK;
}

static int write_metrics(hid_t file, const struct dem_solver *s)
{
    hid_t g;
    SC_TRY(h5_create_group(file, "metrics", &g));
    int status = SC_OK;
    const struct dem_metrics *r = s->metrics;
    size_t n = s->metric_count;
    COLUMN(g, r, n, struct dem_metrics, t, 1, "s", 0);
    COLUMN(g, r, n, struct dem_metrics, injected, 1, "", 1);
    COLUMN(g, r, n, struct dem_metrics, in_flight, 1, "", 1);
    COLUMN(g, r, n, struct dem_metrics, deposited, 1, "", 1);
    COLUMN(g, r, n, struct dem_metrics, escaped, 1, "", 1);
    COLUMN(g, r, n, struct dem_metrics, deposit_fraction, 1, "-", 0);
    COLUMN(g, r, n, struct dem_metrics, volume_fraction, 1, "-", 0);
    COLUMN(g, r, n, struct dem_metrics, mean_spread, 1, "m", 0);
    COLUMN(g, r, n, struct dem_metrics, scatter, 1, "m", 0);
    COLUMN(g, r, n, struct dem_metrics, max_thickness, 1, "m", 0);
    COLUMN(g, r, n, struct dem_metrics, deposition_rate, 1, "1/s", 0);
    COLUMN(g, r, n, struct dem_metrics, resting, 1, "", 1);
    COLUMN(g, r, n, struct dem_metrics, first_impact_deposits, 1, "", 1);
    COLUMN(g, r, n, struct dem_metrics, first_impact_share, 1, "-", 0);
done:
    H5Gclose(g);
    return status;
}

static int write_particles(hid_t file, const struct dem_solver *s, int checksum)
{
    const struct dem_particles *p = &s->p;
    hid_t g;
    SC_TRY(h5_create_group(file, "particles", &g));
    hsize_t n1[1] = {p->count}, n3[2] = {p->count, 3};
    int status = SC_OK;
    size_t state_bytes = (p->count ? p->count : 1) * sizeof(int64_t);
    int64_t *state = malloc(state_bytes);
    if (!state)
        SC_FAIL_OOM_AT(status, done, state_bytes, "the particle states");
    for (size_t i = 0; i < p->count; i++)
        state[i] = p->state[i];
    SC_CHECK(status, h5_write_int64s(g, "id", 1, n1, p->id, "", checksum), done);
    SC_CHECK(status, h5_write_int64s(g, "state", 1, n1, state, "0 flying, 1 deposited, 2 resting", checksum), done);
    SC_CHECK(status, h5_write_doubles(g, "x", 2, n3, p->x, "m", checksum), done);
    SC_CHECK(status, h5_write_doubles(g, "v", 2, n3, p->v, "m/s", checksum), done);
    SC_CHECK(status, h5_write_doubles(g, "w", 2, n3, p->w, "rad/s", checksum), done);
    SC_CHECK(status, h5_write_doubles(g, "d", 1, n1, p->d, "m", checksum), done);
    SC_CHECK(status, h5_write_doubles(g, "m", 1, n1, p->m, "kg", checksum), done);
    SC_CHECK(status, h5_write_doubles(g, "temperature", 1, n1, p->temperature, "K", checksum), done);
done:
    free(state);
    H5Gclose(g);
    return status;
}

static int write_stats(hid_t file, const struct dem_solver *s)
{
    struct dem_counts c = dem_get_counts(s);
    hid_t g;
    SC_TRY(h5_create_group(file, "stats", &g));
    int status = SC_OK;
    SC_CHECK(status, h5_attr_write_int64(g, "steps", c.step), done);
    SC_CHECK(status, h5_attr_write_double(g, "t", c.t), done);
    SC_CHECK(status, h5_attr_write_int64(g, "injected", c.injected), done);
    SC_CHECK(status, h5_attr_write_int64(g, "in_flight", c.in_flight), done);
    SC_CHECK(status, h5_attr_write_int64(g, "deposited", c.deposited), done);
    SC_CHECK(status, h5_attr_write_int64(g, "escaped", c.escaped), done);
    SC_CHECK(status, h5_attr_write_int64(g, "resting", c.resting), done);
    SC_CHECK(status, h5_attr_write_int64(g, "first_impact_deposits", c.first_impact_deposits), done);
    SC_CHECK(status, h5_attr_write_int64(g, "injection_deferred", s->injection_deferred), done);
    SC_CHECK(status, h5_attr_write_int64(g, "contacts_pair", c.contacts_pair), done);
    SC_CHECK(status, h5_attr_write_int64(g, "contacts_target", c.contacts_target), done);
    SC_CHECK(status, h5_attr_write_int64(g, "contacts_deposit", c.contacts_deposit), done);
    SC_CHECK(status, h5_attr_write_int64(g, "contacts_turned_away", c.contacts_turned_away), done);
    SC_CHECK(status, h5_attr_write_int64(g, "fixed_point_iterations", c.fixed_point_iterations), done);
    SC_CHECK(status, h5_attr_write_int64(g, "fixed_point_solves", c.fixed_point_solves), done);
    SC_CHECK(status, h5_attr_write_int64(g, "fixed_point_unconverged", c.fixed_point_unconverged), done);
    SC_CHECK(status, h5_attr_write_int64(g, "fixed_point_max_iterations", c.max_iterations), done);
    SC_CHECK(status, h5_attr_write_int64(g, "subcycled_particle_steps", c.subcycled_particle_steps), done);
    SC_CHECK(status, h5_attr_write_int64(g, "particle_steps", c.particle_steps), done);
    SC_CHECK(status, h5_attr_write_int64(g, "clamps", c.clamps), done);
    SC_CHECK(status, h5_attr_write_int64(g, "trapped", c.trapped), done);
done:
    H5Gclose(g);
    return status;
}

/* spray.h5 /nozzle (docs/files.md): the gas along the axis (/nozzle/profile) and each diameter's exit state
 * (/nozzle/particles), with the stagnation and exit states as attributes. */
static int write_nozzle_profile(hid_t nozzle, const struct dem_nozzle *n)
{
    hid_t g;
    SC_TRY(h5_create_group(nozzle, "profile", &g));
    int status = SC_OK;
    const struct dem_nozzle_station *r = n->profile;
    size_t count = DEM_NOZZLE_PROFILE_POINTS;
    COLUMN(g, r, count, struct dem_nozzle_station, x, 1, "m", 0);
    COLUMN(g, r, count, struct dem_nozzle_station, diameter, 1, "m", 0);
    COLUMN(g, r, count, struct dem_nozzle_station, mach, 1, "-", 0);
    COLUMN(g, r, count, struct dem_nozzle_station, pressure, 1, "Pa", 0);
    COLUMN(g, r, count, struct dem_nozzle_station, temperature, 1, "K", 0);
    COLUMN(g, r, count, struct dem_nozzle_station, density, 1, "kg/m3", 0);
    COLUMN(g, r, count, struct dem_nozzle_station, velocity, 1, "m/s", 0);
done:
    H5Gclose(g);
    return status;
}

static int write_nozzle_particles(hid_t nozzle, const struct dem_nozzle *n)
{
    hid_t g;
    SC_TRY(h5_create_group(nozzle, "particles", &g));
    hsize_t dims[1] = {DEM_NOZZLE_TABLE_ROWS};
    int status;
    SC_CHECK(status, h5_write_doubles(g, "diameter", 1, dims, n->table_diameter, "m", 0), done);
    SC_CHECK(status, h5_write_doubles(g, "velocity", 1, dims, n->table_velocity, "m/s", 0), done);
    SC_CHECK(status, h5_write_doubles(g, "temperature", 1, dims, n->table_temperature, "K", 0), done);
    SC_CHECK(status, h5_write_doubles(g, "time", 1, dims, n->table_time, "s", 0), done);
done:
    H5Gclose(g);
    return status;
}

/* injection_radius: the disc the particles were injected over (the exit's unless [spray] nozzle_radius was given,
 * dem/params.c nozzle_release): the case text records only the key's default, the figures draw this. */
static int write_nozzle(hid_t file, const struct dem_nozzle *n, double injection_radius)
{
    hid_t g;
    SC_TRY(h5_create_group(file, "nozzle", &g));
    int status;
    SC_CHECK(status, h5_attr_write_string(g, "gas", n->properties.name), done);
    SC_CHECK(status, h5_attr_write_double(g, "gamma", n->properties.gamma), done);
    SC_CHECK(status, h5_attr_write_double(g, "gas_constant", n->properties.gas_constant), done);
    SC_CHECK(status, h5_attr_write_double(g, "stagnation_pressure", n->stagnation_pressure), done);
    SC_CHECK(status, h5_attr_write_double(g, "stagnation_temperature", n->stagnation_temperature), done);
    SC_CHECK(status, h5_attr_write_double(g, "ambient_pressure", n->ambient_pressure), done);
    SC_CHECK(status, h5_attr_write_double(g, "exit_mach", n->exit.mach), done);
    SC_CHECK(status, h5_attr_write_double(g, "exit_pressure", n->exit.pressure), done);
    SC_CHECK(status, h5_attr_write_double(g, "exit_temperature", n->exit.temperature), done);
    SC_CHECK(status, h5_attr_write_double(g, "exit_density", n->exit.density), done);
    SC_CHECK(status, h5_attr_write_double(g, "exit_velocity", n->exit.velocity), done);
    SC_CHECK(status, h5_attr_write_double(g, "exit_diameter", n->exit_diameter), done);
    SC_CHECK(status, h5_attr_write_double(g, "injection_radius", injection_radius), done);
    SC_CHECK(status, write_nozzle_profile(g, n), done);
    SC_CHECK(status, write_nozzle_particles(g, n), done);
done:
    H5Gclose(g);
    return status;
}

int dem_write_output(const struct dem_solver *s, hid_t file)
{
    if (s->cfg.nozzle)
        SC_TRY(write_nozzle(file, s->cfg.nozzle, s->cfg.nozzle_radius));
    SC_TRY(write_particles(file, s, 0));
    SC_TRY(write_impacts(file, s));
    SC_TRY(write_handoffs(file, s));
    SC_TRY(write_metrics(file, s));
    SC_TRY(write_stats(file, s));
    SC_TRY(write_escapes(file, s));
    SC_TRY(write_deposition_efficiency(file, s));
    struct dem_deposit deposit;
    SC_TRY(dem_deposit_build(s, &deposit));
    int status = dem_deposit_write(&deposit, file);
    dem_deposit_free(&deposit);
    SC_TRY(status);
    return SC_OK;
}

/* ---------------------------------------------------------------- checkpoints */

/* Scalars of the solver state, in this order, in the dataset "counters". */
enum {
    COUNTER_STEP,
    COUNTER_INJECTED,
    COUNTER_ESCAPED,
    COUNTER_DEPOSITED,
    COUNTER_DEFERRED,
    COUNTER_RESTING,
    COUNTER_FIRST_IMPACT_DEPOSITS,
    COUNTER_COUNT
};

/* The drag kept at each particle's state and the step-end forces before it (struct dem_drag): the next step's
 * first iterate is guessed from them, so a resumed run needs them to give the same bits.  One struct
 * dem_drag_record per particle (its padding zero). */
static void drag_to_record(const struct dem_drag *drag, int64_t step, size_t i, struct dem_drag_record *record)
{
    memset(record, 0, sizeof *record);
    for (int c = 0; c < 3; c++) {
        record->force[c] = drag->forces[dem_drag_slot(step, 0)][c][i];
        record->previous[0][c] = drag->forces[dem_drag_slot(step, 1)][c][i];
        record->previous[1][c] = drag->forces[dem_drag_slot(step, 2)][c][i];
    }
    record->slip = drag->slip[i];
    record->reynolds_power = drag->reynolds_power[i];
    record->kept = drag->kept[i];
    record->history_count = drag->history_count[i];
}

static void drag_from_record(const struct dem_drag_record *record, int64_t step, struct dem_drag *drag, size_t i)
{
    for (int c = 0; c < 3; c++) {
        drag->forces[dem_drag_slot(step, 0)][c][i] = record->force[c];
        drag->forces[dem_drag_slot(step, 1)][c][i] = record->previous[0][c];
        drag->forces[dem_drag_slot(step, 2)][c][i] = record->previous[1][c];
    }
    drag->slip[i] = record->slip;
    drag->reynolds_power[i] = record->reynolds_power;
    drag->kept[i] = record->kept;
    drag->history_count[i] = record->history_count;
}

static int write_drag_state(hid_t group, const struct dem_particles *p, int64_t step)
{
    size_t bytes = (p->count ? p->count : 1) * sizeof(struct dem_drag_record);
    struct dem_drag_record *records = malloc(bytes);
    if (!records)
        SC_FAIL_OOM(bytes, "the drag records");
    for (size_t i = 0; i < p->count; i++)
        drag_to_record(&p->drag, step, i, &records[i]);
    int status = h5_write_bytes(group, "drag", p->count * sizeof *records, records, 1);
    free(records);
    SC_TRY(status);
    return SC_OK;
}

static int read_drag_state(hid_t group, struct dem_particles *p, int64_t step)
{
    size_t bytes;
    SC_TRY(h5_dataset_size(group, "drag", &bytes));
    if (bytes != p->count * sizeof(struct dem_drag_record))
        SC_FAIL(SC_EIO, "checkpoint dataset drag has %zu bytes, not %zu (one record per particle)", bytes,
                p->count * sizeof(struct dem_drag_record));
    if (!bytes)
        return SC_OK;
    struct dem_drag_record *records = malloc(bytes);
    if (!records)
        SC_FAIL_OOM(bytes, "the drag records");
    int status;
    SC_CHECK(status, h5_read_bytes(group, "drag", records, bytes), done);
    for (size_t i = 0; i < p->count; i++)
        drag_from_record(&records[i], step, &p->drag, i);
done:
    free(records);
    return status;
}

int dem_checkpoint_write(const struct dem_solver *s, hid_t group)
{
    int64_t counters[COUNTER_COUNT] = {
        s->step, s->injected, s->escaped, s->deposited, s->injection_deferred, s->resting, s->first_impact_deposits};
    hsize_t dims[1] = {COUNTER_COUNT};
    SC_TRY(h5_write_int64s(group, "counters", 1, dims, counters, "", 1));
    SC_TRY(h5_write_bytes(group, "stats", sizeof s->stats, &s->stats, 1));
    SC_TRY(write_particles(group, s, 1));
    SC_TRY(write_drag_state(group, &s->p, s->step));
    SC_TRY(h5_write_bytes(group, "impacts", s->impact_count * sizeof *s->impacts, s->impacts, 1));
    SC_TRY(h5_write_bytes(group, "handoffs", s->handoff_count * sizeof *s->handoffs, s->handoffs, 1));
    SC_TRY(h5_write_bytes(group, "metrics", s->metric_count * sizeof *s->metrics, s->metrics, 1));
    SC_TRY(h5_write_bytes(group, "escapes", s->escape_count * sizeof *s->escapes, s->escapes, 1));
    return SC_OK;
}

static int read_records(hid_t group, const char *name, void **items, size_t *count, size_t *capacity, size_t item_size)
{
    size_t bytes;
    SC_TRY(h5_dataset_size(group, name, &bytes));
    if (bytes % item_size != 0)
        SC_FAIL(SC_EIO, "checkpoint dataset %s has %zu bytes, not a multiple of %zu", name, bytes, item_size);
    free(*items);
    *items = malloc((bytes ? bytes : item_size));
    if (!*items) {
        *count = *capacity = 0;
        SC_FAIL_OOM(bytes ? bytes : item_size, name);
    }
    *count = bytes / item_size;
    *capacity = *count ? *count : 1;
    if (bytes)
        SC_TRY(h5_read_bytes(group, name, *items, bytes));
    return SC_OK;
}

static int read_particles(hid_t group, struct dem_particles *p)
{
    hid_t g = H5Gopen2(group, "particles", H5P_DEFAULT);
    if (g < 0)
        SC_FAIL(SC_EIO, "checkpoint has no /particles group");
    size_t n;
    int64_t *state = NULL;
    int status;
    SC_CHECK(status, h5_dataset_size(g, "id", &n), done);
    dem_particles_reserve(p, n ? n : 1);
    p->count = n;
    state = malloc((n ? n : 1) * sizeof *state);
    if (!state)
        SC_FAIL_OOM_AT(status, done, (n ? n : 1) * sizeof *state, "the particle states");
    SC_CHECK(status, h5_read_int64s(g, "id", p->id, n), done);
    SC_CHECK(status, h5_read_int64s(g, "state", state, n), done);
    for (size_t i = 0; i < n; i++)
        p->state[i] = (uint8_t)state[i];
    SC_CHECK(status, h5_read_doubles(g, "x", p->x, 3 * n), done);
    SC_CHECK(status, h5_read_doubles(g, "v", p->v, 3 * n), done);
    SC_CHECK(status, h5_read_doubles(g, "w", p->w, 3 * n), done);
    SC_CHECK(status, h5_read_doubles(g, "d", p->d, n), done);
    SC_CHECK(status, h5_read_doubles(g, "m", p->m, n), done);
    SC_CHECK(status, h5_read_doubles(g, "temperature", p->temperature, n), done);
done:
    free(state);
    H5Gclose(g);
    return status;
}

int dem_checkpoint_read(struct dem_solver *s, hid_t group)
{
    int64_t counters[COUNTER_COUNT];
    SC_TRY(h5_read_int64s(group, "counters", counters, COUNTER_COUNT));
    s->step = counters[COUNTER_STEP];
    s->injected = counters[COUNTER_INJECTED];
    s->escaped = counters[COUNTER_ESCAPED];
    s->deposited = counters[COUNTER_DEPOSITED];
    s->injection_deferred = counters[COUNTER_DEFERRED];
    s->resting = counters[COUNTER_RESTING];
    s->first_impact_deposits = counters[COUNTER_FIRST_IMPACT_DEPOSITS];
    SC_TRY(h5_read_bytes(group, "stats", &s->stats, sizeof s->stats));
    SC_TRY(read_particles(group, &s->p));
    SC_TRY(read_drag_state(group, &s->p, s->step));
    SC_TRY(read_records(group, "impacts", (void **)&s->impacts, &s->impact_count, &s->impact_capacity,
                        sizeof *s->impacts));
    if (s->contacts_of) /* derived: rebuilt */
        memset(s->contacts_of, 0, s->contacts_of_capacity * sizeof *s->contacts_of);
    for (size_t k = 0; k < s->impact_count; k++)
        ++*dem_contacts_of(s, s->impacts[k].particle_id);
    SC_TRY(read_records(group, "handoffs", (void **)&s->handoffs, &s->handoff_count, &s->handoff_capacity,
                        sizeof *s->handoffs));
    SC_TRY(read_records(group, "metrics", (void **)&s->metrics, &s->metric_count, &s->metric_capacity,
                        sizeof *s->metrics));
    SC_TRY(read_records(group, "escapes", (void **)&s->escapes, &s->escape_count, &s->escape_capacity,
                        sizeof *s->escapes));
    SC_TRY(dem_check_accounting(s));
    return SC_OK;
}

/* ---------------------------------------------------------------- snapshots */

int64_t dem_snapshot_steps(const struct dem_config *cfg)
{
    if (!(cfg->snapshot_every > 0))
        return 0;
    double steps = round(cfg->snapshot_every / cfg->dt);
    return steps < 1 ? 1 : (int64_t)fmin(steps, 9e18);
}

static void snapshot_free(struct dem_snapshot *snap)
{
    free(snap->id), free(snap->state), free(snap->x), free(snap->v), free(snap->d);
    memset(snap, 0, sizeof *snap);
}

void dem_snapshots_free(struct dem_snapshots *list)
{
    for (size_t i = 0; i < list->count; i++)
        snapshot_free(&list->items[i]);
    free(list->items);
    memset(list, 0, sizeof *list);
}

/* Room for one more snapshot of n particles at the end of the list (its arrays allocated). */
static int snapshot_append(struct dem_snapshots *list, size_t n, struct dem_snapshot **out)
{
    if (list->count == list->capacity) {
        size_t grown = list->capacity ? 2 * list->capacity : 16;
        struct dem_snapshot *more = realloc(list->items, grown * sizeof *more);
        if (!more)
            SC_FAIL_OOM(grown * sizeof *more, "the snapshot list");
        list->items = more, list->capacity = grown;
    }
    struct dem_snapshot *snap = &list->items[list->count];
    memset(snap, 0, sizeof *snap);
    size_t k = n ? n : 1;
    snap->count = n;
    snap->id = malloc(k * sizeof *snap->id), snap->state = malloc(k * sizeof *snap->state);
    snap->x = malloc(3 * k * sizeof *snap->x), snap->v = malloc(3 * k * sizeof *snap->v);
    snap->d = malloc(k * sizeof *snap->d);
    if (!snap->id || !snap->state || !snap->x || !snap->v || !snap->d) {
        snapshot_free(snap);
        SC_FAIL_OOM(k * 9 * sizeof(double), "a snapshot of the particles");
    }
    list->count++;
    *out = snap;
    return SC_OK;
}

int dem_snapshot_take(const struct dem_solver *s, struct dem_snapshots *list)
{
    const struct dem_particles *p = &s->p;
    struct dem_snapshot *snap;
    SC_TRY(snapshot_append(list, p->count, &snap));
    snap->step = s->step;
    snap->t = (double)s->step * s->cfg.dt;
    for (size_t i = 0; i < p->count; i++)
        snap->state[i] = p->state[i];
    memcpy(snap->id, p->id, p->count * sizeof *snap->id);
    memcpy(snap->x, p->x, 3 * p->count * sizeof *snap->x);
    memcpy(snap->v, p->v, 3 * p->count * sizeof *snap->v);
    memcpy(snap->d, p->d, p->count * sizeof *snap->d);
    return SC_OK;
}

static int snapshot_write(const struct dem_snapshot *snap, hid_t parent, size_t index, int checksum)
{
    char name[32];
    snprintf(name, sizeof name, "%06zu", index);
    hid_t g;
    SC_TRY(h5_create_group(parent, name, &g));
    hsize_t n1[1] = {snap->count}, n3[2] = {snap->count, 3};
    int status;
    SC_CHECK(status, h5_attr_write_double(g, "t", snap->t), done);
    SC_CHECK(status, h5_attr_write_int64(g, "step", snap->step), done);
    SC_CHECK(status, h5_write_int64s(g, "id", 1, n1, snap->id, "", checksum), done);
    SC_CHECK(status, h5_write_int64s(g, "state", 1, n1, snap->state, "0 flying, 1 deposited", checksum), done);
    SC_CHECK(status, h5_write_doubles(g, "x", 2, n3, snap->x, "m", checksum), done);
    SC_CHECK(status, h5_write_doubles(g, "v", 2, n3, snap->v, "m/s", checksum), done);
    SC_CHECK(status, h5_write_doubles(g, "d", 1, n1, snap->d, "m", checksum), done);
done:
    H5Gclose(g);
    return status;
}

int dem_snapshots_write(const struct dem_snapshots *list, hid_t loc, int checksum)
{
    hid_t g;
    SC_TRY(h5_create_group(loc, "snapshots", &g));
    int status = SC_OK;
    size_t most = 0;
    int64_t *index = NULL;
    SC_CHECK(status, h5_attr_write_int64(g, "count", (int64_t)list->count), done);
    for (size_t i = 0; i < list->count; i++) {
        SC_CHECK(status, snapshot_write(&list->items[i], g, i, checksum), done);
        most = list->items[i].count > most ? list->items[i].count : most;
    }
    /* 0 1 .. : the vertex cells of every snapshot for spray.xdmf (a hyperslab of its first n) */
    index = malloc((most ? most : 1) * sizeof *index);
    if (!index)
        SC_FAIL_OOM_AT(status, done, (most ? most : 1) * sizeof *index, "the snapshot index");
    for (size_t i = 0; i < most; i++)
        index[i] = (int64_t)i;
    hsize_t dims[1] = {most};
    SC_CHECK(status, h5_write_int64s(g, "index", 1, dims, index, "", checksum), done);
done:
    free(index);
    H5Gclose(g);
    return status;
}

static int snapshot_read(hid_t parent, size_t index, struct dem_snapshots *list)
{
    char name[32];
    snprintf(name, sizeof name, "%06zu", index);
    hid_t g = H5Gopen2(parent, name, H5P_DEFAULT);
    if (g < 0)
        SC_FAIL(SC_EIO, "snapshots: no group %s", name);
    size_t n;
    struct dem_snapshot *snap;
    int status;
    SC_CHECK(status, h5_dataset_size(g, "id", &n), done);
    SC_CHECK(status, snapshot_append(list, n, &snap), done);
    SC_CHECK(status, h5_attr_read_double(g, "t", &snap->t), done);
    SC_CHECK(status, h5_attr_read_int64(g, "step", &snap->step), done);
    SC_CHECK(status, h5_read_int64s(g, "id", snap->id, n), done);
    SC_CHECK(status, h5_read_int64s(g, "state", snap->state, n), done);
    SC_CHECK(status, h5_read_doubles(g, "x", snap->x, 3 * n), done);
    SC_CHECK(status, h5_read_doubles(g, "v", snap->v, 3 * n), done);
    SC_CHECK(status, h5_read_doubles(g, "d", snap->d, n), done);
done:
    H5Gclose(g);
    return status;
}

int dem_snapshots_read(hid_t loc, struct dem_snapshots *list)
{
    dem_snapshots_free(list);
    if (!h5_exists(loc, "snapshots"))
        return SC_OK;
    hid_t g = H5Gopen2(loc, "snapshots", H5P_DEFAULT);
    if (g < 0)
        SC_FAIL(SC_EIO, "cannot open the group snapshots");
    int64_t count = 0;
    int status;
    SC_CHECK(status, h5_attr_read_int64(g, "count", &count), done);
    for (int64_t i = 0; i < count; i++)
        SC_CHECK(status, snapshot_read(g, (size_t)i, list), done);
done:
    H5Gclose(g);
    return status;
}
