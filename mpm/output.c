/* impact.h5 contents (snapshots, series, summary, stats) and the impact stage's checkpoints. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/h5io.h"
#include "mpm/mpm_impl.h"

static size_t active_count(const struct mpm_points *p)
{
    size_t n = 0;
    for (size_t q = 0; q < p->count; q++)
        n += (p->flags[q] & POINT_ACTIVE) != 0;
    return n;
}

static double von_mises(const double *s)
{
    double p = (s[0] + s[1] + s[2]) / 3.0;
    double a = s[0] - p, b = s[1] - p, c = s[2] - p;
    return sqrt(1.5 * (a * a + b * b + c * c + 2.0 * (s[3] * s[3] + s[4] * s[4] + s[5] * s[5])));
}

/* Gather a field of the active points into out (width values each). */
enum field { F_X, F_V, F_EPS_P, F_T, F_D_BOND, F_PRESSURE, F_VON_MISES, F_RHO, F_BODY, F_ID, F_SURFACE };

static void gather(const struct mpm_points *p, enum field f, double *out)
{
    size_t k = 0;
    for (size_t i = 0; i < p->count; i++) {
        size_t q = p->slot[i]; /* in id order, whatever the storage order */
        if (!(p->flags[q] & POINT_ACTIVE))
            continue;
        const struct mpm_point_state *s = &p->state[q];
        switch (f) {
        case F_X:
            memcpy(out + 3 * k, p->x + 3 * q, 3 * sizeof *out);
            break;
        case F_V:
            memcpy(out + 3 * k, p->v + 3 * q, 3 * sizeof *out);
            break;
        case F_EPS_P:
            out[k] = s->eps_p;
            break;
        case F_T:
            out[k] = s->T;
            break;
        case F_D_BOND:
            out[k] = p->d_bond[q];
            break;
        case F_PRESSURE:
            out[k] = s->pressure;
            break;
        case F_VON_MISES:
            out[k] = von_mises(s->stress);
            break;
        case F_RHO:
            out[k] = s->rho;
            break;
        case F_BODY:
            out[k] = p->body[q];
            break;
        case F_ID:
            out[k] = (double)i;
            break;
        case F_SURFACE:
            out[k] = (p->flags[q] & POINT_SURFACE) != 0;
            break;
        }
        k++;
    }
}

int mpm_write_snapshot(const struct mpm_solver *s, hid_t group)
{
    SC_TRY(mpm_gpu_sync(s)); /* the points from the device ([run] device = gpu) */
    static const struct {
        const char *name;
        enum field field;
        int width;
        const char *units;
        int integer;
    } fields[] = {
        {"x", F_X, 3, "m", 0},
        {"v", F_V, 3, "m/s", 0},
        {"eps_p", F_EPS_P, 1, "-", 0},
        {"T", F_T, 1, "K", 0},
        {"D_bond", F_D_BOND, 1, "-", 0},
        {"pressure", F_PRESSURE, 1, "Pa", 0},
        {"von_mises", F_VON_MISES, 1, "Pa", 0},
        {"rho", F_RHO, 1, "kg/m3", 0},
        {"body", F_BODY, 1, "-", 1},
        {"id", F_ID, 1, "-", 1},
        {"surface", F_SURFACE, 1, "-", 1},
    };
    const struct mpm_points *p = &s->points;
    size_t n = active_count(p);
    int status = SC_OK;
    double *buffer = malloc((3 * n + 1) * sizeof *buffer);
    int64_t *integers = malloc((n + 1) * sizeof *integers);
    if (!buffer)
        SC_FAIL_OOM_AT(status, done, (3 * n + 1) * sizeof *buffer, "a snapshot field");
    if (!integers)
        SC_FAIL_OOM_AT(status, done, (n + 1) * sizeof *integers, "a snapshot field");
    for (size_t f = 0; f < sizeof fields / sizeof fields[0]; f++) {
        hsize_t dims[2] = {n, 3};
        gather(p, fields[f].field, buffer);
        if (fields[f].integer) {
            for (size_t k = 0; k < n; k++)
                integers[k] = (int64_t)buffer[k];
            SC_CHECK(status, h5_write_int64s(group, fields[f].name, 1, dims, integers, fields[f].units, 0), done);
        } else {
            SC_CHECK(
                status,
                h5_write_doubles(group, fields[f].name, fields[f].width == 3 ? 2 : 1, dims, buffer, fields[f].units, 0),
                done);
        }
    }
    SC_CHECK(status, h5_attr_write_double(group, "t", s->t), done);
    SC_CHECK(status, h5_attr_write_int64(group, "step", s->step), done);
done:
    free(buffer);
    free(integers);
    return status;
}

/* Column `column` of every body out of the recorded series rows into out (rows x bodies). */
static void series_column(const struct mpm_solver *s, int column, double *out)
{
    int nb = s->cfg.body_count;
    size_t width = SERIES_FIXED + (size_t)nb * SERIES_PER_BODY;
    for (size_t r = 0; r < s->series_rows; r++)
        for (int b = 0; b < nb; b++)
            out[r * (size_t)nb + (size_t)b] =
                s->series[r * width + SERIES_FIXED + (size_t)b * SERIES_PER_BODY + column];
}

static int write_series(const struct mpm_solver *s, hid_t group)
{
    static const struct {
        const char *name;
        int column;
        const char *units;
    } per_body[] = {
        {"ke", 3, "J"},
        {"internal_energy", 4, "J"},
        {"plastic_work", 5, "J"},
        {"mean_eps_p", 6, "-"},
        {"plastic_energy_density", 7, "J/m3"},
        {"pbcp", 8, "-"},
        {"v_rest", 9, "m/s"},
        {"mean_d_bond", 10, "-"},
        {"contacted_points", 11, "-"},
        {"bonded_points", 12, "-"},
        {"interface_nodes", 13, "-"},
        {"bonded_nodes", 14, "-"},
    };
    size_t nt = s->series_rows, nb = (size_t)s->cfg.body_count, width = SERIES_FIXED + nb * SERIES_PER_BODY;
    double *buffer = malloc((3 * nt * nb + 1) * sizeof *buffer);
    if (!buffer)
        SC_FAIL_OOM((3 * nt * nb + 1) * sizeof *buffer, "the impact series");
    int status = SC_OK;
    static const char *const fixed[] = {"t", "energy_total", "energy_absorbed", "energy_removed"};
    static const char *const fixed_units[] = {"s", "J", "J", "J"};
    for (int c = 0; c < SERIES_FIXED; c++) {
        for (size_t r = 0; r < nt; r++)
            buffer[r] = s->series[r * width + (size_t)c];
        hsize_t dims[1] = {nt};
        SC_CHECK(status, h5_write_doubles(group, fixed[c], 1, dims, buffer, fixed_units[c], 0), done);
    }
    for (size_t f = 0; f < sizeof per_body / sizeof per_body[0]; f++) {
        series_column(s, per_body[f].column, buffer);
        hsize_t dims[2] = {nt, nb};
        SC_CHECK(status, h5_write_doubles(group, per_body[f].name, 2, dims, buffer, per_body[f].units, 0), done);
    }
    for (size_t r = 0; r < nt; r++)
        for (size_t b = 0; b < nb; b++)
            for (int d = 0; d < 3; d++)
                buffer[(r * nb + b) * 3 + (size_t)d] =
                    s->series[r * width + SERIES_FIXED + b * SERIES_PER_BODY + (size_t)d];
    hsize_t dims[3] = {nt, nb, 3};
    SC_CHECK(status, h5_write_doubles(group, "v_com", 3, dims, buffer, "m/s", 0), done);
done:
    free(buffer);
    return status;
}

/* How many bodies run off the resolution their shipped bonding parameters were calibrated at
 * (mpm_bonding_calibrated_resolution): their verdicts are not calibrated; -1 when no body is judged. */
static int64_t uncalibrated_bodies(const struct mpm_config *cfg)
{
    int64_t judged = 0, off = 0;
    for (int b = 0; b < cfg->body_count; b++) {
        int calibrated = mpm_bonding_calibrated_resolution(cfg, b);
        judged += calibrated >= 0;
        off += calibrated == 0;
    }
    return judged ? off : -1;
}

static int write_summary(struct mpm_solver *s, hid_t group)
{
    int nb = s->cfg.body_count;
    double *values = calloc((size_t)nb * 8, sizeof *values);
    int64_t *integers = calloc((size_t)nb * 4, sizeof *integers);
    int *verdict = calloc((size_t)nb, sizeof *verdict);
    int status = SC_OK;
    if (!values || !integers || !verdict)
        SC_FAIL_OOM_AT(status, done, (size_t)nb * (8 * sizeof *values + 4 * sizeof *integers + sizeof *verdict),
                       "the impact summary");
    mpm_verdicts(s, verdict);
    const struct mpm_diagnostics *d = mpm_final_diagnostics(s);
    double *diameter = values, *v_impact = values + nb, *pbcp = values + 2 * nb, *v_rest = values + 3 * nb,
           *cor = values + 4 * nb, *t_settled = values + 5 * nb, *bonding_scale = values + 6 * nb,
           *bonded_interface = values + 7 * nb;
    int64_t *bonded = integers, *substrate = integers + nb, *verdicts = integers + 2 * nb, *settled = integers + 3 * nb;
    for (int b = 0; b < nb; b++) {
        diameter[b] = s->cfg.bodies[b].d;
        v_impact[b] = s->body_speed[b];
        pbcp[b] = d->body[b].pbcp;
        /* the window mean the verdict is judged on; the last row's value while there is none */
        v_rest[b] = isnan(mpm_verdict_vrest(s, b)) ? d->body[b].v_rest : mpm_verdict_vrest(s, b);
        cor[b] = v_impact[b] > 0 ? v_rest[b] / v_impact[b] : NAN; /* restitution ratio */
        t_settled[b] = mpm_verdict_settled_at(s, b);
        verdicts[b] = verdict[b];
        /* 1 only for a settled bond: a reader of `bonded` alone never takes an unsettled body for bonded */
        bonded[b] = verdict[b] == MPM_VERDICT_SUBSTRATE ? -1 : verdict[b] == MPM_VERDICT_BONDED;
        settled[b] = !isnan(t_settled[b]);
        substrate[b] = s->cfg.bodies[b].substrate;
        bonding_scale[b] = s->body_bond_scale[b];
        bonded_interface[b] = d->body[b].bonded_interface;
    }
    hsize_t dims[1] = {(hsize_t)nb};
    SC_CHECK(status, h5_write_doubles(group, "diameter", 1, dims, diameter, "m", 0), done);
    SC_CHECK(status, h5_write_doubles(group, "v_impact", 1, dims, v_impact, "m/s", 0), done);
    SC_CHECK(status, h5_write_int64s(group, "bonded", 1, dims, bonded, "-", 0), done);
    SC_CHECK(status, h5_write_int64s(group, "verdict", 1, dims, verdicts, "-", 0), done);
    SC_CHECK(status, h5_write_int64s(group, "settled", 1, dims, settled, "-", 0), done);
    SC_CHECK(status, h5_write_doubles(group, "t_settled", 1, dims, t_settled, "s", 0), done);
    SC_CHECK(status, h5_write_doubles(group, "pbcp", 1, dims, pbcp, "-", 0), done);
    SC_CHECK(status, h5_write_doubles(group, "v_rest", 1, dims, v_rest, "m/s", 0), done);
    SC_CHECK(status, h5_write_doubles(group, "cor", 1, dims, cor, "-", 0), done);
    SC_CHECK(status, h5_write_int64s(group, "substrate", 1, dims, substrate, "-", 0), done);
    SC_CHECK(status, h5_write_doubles(group, "bonding_scale", 1, dims, bonding_scale, "-", 0), done);
    SC_CHECK(status, h5_write_doubles(group, "bonded_interface", 1, dims, bonded_interface, "-", 0), done);
    /* the thresholds the verdicts were judged with: a reader tells "at rest but too few bonds" from "left" */
    SC_CHECK(status, h5_attr_write_double(group, "pbcp_threshold", s->cfg.pbcp_threshold), done);
    SC_CHECK(status, h5_attr_write_double(group, "vrest_threshold", s->cfg.vrest_threshold), done);
    /* the particles off the resolution their shipped bonding parameters belong to (-1: none judged) */
    SC_CHECK(status, h5_attr_write_int64(group, "uncalibrated_bodies", uncalibrated_bodies(&s->cfg)), done);
done:
    free(values), free(integers), free(verdict);
    return status;
}

static int write_stats(const struct mpm_solver *s, hid_t group)
{
    SC_TRY(h5_attr_write_int64(group, "steps", s->step));
    SC_TRY(h5_attr_write_int64(group, "points", (int64_t)s->points.count));
    /* the stats are of the modelled part: the whole set-up is this many copies of it ([impact] symmetry) */
    SC_TRY(h5_attr_write_int64(group, "mirror_copies", mpm_mirror_copies(&s->cfg)));
    SC_TRY(h5_attr_write_int64(group, "point_updates", s->point_updates));
    SC_TRY(h5_attr_write_int64(group, "removed_points", s->removed_points));
    SC_TRY(h5_attr_write_double(group, "removed_mass", s->removed_mass));
    SC_TRY(h5_attr_write_int64(group, "contact_node_steps", s->contact_node_steps));
    SC_TRY(h5_attr_write_int64(group, "bonded_node_steps", s->bonded_node_steps));
    SC_TRY(h5_attr_write_double(group, "energy_initial", s->energy_initial));
    SC_TRY(h5_attr_write_double(group, "t_end", s->t));
    SC_TRY(h5_attr_write_int64(group, "grid_nodes", (int64_t)s->grid.nodes));
    /* the run's resolution: [impact]'s, or scaled to its particle ([couple] reference_diameter) */
    SC_TRY(h5_attr_write_double(group, "grid", s->cfg.grid));
    SC_TRY(h5_attr_write_double(group, "spacing", s->cfg.spacing));
    return SC_OK;
}

static int write_group(hid_t parent, const char *name, int (*writer)(struct mpm_solver *, hid_t), struct mpm_solver *s)
{
    hid_t group;
    SC_TRY(h5_create_group(parent, name, &group));
    int status;
    SC_CHECK(status, writer(s, group), done);
done:
    H5Gclose(group);
    return status;
}

static int series_writer(struct mpm_solver *s, hid_t g)
{
    return write_series(s, g);
}
static int stats_writer(struct mpm_solver *s, hid_t g)
{
    return write_stats(s, g);
}

int mpm_write_results(struct mpm_solver *s, hid_t parent)
{
    SC_TRY(write_group(parent, "series", series_writer, s));
    SC_TRY(write_group(parent, "summary", write_summary, s));
    SC_TRY(write_group(parent, "stats", stats_writer, s));
    return SC_OK;
}

/* ---- checkpoints ---- */

#define CHECKPOINT_DOUBLES  12
#define CHECKPOINT_INTEGERS 7

/* A copy of a per-point array (size bytes a point) in id order: checkpoints hold the points in set-up order,
 * as before the storage order changed during a run (point_order.c), so the file layout is unchanged. */
static void *in_id_order(const struct mpm_points *p, const void *data, size_t size)
{
    char *out = malloc(p->count * size + 1);
    if (out)
        for (size_t i = 0; i < p->count; i++)
            memcpy(out + i * size, (const char *)data + p->slot[i] * size, size);
    return out;
}

static int write_point_doubles(hid_t g, const char *name, const struct mpm_points *p, const double *data, int width,
                               const char *units)
{
    hsize_t dims[2] = {p->count, (hsize_t)width};
    double *ordered = in_id_order(p, data, (size_t)width * sizeof *data);
    if (!ordered)
        SC_FAIL_OOM(p->count * (size_t)width * sizeof *data + 1, name);
    int status = h5_write_doubles(g, name, width > 1 ? 2 : 1, dims, ordered, units, 1);
    free(ordered);
    SC_TRY(status);
    return SC_OK;
}

static int write_point_bytes(hid_t g, const char *name, const struct mpm_points *p, const void *data, size_t size)
{
    void *ordered = in_id_order(p, data, size);
    if (!ordered)
        SC_FAIL_OOM(p->count * size + 1, name);
    int status = h5_write_bytes(g, name, p->count * size, ordered, 1);
    free(ordered);
    SC_TRY(status);
    return SC_OK;
}

int mpm_checkpoint_write(const struct mpm_solver *s, hid_t g)
{
    SC_TRY(mpm_gpu_sync(s)); /* the points from the device ([run] device = gpu) */
    const struct mpm_points *p = &s->points;
    double scalars[CHECKPOINT_DOUBLES] = {s->t,
                                          s->dt,
                                          s->next_series,
                                          s->next_snapshot,
                                          s->removed_mass,
                                          s->energy_absorbed,
                                          s->energy_removed,
                                          s->energy_initial,
                                          0,
                                          0,
                                          0,
                                          0};
    int64_t integers[CHECKPOINT_INTEGERS] = {
        s->step,          s->snapshot_count,     s->snapshot_pending, s->removed_points,
        s->point_updates, s->contact_node_steps, s->bonded_node_steps};
    hsize_t ds[1] = {CHECKPOINT_DOUBLES}, is[1] = {CHECKPOINT_INTEGERS};
    size_t width = SERIES_FIXED + (size_t)s->cfg.body_count * SERIES_PER_BODY;
    hsize_t series_dims[2] = {s->series_rows, width};
    SC_TRY(h5_write_doubles(g, "scalars", 1, ds, scalars, NULL, 1));
    SC_TRY(h5_write_int64s(g, "integers", 1, is, integers, NULL, 1));
    SC_TRY(h5_write_doubles(g, "series", 2, series_dims, s->series, NULL, 1));
    SC_TRY(write_point_doubles(g, "x", p, p->x, 3, "m"));
    SC_TRY(write_point_doubles(g, "v", p, p->v, 3, "m/s"));
    SC_TRY(write_point_doubles(g, "normal", p, p->normal, 3, "-"));
    SC_TRY(write_point_doubles(g, "mass", p, p->mass, 1, "kg"));
    SC_TRY(write_point_doubles(g, "volume0", p, p->volume0, 1, "m3"));
    SC_TRY(write_point_doubles(g, "volume", p, p->volume, 1, "m3"));
    SC_TRY(write_point_doubles(g, "d_bond", p, p->d_bond, 1, "-"));
    SC_TRY(write_point_doubles(g, "plastic_work", p, p->plastic_work, 1, "J"));
    /* the point state as its struct bytes: MPM_FORMAT_VERSION changes when struct mpm_point_state does */
    SC_TRY(write_point_bytes(g, "state", p, p->state, sizeof *p->state));
    SC_TRY(write_point_bytes(g, "body", p, p->body, sizeof *p->body));
    SC_TRY(write_point_bytes(g, "flags", p, p->flags, sizeof *p->flags));
    /* transfer = apic: C_p (9 a point, row-major); a flip run's checkpoint has no such dataset, as before */
    if (p->affine)
        SC_TRY(write_point_doubles(g, "affine", p, p->affine, 9, "1/s"));
    return SC_OK;
}

int mpm_checkpoint_read(struct mpm_solver *s, hid_t g)
{
    struct mpm_points *p = &s->points;
    size_t n = p->count, count;
    s->vmax2_known = 0; /* the velocities read: the next time step from them */
    SC_TRY(h5_dataset_size(g, "mass", &count));
    if (count != n)
        SC_FAIL(SC_EINPUT, "impact checkpoint holds %zu material points, this case makes %zu", count, n);
    double scalars[CHECKPOINT_DOUBLES];
    int64_t integers[CHECKPOINT_INTEGERS];
    SC_TRY(h5_read_doubles(g, "scalars", scalars, CHECKPOINT_DOUBLES));
    SC_TRY(h5_read_int64s(g, "integers", integers, CHECKPOINT_INTEGERS));
    size_t width = SERIES_FIXED + (size_t)s->cfg.body_count * SERIES_PER_BODY;
    SC_TRY(h5_dataset_size(g, "series", &count));
    if (count % width != 0)
        SC_FAIL(SC_EINPUT, "impact checkpoint: series of %zu values is not a whole number of rows", count);
    double *series = malloc((count + 1) * sizeof *series);
    if (!series)
        SC_FAIL_OOM((count + 1) * sizeof *series, "the impact series");
    free(s->series);
    s->series = series;
    s->series_rows = s->series_capacity = count / width;
    SC_TRY(h5_read_doubles(g, "series", s->series, count));
    SC_TRY(h5_read_doubles(g, "x", p->x, 3 * n));
    SC_TRY(h5_read_doubles(g, "v", p->v, 3 * n));
    SC_TRY(h5_read_doubles(g, "normal", p->normal, 3 * n));
    SC_TRY(h5_read_doubles(g, "mass", p->mass, n));
    SC_TRY(h5_read_doubles(g, "volume0", p->volume0, n));
    SC_TRY(h5_read_doubles(g, "volume", p->volume, n));
    SC_TRY(h5_read_doubles(g, "d_bond", p->d_bond, n));
    SC_TRY(h5_read_doubles(g, "plastic_work", p->plastic_work, n));
    SC_TRY(h5_read_bytes(g, "state", p->state, n * sizeof *p->state));
    SC_TRY(h5_read_bytes(g, "body", p->body, n * sizeof *p->body));
    SC_TRY(h5_read_bytes(g, "flags", p->flags, n * sizeof *p->flags));
    if (p->affine) {
        if (!h5_exists(g, "affine"))
            SC_FAIL(SC_EINPUT, "impact checkpoint: no affine matrices (written with transfer = flip); resume it with "
                               "transfer = flip, or start the apic run again");
        SC_TRY(h5_read_doubles(g, "affine", p->affine, 9 * n));
    }
    mpm_points_order_reset(p); /* the file holds the points in id order */
    s->t = scalars[0], s->dt = scalars[1], s->next_series = scalars[2], s->next_snapshot = scalars[3];
    s->removed_mass = scalars[4], s->energy_absorbed = scalars[5], s->energy_removed = scalars[6];
    s->energy_initial = scalars[7];
    s->step = integers[0], s->snapshot_count = integers[1], s->snapshot_pending = (int)integers[2];
    s->removed_points = integers[3], s->point_updates = integers[4], s->contact_node_steps = integers[5];
    s->bonded_node_steps = integers[6];
    mpm_verdict_replay(s);    /* derived from the series read back */
    return mpm_gpu_reload(s); /* a checkpoint of either device, onto the GPU ([run] device = gpu) */
}
