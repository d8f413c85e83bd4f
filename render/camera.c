/* Layout of a 3-D picture (scene, colour bar, caption) and the orthographic camera framed on the spheres. */
#include <math.h>

#include "core/error.h"
#include "render/render_impl.h"

struct render_box render_colorbar_box(const struct render_scene *scene)
{
    double w = scene->width, h = scene->height;
    double margin = fmax(6, 0.02 * w), label_space = fmax(70, 0.08 * w);
    double bar_w = fmax(12, 0.02 * w), bar_h = 0.6 * h;
    return (struct render_box){w - margin - label_space - bar_w, 0.5 * (h - bar_h) + 0.03 * h, bar_w, bar_h};
}

/* Left of the colour bar (and its title, which may be wider than the bar), below the caption band; with axes,
 * right of and above their labels. */
struct render_box render_scene_box(const struct render_scene *scene)
{
    struct render_box bar = render_colorbar_box(scene);
    double top = fmax(20, 0.08 * scene->height), bottom = 0.03 * scene->height;
    double right = bar.x - fmax(40, 0.1 * scene->width), left = 0;
    if (scene->axes) /* room for the tick labels and the axis titles */
        left = fmax(60, 0.08 * scene->width), bottom = fmax(45, 0.1 * scene->height);
    return (struct render_box){left, top, fmax(1, right - left), fmax(1, scene->height - top - bottom)};
}

double render_scale_length(double target)
{
    if (!(target > 0) || !isfinite(target))
        return 0;
    double magnitude = pow(10, floor(log10(target)));
    double mantissa = target / magnitude;
    return (mantissa >= 5 ? 5 : mantissa >= 2 ? 2 : 1) * magnitude;
}

double render_point_radius(double spacing)
{
    return spacing * 0.5 * sqrt(3.0);
}

int render_view_shows(const struct render_scene *scene, const double x[3])
{
    return scene->view != RENDER_VIEW_SECTION || x[1] >= scene->section_y;
}

static void cross(const double a[3], const double b[3], double out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

static double dot(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void normalise(double v[3])
{
    double n = sqrt(dot(v, v));
    for (int k = 0; k < 3; k++)
        v[k] /= n;
}

/* The viewing direction and the world direction that should point up on the screen. */
static void view_axes(enum render_view view, struct render_camera *cam)
{
    static const double toward[][3] = {
        [RENDER_VIEW_ISO] = {1, -1, 0.8}, [RENDER_VIEW_SECTION] = {0, -1, 0}, [RENDER_VIEW_TOP] = {0, 0, 1},
        [RENDER_VIEW_SIDE] = {0, -1, 0},  [RENDER_VIEW_FACING] = {0, 0, -1},
    };
    static const double up_hint[][3] = {
        [RENDER_VIEW_ISO] = {0, 0, 1},  [RENDER_VIEW_SECTION] = {0, 0, 1}, [RENDER_VIEW_TOP] = {0, 1, 0},
        [RENDER_VIEW_SIDE] = {0, 0, 1}, [RENDER_VIEW_FACING] = {0, -1, 0},
    };
    for (int k = 0; k < 3; k++)
        cam->toward[k] = toward[view][k];
    normalise(cam->toward);
    cross(up_hint[view], cam->toward, cam->right);
    normalise(cam->right);
    cross(cam->toward, cam->right, cam->up);
}

static double sphere_radius(const struct render_spheres *s, size_t i)
{
    return s->radius ? s->radius[i] : s->common_radius;
}

int render_camera_frame(const struct render_spheres *s, const struct render_scene *scene, struct render_camera *cam)
{
    view_axes(scene->view, cam);
    const double *axis[3] = {cam->right, cam->up, cam->toward};
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < s->count; i++) {
        const double *x = s->x + 3 * i;
        if (!render_view_shows(scene, x))
            continue;
        double r = sphere_radius(s, i);
        for (int k = scene->frame ? 2 : 0; k < 3; k++) { /* with a frame box: the depth range only */
            double c = dot(x, axis[k]);
            lo[k] = fmin(lo[k], c - r);
            hi[k] = fmax(hi[k], c + r);
        }
    }
    for (int corner = 0; corner < 8 && scene->frame; corner++) { /* the frame box's corners */
        double x[3];
        for (int k = 0; k < 3; k++)
            x[k] = scene->frame[(corner >> k & 1) ? 3 + k : k];
        for (int k = 0; k < 3; k++) {
            double c = dot(x, axis[k]);
            lo[k] = fmin(lo[k], c);
            hi[k] = fmax(hi[k], c);
        }
    }
    for (int k = 0; k < 3; k++) /* nothing to show: a unit box around the origin keeps the picture well defined */
        if (!(lo[k] <= hi[k]))
            lo[k] = -1, hi[k] = 1;
    double mid[3];
    for (int k = 0; k < 3; k++)
        mid[k] = 0.5 * (lo[k] + hi[k]);
    for (int k = 0; k < 3; k++)
        cam->center[k] = mid[0] * cam->right[k] + mid[1] * cam->up[k] + mid[2] * cam->toward[k];
    struct render_box box = render_scene_box(scene);
    /* 4 % margin on every side; a degenerate extent (one sphere of radius 0) still gives a finite scale */
    double extent_u = fmax(hi[0] - lo[0], 1e-300), extent_v = fmax(hi[1] - lo[1], 1e-300);
    cam->pixels_per_metre = 0.92 * fmin(box.width / extent_u, box.height / extent_v);
    cam->px0 = box.x + 0.5 * box.width;
    cam->py0 = box.y + 0.5 * box.height;
    cam->depth_half = fmax(0.5 * (hi[2] - lo[2]), 1e-300) * 1.01;
    if (!isfinite(cam->pixels_per_metre) || !isfinite(cam->depth_half))
        SC_FAIL(SC_EINPUT, "render: cannot frame %zu spheres (non-finite coordinates)", s->count);
    return SC_OK;
}

void render_camera_project(const struct render_camera *cam, const double x[3], double *px, double *py)
{
    double d[3] = {x[0] - cam->center[0], x[1] - cam->center[1], x[2] - cam->center[2]};
    *px = cam->px0 + dot(d, cam->right) * cam->pixels_per_metre;
    *py = cam->py0 - dot(d, cam->up) * cam->pixels_per_metre;
}
