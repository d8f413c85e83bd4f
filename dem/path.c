/* The nozzle's path over the target ([path], docs/physics.md "A traversing nozzle").
 *
 * The nozzle moves in its exit plane z = 0; the target plane is parallel to it, so the nozzle's (x, y) is also the
 * point of the target under the jet's axis.  Patterns: none (fixed at the origin), line (`passes` passes along +x
 * and back over the same line), raster (passes along x in alternating directions, `step_over` apart in +y, the
 * step-over moves at the traverse speed too) and file (waypoints (t, x, y), linear between them).  Before the path
 * starts (t < 0 cannot happen) and after it ends the nozzle stays at the path's last point. */
#include <math.h>

#include "dem/dem.h"

/* Where along a pass of length L the nozzle is after moving `distance` from the pass's start; even passes go +x,
 * odd ones -x. */
static double along_pass(const struct dem_path *path, long pass, double distance)
{
    return pass % 2 == 0 ? path->start_x + distance : path->start_x + path->pass_length - distance;
}

static void line_position(const struct dem_path *path, double t, double xy[2])
{
    double travelled = fmax(0.0, t) * path->traverse_speed, total = (double)path->passes * path->pass_length;
    travelled = fmin(travelled, total);
    long pass = (long)floor(travelled / path->pass_length);
    if (pass >= path->passes) /* the end of the last pass */
        pass = path->passes - 1;
    xy[0] = along_pass(path, pass, travelled - (double)pass * path->pass_length);
    xy[1] = path->start_y;
}

/* A raster's passes are legs of pass_length and step-overs of step_over in turn. */
static void raster_position(const struct dem_path *path, double t, double xy[2])
{
    double leg = path->pass_length + path->step_over;
    double travelled = fmin(fmax(0.0, t) * path->traverse_speed, dem_path_duration(path) * path->traverse_speed);
    long pass = (long)floor(travelled / leg);
    if (pass >= path->passes)
        pass = path->passes - 1;
    double into = travelled - (double)pass * leg;
    double on_pass = fmin(into, path->pass_length), stepping = fmax(0.0, into - path->pass_length);
    xy[0] = along_pass(path, pass, on_pass);
    xy[1] = path->start_y + (double)pass * path->step_over + stepping;
}

static void waypoint_position(const struct dem_path *path, double t, double xy[2])
{
    const double *w = path->waypoints;
    size_t n = path->waypoint_count;
    if (t <= w[0] || n == 1) {
        xy[0] = w[1], xy[1] = w[2];
        return;
    }
    if (t >= w[3 * (n - 1)]) {
        xy[0] = w[3 * (n - 1) + 1], xy[1] = w[3 * (n - 1) + 2];
        return;
    }
    size_t lo = 0, hi = n - 1; /* w[3 lo] <= t < w[3 hi] */
    while (hi - lo > 1) {
        size_t mid = (lo + hi) / 2;
        if (w[3 * mid] <= t)
            lo = mid;
        else
            hi = mid;
    }
    double fraction = (t - w[3 * lo]) / (w[3 * hi] - w[3 * lo]);
    xy[0] = w[3 * lo + 1] + fraction * (w[3 * hi + 1] - w[3 * lo + 1]);
    xy[1] = w[3 * lo + 2] + fraction * (w[3 * hi + 2] - w[3 * lo + 2]);
}

void dem_path_position(const struct dem_path *path, double t, double xy[2])
{
    switch (path->pattern) {
    case DEM_PATH_LINE:
        line_position(path, t, xy);
        return;
    case DEM_PATH_RASTER:
        raster_position(path, t, xy);
        return;
    case DEM_PATH_FILE:
        waypoint_position(path, t, xy);
        return;
    case DEM_PATH_NONE:
        break;
    }
    xy[0] = xy[1] = 0.0;
}

double dem_path_duration(const struct dem_path *path)
{
    switch (path->pattern) {
    case DEM_PATH_LINE:
        return (double)path->passes * path->pass_length / path->traverse_speed;
    case DEM_PATH_RASTER:
        return ((double)path->passes * path->pass_length + (double)(path->passes - 1) * path->step_over) /
               path->traverse_speed;
    case DEM_PATH_FILE:
        return path->waypoints[3 * (path->waypoint_count - 1)];
    case DEM_PATH_NONE:
        break;
    }
    return 0.0;
}
