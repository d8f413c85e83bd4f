/* The deposit as a height map on the target, the track's thickness profile and its Gaussian fit (docs/physics.md
 * "The deposit as a height map").
 *
 * Each deposited particle's volume pi d^3 / 6 goes to the square cell of the target under its centre; the cell's
 * height is the volume in it over the cell's area and the packing fraction ([path] packing; 1: the volume-equivalent
 * thickness of a dense coating).  The map's mass, sum of height * area * packing * density, is then the deposited
 * mass by construction; tests/test_traverse.c checks the map against the particles all the same. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/h5io.h"
#include "core/log.h"
#include "dem/dem_impl.h"

/* The map's cells have at most this many per side: a finer map would be mostly empty cells. */
#define DEPOSIT_MAX_CELLS_PER_SIDE 2000

/* ---- the Gaussian fit ---------------------------------------------------------------------------------------------
 */

/* Solve the 3x3 system a x = b by Gaussian elimination with partial pivoting; 0 if singular. */
static int solve3(double a[3][3], double b[3], double x[3])
{
    for (int k = 0; k < 3; k++) {
        int pivot = k;
        for (int i = k + 1; i < 3; i++)
            if (fabs(a[i][k]) > fabs(a[pivot][k]))
                pivot = i;
        if (!(fabs(a[pivot][k]) > 0.0))
            return 0;
        for (int j = 0; j < 3; j++) {
            double t = a[k][j];
            a[k][j] = a[pivot][j], a[pivot][j] = t;
        }
        double t = b[k];
        b[k] = b[pivot], b[pivot] = t;
        for (int i = k + 1; i < 3; i++) {
            double factor = a[i][k] / a[k][k];
            for (int j = k; j < 3; j++)
                a[i][j] -= factor * a[k][j];
            b[i] -= factor * b[k];
        }
    }
    for (int k = 2; k >= 0; k--) {
        double sum = b[k];
        for (int j = k + 1; j < 3; j++)
            sum -= a[k][j] * x[j];
        x[k] = sum / a[k][k];
    }
    return 1;
}

/* Sum of squared residuals of parameters p = (A, c, w); with jtj and jtr (J^T J, J^T r of the model's Jacobian)
 * when they are not NULL. */
static double gaussian_residuals(const double *y, const double *h, size_t n, const double p[3], double jtj[3][3],
                                 double jtr[3])
{
    double sum = 0.0;
    if (jtj) {
        memset(jtj, 0, 9 * sizeof(double));
        memset(jtr, 0, 3 * sizeof(double));
    }
    for (size_t i = 0; i < n; i++) {
        double u = (y[i] - p[1]) / p[2], e = exp(-0.5 * u * u);
        double r = h[i] - p[0] * e;
        sum += r * r;
        if (!jtj)
            continue;
        double j[3] = {e, p[0] * e * u / p[2], p[0] * e * u * u / p[2]}; /* d(model)/d(A, c, w) */
        for (int a = 0; a < 3; a++) {
            jtr[a] += j[a] * r;
            for (int b = 0; b < 3; b++)
                jtj[a][b] += j[a] * j[b];
        }
    }
    return sum;
}

/* The start: amplitude the largest h, centre and width the mean and standard deviation of y weighted by h. */
static int gaussian_moments(const double *y, const double *h, size_t n, double p[3])
{
    double weight = 0.0, first = 0.0, peak = 0.0;
    for (size_t i = 0; i < n; i++) {
        double w = fmax(h[i], 0.0);
        weight += w, first += w * y[i], peak = fmax(peak, h[i]);
    }
    if (!(weight > 0.0))
        return 0;
    double centre = first / weight, second = 0.0;
    for (size_t i = 0; i < n; i++)
        second += fmax(h[i], 0.0) * (y[i] - centre) * (y[i] - centre);
    double spacing = fabs(y[n - 1] - y[0]) / (double)(n - 1);
    p[0] = peak, p[1] = centre, p[2] = fmax(sqrt(second / weight), 0.5 * spacing);
    return p[2] > 0.0;
}

/* Levenberg-Marquardt (Marquardt 1963, the diagonal scaling of J^T J): a step that lowers the sum of squares is
 * taken and the damping lowered, else the damping raised; stop when the change of every parameter is below 1e-10 of
 * its scale (the amplitude's own, the width for the centre and the width). */
static int fit_rows(const double *y, const double *h, size_t n, struct dem_gaussian *fit)
{
    memset(fit, 0, sizeof *fit);
    double p[3];
    if (n < 4 || !gaussian_moments(y, h, n, p))
        SC_FAIL(SC_ESIM, "Gaussian fit: %zu points hold no peak", n);
    double jtj[3][3], jtr[3], lambda = 1e-3;
    double sum = gaussian_residuals(y, h, n, p, jtj, jtr);
    int converged = 0, iteration;
    for (iteration = 0; iteration < 200 && !converged; iteration++) {
        double a[3][3], b[3] = {jtr[0], jtr[1], jtr[2]}, step[3], trial[3];
        memcpy(a, jtj, sizeof a);
        for (int k = 0; k < 3; k++)
            a[k][k] *= 1.0 + lambda;
        if (!solve3(a, b, step))
            break;
        for (int k = 0; k < 3; k++)
            trial[k] = p[k] + step[k];
        trial[2] = fabs(trial[2]);
        double trial_sum = trial[2] > 0.0 ? gaussian_residuals(y, h, n, trial, NULL, NULL) : INFINITY;
        if (trial_sum <= sum) {
            /* the centre's and the width's steps measured against the width: a track centred on y = 0 gives the
             * centre no scale of its own, and a step relative to it never counted as small */
            double scale[3] = {fabs(trial[0]), trial[2], trial[2]};
            converged = 1;
            for (int k = 0; k < 3; k++)
                converged &= fabs(trial[k] - p[k]) <= 1e-10 * fmax(scale[k], 1e-300);
            memcpy(p, trial, sizeof p);
            sum = gaussian_residuals(y, h, n, p, jtj, jtr);
            lambda = fmax(lambda / 10.0, 1e-12);
        } else {
            lambda *= 10.0;
            converged = lambda > 1e12; /* no step lowers the sum: at its minimum to rounding */
        }
    }
    if (!converged || !(p[0] > 0.0))
        SC_FAIL(SC_ESIM, "Gaussian fit: no convergence in %d iterations", iteration);
    /* covariance sigma^2 (J^T J)^-1 with sigma^2 = sum / (n - 3): the standard errors of the parameters */
    double variance = sum / (double)(n - 3), covariance[3];
    for (int k = 0; k < 3; k++) {
        double a[3][3], unit[3] = {0, 0, 0}, column[3];
        memcpy(a, jtj, sizeof a);
        unit[k] = 1.0;
        covariance[k] = solve3(a, unit, column) ? column[k] * variance : INFINITY;
    }
    fit->amplitude = p[0], fit->centre = p[1], fit->width = p[2];
    fit->amplitude_error = sqrt(covariance[0]);
    fit->centre_error = sqrt(covariance[1]);
    fit->width_error = sqrt(covariance[2]);
    fit->rms = sqrt(sum / (double)n);
    fit->iterations = iteration;
    return SC_OK;
}

/* The rows within FIT_WINDOW widths of the first fit's centre carry the track (the Gaussian is 4e-6 of its peak at
 * 5 widths); the map's other rows, as many as its extent gives (the band, a stray deposit), would add rows to n - 3
 * without adding to the residuals and shrink every standard error as 1 / sqrt(n - 3). */
#define FIT_WINDOW 5.0

int dem_gaussian_fit(const double *y, const double *h, size_t n, struct dem_gaussian *fit)
{
    SC_TRY(fit_rows(y, h, n, fit));
    size_t first = 0, end = n;
    while (first < n && y[first] < fit->centre - FIT_WINDOW * fit->width)
        first++;
    while (end > first && y[end - 1] > fit->centre + FIT_WINDOW * fit->width)
        end--;
    if (end - first == n || end - first < 4)
        return SC_OK;
    struct dem_gaussian windowed;
    if (fit_rows(y + first, h + first, end - first, &windowed) != SC_OK) {
        sc_error_clear(); /* the fit over every row stands */
        return SC_OK;
    }
    windowed.iterations += fit->iterations;
    *fit = windowed;
    return SC_OK;
}

/* ---- the height map -----------------------------------------------------------------------------------------------
 */

/* The map covers the deposited centres and the band the nozzle disc sweeps, one cell beyond. */
static void map_extent(const struct dem_solver *s, double lo[2], double hi[2])
{
    const struct dem_path *path = &s->cfg.path;
    double duration = dem_path_duration(path), xy[2];
    lo[0] = lo[1] = INFINITY, hi[0] = hi[1] = -INFINITY;
    /* the positions at 64 samples a pass: the pass ends fall between two, so the map may stop up to 1/64 of a pass
     * short of the swept band, where it would hold only empty cells (every deposited centre is added below) */
    long samples = 64 * (path->passes > 0 ? path->passes : 1) + 1;
    for (long k = 0; k <= samples; k++) {
        dem_path_position(path, duration * (double)k / (double)samples, xy);
        for (int c = 0; c < 2; c++)
            lo[c] = fmin(lo[c], xy[c] - s->cfg.nozzle_radius), hi[c] = fmax(hi[c], xy[c] + s->cfg.nozzle_radius);
    }
    for (size_t k = 0; k < path->waypoint_count; k++)
        for (int c = 0; c < 2; c++) {
            lo[c] = fmin(lo[c], path->waypoints[3 * k + 1 + c] - s->cfg.nozzle_radius);
            hi[c] = fmax(hi[c], path->waypoints[3 * k + 1 + c] + s->cfg.nozzle_radius);
        }
    for (size_t i = 0; i < s->p.count; i++)
        if (s->p.state[i] == DEM_DEPOSITED)
            for (int c = 0; c < 2; c++)
                lo[c] = fmin(lo[c], s->p.x[3 * i + c]), hi[c] = fmax(hi[c], s->p.x[3 * i + c]);
}

static size_t cells_over(double lo, double hi, double cell)
{
    return (size_t)ceil((hi - lo) / cell) + 2;
}

/* [path] map_cell, widened if the map would have more than DEPOSIT_MAX_CELLS_PER_SIDE cells a side. */
static double map_cell(const struct dem_solver *s, const double lo[2], const double hi[2])
{
    double largest = fmax(hi[0] - lo[0], hi[1] - lo[1]);
    return fmax(s->cfg.path.map_cell, largest / DEPOSIT_MAX_CELLS_PER_SIDE);
}

static int map_fill(const struct dem_solver *s, struct dem_deposit *deposit)
{
    double lo[2], hi[2];
    map_extent(s, lo, hi);
    deposit->cell = map_cell(s, lo, hi);
    deposit->nx = cells_over(lo[0], hi[0], deposit->cell);
    deposit->ny = cells_over(lo[1], hi[1], deposit->cell);
    /* cell (0, 0) one cell below lo: every centre lies in a cell that is not on the map's edge */
    deposit->x0 = lo[0] - 0.5 * deposit->cell;
    deposit->y0 = lo[1] - 0.5 * deposit->cell;
    deposit->packing = s->cfg.path.packing;
    static const char *const patterns[] = {"none", "line", "raster", "file"};
    deposit->pattern = patterns[s->cfg.path.pattern];
    size_t bytes = deposit->nx * deposit->ny * sizeof(double);
    deposit->height = calloc(deposit->nx * deposit->ny, sizeof(double));
    if (!deposit->height)
        SC_FAIL_OOM(bytes, "the deposit's height map");
    double area = deposit->cell * deposit->cell;
    for (size_t i = 0; i < s->p.count; i++) {
        if (s->p.state[i] != DEM_DEPOSITED)
            continue;
        double d = s->p.d[i], volume = M_PI * d * d * d / 6.0;
        size_t ix = (size_t)floor((s->p.x[3 * i] - deposit->x0) / deposit->cell + 0.5);
        size_t iy = (size_t)floor((s->p.x[3 * i + 1] - deposit->y0) / deposit->cell + 0.5);
        deposit->height[iy * deposit->nx + ix] += volume / (area * deposit->packing);
        deposit->volume += volume;
        deposit->mass += s->p.m[i];
    }
    return SC_OK;
}

/* ---- the track's profile ------------------------------------------------------------------------------------------
 */

static int profile_fill(const struct dem_solver *s, struct dem_deposit *deposit)
{
    const struct dem_path *path = &s->cfg.path;
    size_t n = deposit->ny;
    deposit->profile_y = malloc(n * sizeof(double));
    deposit->profile_height = malloc(n * sizeof(double));
    if (!deposit->profile_y || !deposit->profile_height)
        SC_FAIL_OOM(2 * n * sizeof(double), "the deposit's profile");
    deposit->profile_count = n;
    double x_lo = path->start_x + 0.25 * path->pass_length, x_hi = path->start_x + 0.75 * path->pass_length;
    for (size_t j = 0; j < n; j++) {
        double sum = 0.0;
        size_t cells = 0;
        for (size_t i = 0; i < deposit->nx; i++) {
            double x = deposit->x0 + (double)i * deposit->cell;
            if (x >= x_lo && x <= x_hi)
                sum += deposit->height[j * deposit->nx + i], cells++;
        }
        deposit->profile_y[j] = deposit->y0 + (double)j * deposit->cell;
        deposit->profile_height[j] = cells ? sum / (double)cells : 0.0;
    }
    /* the band the nozzle disc swept across the track */
    long last_pass = path->pattern == DEM_PATH_RASTER ? path->passes - 1 : 0;
    deposit->band_lo = path->start_y - s->cfg.nozzle_radius;
    deposit->band_hi = path->start_y + (double)last_pass * path->step_over + s->cfg.nozzle_radius;
    double sum = 0.0;
    size_t rows = 0;
    for (size_t j = 0; j < n; j++)
        if (deposit->profile_y[j] >= deposit->band_lo && deposit->profile_y[j] <= deposit->band_hi)
            sum += deposit->profile_height[j], rows++;
    deposit->mean_thickness = rows ? sum / (double)rows : 0.0;
    if (path->pattern == DEM_PATH_LINE)
        deposit->has_fit = dem_gaussian_fit(deposit->profile_y, deposit->profile_height, n, &deposit->fit) == SC_OK;
    if (path->pattern == DEM_PATH_LINE && !deposit->has_fit) {
        log_warn("spray: the track's profile has no Gaussian fit (%s): spray.h5 /deposit holds no fit_* attributes",
                 sc_error_message());
        sc_error_clear();
    }
    return SC_OK;
}

int dem_deposit_build(const struct dem_solver *s, struct dem_deposit *deposit)
{
    memset(deposit, 0, sizeof *deposit);
    int status = map_fill(s, deposit);
    if (status == SC_OK && (s->cfg.path.pattern == DEM_PATH_LINE || s->cfg.path.pattern == DEM_PATH_RASTER))
        status = profile_fill(s, deposit);
    if (status != SC_OK)
        dem_deposit_free(deposit);
    SC_TRY(status);
    return SC_OK;
}

void dem_deposit_free(struct dem_deposit *deposit)
{
    free(deposit->height);
    free(deposit->profile_y);
    free(deposit->profile_height);
    memset(deposit, 0, sizeof *deposit);
}

static int write_fit(hid_t g, const struct dem_gaussian *fit)
{
    SC_TRY(h5_attr_write_double(g, "fit_amplitude", fit->amplitude));
    SC_TRY(h5_attr_write_double(g, "fit_centre", fit->centre));
    SC_TRY(h5_attr_write_double(g, "fit_width", fit->width));
    SC_TRY(h5_attr_write_double(g, "fit_amplitude_error", fit->amplitude_error));
    SC_TRY(h5_attr_write_double(g, "fit_centre_error", fit->centre_error));
    SC_TRY(h5_attr_write_double(g, "fit_width_error", fit->width_error));
    SC_TRY(h5_attr_write_double(g, "fit_rms", fit->rms));
    return SC_OK;
}

static int write_group(const struct dem_deposit *deposit, hid_t g)
{
    hsize_t map_dims[2] = {deposit->ny, deposit->nx}, x_dims[1] = {deposit->nx}, y_dims[1] = {deposit->ny};
    double *x = malloc(deposit->nx * sizeof *x), *y = malloc(deposit->ny * sizeof *y);
    int status = SC_OK;
    if (!x || !y)
        SC_FAIL_OOM_AT(status, done, (deposit->nx + deposit->ny) * sizeof *x, "the deposit's cell centres");
    for (size_t i = 0; i < deposit->nx; i++)
        x[i] = deposit->x0 + (double)i * deposit->cell;
    for (size_t j = 0; j < deposit->ny; j++)
        y[j] = deposit->y0 + (double)j * deposit->cell;
    SC_CHECK(status, h5_write_doubles(g, "height", 2, map_dims, deposit->height, "m", 0), done);
    SC_CHECK(status, h5_write_doubles(g, "x", 1, x_dims, x, "m", 0), done);
    SC_CHECK(status, h5_write_doubles(g, "y", 1, y_dims, y, "m", 0), done);
    SC_CHECK(status, h5_attr_write_double(g, "cell", deposit->cell), done);
    SC_CHECK(status, h5_attr_write_double(g, "packing", deposit->packing), done);
    SC_CHECK(status, h5_attr_write_string(g, "pattern", deposit->pattern), done);
    SC_CHECK(status, h5_attr_write_double(g, "volume", deposit->volume), done);
    SC_CHECK(status, h5_attr_write_double(g, "mass", deposit->mass), done);
    if (deposit->profile_count) {
        hsize_t p_dims[1] = {deposit->profile_count};
        SC_CHECK(status, h5_write_doubles(g, "profile_y", 1, p_dims, deposit->profile_y, "m", 0), done);
        SC_CHECK(status, h5_write_doubles(g, "profile_height", 1, p_dims, deposit->profile_height, "m", 0), done);
        SC_CHECK(status, h5_attr_write_double(g, "mean_thickness", deposit->mean_thickness), done);
        SC_CHECK(status, h5_attr_write_double(g, "band_lo", deposit->band_lo), done);
        SC_CHECK(status, h5_attr_write_double(g, "band_hi", deposit->band_hi), done);
    }
    if (deposit->has_fit)
        SC_CHECK(status, write_fit(g, &deposit->fit), done);
done:
    free(x);
    free(y);
    return status;
}

int dem_deposit_write(const struct dem_deposit *deposit, hid_t file)
{
    hid_t g;
    SC_TRY(h5_create_group(file, "deposit", &g));
    int status = write_group(deposit, g);
    H5Gclose(g);
    return status;
}
