/* The deposition efficiency (DE) of a spray run by mass, and its split by particle size and by the angle of the
 * first impact (docs/physics.md, "Deposition efficiency").  DE is the coating engineer's figure: the mass that
 * stays on the substrate over the mass of powder fed (what a weighed substrate and powder feeder measure), not
 * the count fraction N_dep/N_inj of Mukherjee & Zohdi Section 5.2, which weighs a 10 um particle as much as a
 * 30 um one (27 times its mass).  Computed from the solver's state at the end: the particles still held (flying,
 * deposited, resting), the escaped ones (s->escapes) and the first contacts of /impacts. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/h5io.h"
#include "dem/dem_impl.h"

/* The class of x among count classes of equal width over [lo, hi]; x outside goes to the nearest end. */
static size_t class_of(double x, double lo, double hi, size_t count)
{
    if (!(hi > lo) || !(x > lo))
        return 0;
    double k = floor((x - lo) / (hi - lo) * (double)count);
    return k >= (double)count ? count - 1 : (size_t)k;
}

static void add_sprayed(struct dem_de_class *c, double m)
{
    c->sprayed_mass += m;
    c->sprayed_count++;
}

static void add_deposited(struct dem_de_class *c, double m)
{
    c->deposited_mass += m;
    c->deposited_count++;
}

static void finish_classes(struct dem_de_class *classes, size_t count)
{
    for (size_t k = 0; k < count; k++)
        classes[k].de = classes[k].sprayed_mass > 0 ? classes[k].deposited_mass / classes[k].sprayed_mass : 0.0;
}

/* The size range of the classes: the powder's truncation where it has one, else the sprayed diameters' range. */
static void size_range(const struct dem_solver *s, double *lo, double *hi)
{
    const struct dem_size_distribution *sizes = &s->cfg.sizes;
    if (s->cfg.injection == DEM_INJECT_STREAM && !sizes->monodisperse && sizes->d_min > 0 && isfinite(sizes->d_max)) {
        *lo = sizes->d_min;
        *hi = sizes->d_max;
        return;
    }
    *lo = INFINITY;
    *hi = -INFINITY;
    for (size_t i = 0; i < s->p.count; i++)
        *lo = fmin(*lo, s->p.d[i]), *hi = fmax(*hi, s->p.d[i]);
    for (size_t k = 0; k < s->escape_count; k++)
        *lo = fmin(*lo, s->escapes[k].d), *hi = fmax(*hi, s->escapes[k].d);
    if (!(*hi >= *lo))
        *lo = *hi = s->cfg.sizes.median_diameter;
}

static void split_by_size(const struct dem_solver *s, struct dem_deposition_efficiency *de)
{
    double lo, hi;
    size_range(s, &lo, &hi);
    size_t n = de->size_count;
    for (size_t k = 0; k < n; k++) {
        de->by_size[k].lo = lo + (hi - lo) * (double)k / (double)n;
        de->by_size[k].hi = k + 1 == n ? hi : lo + (hi - lo) * (double)(k + 1) / (double)n;
    }
    const struct dem_particles *p = &s->p;
    for (size_t i = 0; i < p->count; i++) {
        struct dem_de_class *c = &de->by_size[class_of(p->d[i], lo, hi, n)];
        add_sprayed(c, p->m[i]);
        if (p->state[i] == DEM_DEPOSITED)
            add_deposited(c, p->m[i]);
    }
    for (size_t k = 0; k < s->escape_count; k++)
        add_sprayed(&de->by_size[class_of(s->escapes[k].d, lo, hi, n)], s->escapes[k].m);
}

/* Is the particle of this id deposited?  The particles are held in order of id. */
static int is_deposited(const struct dem_particles *p, int64_t id)
{
    size_t lo = 0, hi = p->count;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (p->id[mid] < id)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo < p->count && p->id[lo] == id && p->state[lo] == DEM_DEPOSITED;
}

static int compare_ids(const void *a, const void *b)
{
    int64_t x = *(const int64_t *)a, y = *(const int64_t *)b;
    return (x > y) - (x < y);
}

static int has_impact(const int64_t *sorted, size_t count, int64_t id)
{
    return bsearch(&id, sorted, count, sizeof *sorted, compare_ids) != NULL;
}

/* The mass and number sprayed without an impact (still in flight, or escaped without touching): summed over
 * those particles rather than taken as a difference, so that none gives exactly 0. */
static int sum_unimpacted(const struct dem_solver *s, struct dem_deposition_efficiency *de)
{
    size_t count = 0;
    int64_t *ids = malloc((s->impact_count ? s->impact_count : 1) * sizeof *ids);
    if (!ids)
        SC_FAIL_OOM(s->impact_count * sizeof *ids, "the ids of the first impacts");
    for (size_t r = 0; r < s->impact_count; r++)
        if (s->impacts[r].contact_index == 0)
            ids[count++] = s->impacts[r].particle_id;
    qsort(ids, count, sizeof *ids, compare_ids);
    for (size_t i = 0; i < s->p.count; i++)
        if (!has_impact(ids, count, s->p.id[i]))
            de->unimpacted_mass += s->p.m[i], de->unimpacted_count++;
    for (size_t k = 0; k < s->escape_count; k++)
        if (!has_impact(ids, count, s->escapes[k].particle_id))
            de->unimpacted_mass += s->escapes[k].m, de->unimpacted_count++;
    free(ids);
    return SC_OK;
}

/* The angle of an impact velocity to the line of the target normal (the spray axis; the target faces -z), 0 to 90
 * degrees: a first contact with a deposited particle met from the side can move away from the target (v_z < 0), and
 * render/spray_figures.c's histogram of the same impacts folds it the same way. */
static double impact_angle(const double v[3])
{
    double speed = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    return speed > 0 ? acos(fmin(1.0, fabs(v[2]) / speed)) : 0.0;
}

static void split_by_angle(const struct dem_solver *s, struct dem_deposition_efficiency *de)
{
    size_t n = de->angle_count;
    double width = s->cfg.de_angle_class_width;
    for (size_t k = 0; k < n; k++) {
        de->by_angle[k].lo = width * (double)k;
        de->by_angle[k].hi = fmin(width * (double)(k + 1), 0.5 * M_PI);
    }
    double speed_sum = 0, normal_sum = 0;
    int64_t impacted = 0;
    for (size_t r = 0; r < s->impact_count; r++) {
        const struct dem_impact *row = &s->impacts[r];
        if (row->contact_index != 0)
            continue;
        double angle = impact_angle(row->v_in);
        struct dem_de_class *c = &de->by_angle[class_of(angle, 0.0, width * (double)n, n)];
        add_sprayed(c, row->m);
        if (is_deposited(&s->p, row->particle_id))
            add_deposited(c, row->m);
        impacted++;
        speed_sum += sqrt(row->v_in[0] * row->v_in[0] + row->v_in[1] * row->v_in[1] + row->v_in[2] * row->v_in[2]);
        normal_sum += row->v_in[2];
    }
    /* NaN without an impact: no speed was measured (0 m/s read as a measurement in the sweep's map) */
    de->mean_impact_speed = impacted ? speed_sum / (double)impacted : NAN;
    de->mean_impact_normal_speed = impacted ? normal_sum / (double)impacted : NAN;
}

/* Whether x lies beyond [lo, hi] (a value at an end, written and read back, counts as inside). */
static int beyond(double x, double lo, double hi)
{
    return x < lo * (1.0 - 1e-12) || x > hi * (1.0 + 1e-12);
}

/* rule = table: how many impacts the table judged, and how many of them beyond its grid (dem_vcrit_lookup clamps
 * them to its edge: a finer, coarser, colder or hotter particle than the search's gets the edge's v_crit). */
static void count_table_reach(const struct dem_solver *s, struct dem_deposition_efficiency *de)
{
    const struct dem_config *cfg = &s->cfg;
    if (cfg->rule != DEM_DEPOSIT_TABLE || cfg->table_count == 0)
        return;
    size_t nd = cfg->table_count, nt = cfg->table_temperature_count;
    for (size_t r = 0; r < s->impact_count; r++) {
        const struct dem_impact *row = &s->impacts[r];
        de->table_impacts++;
        de->table_impacts_outside +=
            beyond(row->d, cfg->table_diameter[0], cfg->table_diameter[nd - 1]) ||
            (nt > 0 && beyond(row->temperature, cfg->table_temperature[0], cfg->table_temperature[nt - 1]));
    }
}

int dem_deposition_efficiency(const struct dem_solver *s, struct dem_deposition_efficiency *de)
{
    memset(de, 0, sizeof *de);
    de->size_count = s->cfg.de_size_classes > 0 ? (size_t)s->cfg.de_size_classes : 1;
    double width = s->cfg.de_angle_class_width > 0 ? s->cfg.de_angle_class_width : 0.5 * M_PI;
    de->angle_count = (size_t)ceil(0.5 * M_PI / width * (1.0 - 1e-12));
    de->by_size = calloc(de->size_count, sizeof *de->by_size);
    de->by_angle = calloc(de->angle_count, sizeof *de->by_angle);
    if (!de->by_size || !de->by_angle) {
        dem_deposition_efficiency_free(de);
        SC_FAIL_OOM((de->size_count + de->angle_count) * sizeof *de->by_size, "the deposition efficiency classes");
    }
    split_by_size(s, de);
    for (size_t k = 0; k < de->size_count; k++) {
        de->sprayed_mass += de->by_size[k].sprayed_mass;
        de->deposited_mass += de->by_size[k].deposited_mass;
        de->sprayed_count += de->by_size[k].sprayed_count;
        de->deposited_count += de->by_size[k].deposited_count;
    }
    de->de = de->sprayed_mass > 0 ? de->deposited_mass / de->sprayed_mass : 0.0;
    split_by_angle(s, de);
    count_table_reach(s, de);
    int status = sum_unimpacted(s, de);
    if (status != SC_OK) {
        dem_deposition_efficiency_free(de);
        SC_TRY(status);
    }
    finish_classes(de->by_size, de->size_count);
    finish_classes(de->by_angle, de->angle_count);
    return SC_OK;
}

void dem_deposition_efficiency_free(struct dem_deposition_efficiency *de)
{
    free(de->by_size);
    free(de->by_angle);
    de->by_size = de->by_angle = NULL;
}

/* One group of classes: lo, hi (in `bound_units`, angles in degrees), the masses, counts and de. */
static int write_classes(hid_t parent, const char *name, const struct dem_de_class *classes, size_t count,
                         double bound_scale, const char *bound_units)
{
    hid_t g;
    SC_TRY(h5_create_group(parent, name, &g));
    int status = SC_OK;
    hsize_t dims[1] = {count};
    double *column = malloc((count ? count : 1) * 5 * sizeof *column);
    int64_t *counts = malloc((count ? count : 1) * 2 * sizeof *counts);
    if (!column || !counts)
        SC_FAIL_OOM_AT(status, done, count * 7 * sizeof *column, "the deposition efficiency columns");
    for (size_t k = 0; k < count; k++) {
        column[k] = classes[k].lo * bound_scale;
        column[count + k] = classes[k].hi * bound_scale;
        column[2 * count + k] = classes[k].sprayed_mass;
        column[3 * count + k] = classes[k].deposited_mass;
        column[4 * count + k] = classes[k].de;
        counts[k] = classes[k].sprayed_count;
        counts[count + k] = classes[k].deposited_count;
    }
    SC_CHECK(status, h5_write_doubles(g, "lo", 1, dims, column, bound_units, 0), done);
    SC_CHECK(status, h5_write_doubles(g, "hi", 1, dims, column + count, bound_units, 0), done);
    SC_CHECK(status, h5_write_doubles(g, "sprayed_mass", 1, dims, column + 2 * count, "kg", 0), done);
    SC_CHECK(status, h5_write_doubles(g, "deposited_mass", 1, dims, column + 3 * count, "kg", 0), done);
    SC_CHECK(status, h5_write_doubles(g, "de", 1, dims, column + 4 * count, "-", 0), done);
    SC_CHECK(status, h5_write_int64s(g, "sprayed_count", 1, dims, counts, "", 0), done);
    SC_CHECK(status, h5_write_int64s(g, "deposited_count", 1, dims, counts + count, "", 0), done);
done:
    free(column);
    free(counts);
    H5Gclose(g);
    return status;
}

/* A scalar as a one-element dataset, so that it carries its units like every other dataset. */
static int write_scalar(hid_t g, const char *name, double value, const char *units)
{
    hsize_t one[1] = {1};
    return h5_write_doubles(g, name, 1, one, &value, units, 0);
}

int dem_deposition_efficiency_write(const struct dem_deposition_efficiency *de, hid_t loc)
{
    hid_t g;
    SC_TRY(h5_create_group(loc, "deposition_efficiency", &g));
    int status = SC_OK;
    SC_CHECK(status, write_scalar(g, "de", de->de, "-"), done);
    SC_CHECK(status, write_scalar(g, "sprayed_mass", de->sprayed_mass, "kg"), done);
    SC_CHECK(status, write_scalar(g, "deposited_mass", de->deposited_mass, "kg"), done);
    SC_CHECK(status, write_scalar(g, "unimpacted_mass", de->unimpacted_mass, "kg"), done);
    SC_CHECK(status, write_scalar(g, "mean_impact_speed", de->mean_impact_speed, "m/s"), done);
    SC_CHECK(status, write_scalar(g, "mean_impact_normal_speed", de->mean_impact_normal_speed, "m/s"), done);
    SC_CHECK(status, h5_attr_write_int64(g, "sprayed_count", de->sprayed_count), done);
    SC_CHECK(status, h5_attr_write_int64(g, "deposited_count", de->deposited_count), done);
    SC_CHECK(status, h5_attr_write_int64(g, "unimpacted_count", de->unimpacted_count), done);
    SC_CHECK(status, h5_attr_write_int64(g, "table_impacts", de->table_impacts), done);
    SC_CHECK(status, h5_attr_write_int64(g, "table_impacts_outside", de->table_impacts_outside), done);
    SC_CHECK(status, write_classes(g, "by_size", de->by_size, de->size_count, 1.0, "m"), done);
    SC_CHECK(status, write_classes(g, "by_angle", de->by_angle, de->angle_count, 180.0 / M_PI, "degree"), done);
done:
    H5Gclose(g);
    return status;
}
