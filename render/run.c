/* render_run_dir: every figure the run's outputs allow, then the report. */
#include <dirent.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/error.h"
#include "core/log.h"
#include "render/render_impl.h"

struct render_figure *render_output_add(struct render_output *out, const char *name, const char *group, int is_plot,
                                        const char *title)
{
    if (out->count == out->capacity) {
        int capacity = out->capacity ? 2 * out->capacity : 16;
        struct render_figure *grown = realloc(out->figures, (size_t)capacity * sizeof *grown);
        if (!grown)
            return NULL;
        out->figures = grown;
        out->capacity = capacity;
    }
    struct render_figure *fig = &out->figures[out->count++];
    memset(fig, 0, sizeof *fig);
    snprintf(fig->name, sizeof fig->name, "%s", name);
    snprintf(fig->group, sizeof fig->group, "%s", group);
    snprintf(fig->title, sizeof fig->title, "%s", title);
    fig->is_plot = is_plot;
    return fig;
}

int render_output_push(struct render_output *out, const char *name, const char *group, int is_plot, const char *title,
                       struct render_figure **figure)
{
    struct render_figure *fig = render_output_add(out, name, group, is_plot, title);
    if (!fig)
        SC_FAIL_OOM((size_t)(out->capacity ? 2 * out->capacity : 16) * sizeof *fig, "the list of figures");
    if (figure)
        *figure = fig;
    return SC_OK;
}

int render_plot_publish(const char *run_dir, struct render_output *out, const char *name, const char *group,
                        const char *title, const struct render_plot *plot)
{
    char dir[4200];
    render_figures_dir(run_dir, dir, sizeof dir);
    SC_TRY(render_output_push(out, name, group, 1, title, NULL));
    return render_plot_write(plot, dir, name);
}

void render_output_free(struct render_output *out)
{
    for (int i = 0; i < out->count; i++)
        render_histogram_free(&out->figures[i].histogram);
    free(out->figures);
    memset(out, 0, sizeof *out);
}

const struct render_figure *render_output_find(const struct render_output *out, const char *name)
{
    for (int i = 0; i < out->count; i++)
        if (strcmp(out->figures[i].name, name) == 0)
            return &out->figures[i];
    return NULL;
}

struct render_plot render_plot_start(const struct render_config *cfg, int panels)
{
    struct render_plot plot;
    memset(&plot, 0, sizeof plot);
    plot.width = cfg->plot_width;
    plot.height = cfg->plot_height;
    plot.panel_count = panels;
    return plot;
}

void render_figures_dir(const char *run_dir, char *out, size_t size)
{
    snprintf(out, size, "%s/figures", run_dir);
}

int render_renderer_get(const struct render_config *cfg, struct render_renderer **renderer)
{
    if (!*renderer)
        SC_TRY(render_renderer_create(cfg->width, cfg->height, renderer));
    return SC_OK;
}

static int make_folder(const char *path)
{
    if (mkdir(path, 0777) != 0 && errno != EEXIST)
        SC_FAIL(SC_EIO, "render: cannot create folder %s: %s", path, strerror(errno));
    return SC_OK;
}

int render_film_folder(const char *path)
{
    SC_TRY(make_folder(path));
    DIR *dir = opendir(path);
    if (!dir)
        SC_FAIL(SC_EIO, "render: cannot read folder %s: %s", path, strerror(errno));
    struct dirent *entry;
    char file[4600];
    while ((entry = readdir(dir))) {
        size_t len = strlen(entry->d_name);
        if (len < 4 || strcmp(entry->d_name + len - 4, ".png") != 0)
            continue;
        snprintf(file, sizeof file, "%s/%s", path, entry->d_name);
        if (unlink(file) != 0 && errno != ENOENT) {
            int saved = errno;
            closedir(dir);
            SC_FAIL(SC_EIO, "render: cannot remove the old frame %s: %s", file, strerror(saved));
        }
    }
    closedir(dir);
    return SC_OK;
}

int render_input_present(const struct render_request *req, const char *name)
{
    for (int k = 0; k < req->ignored_count; k++)
        if (strcmp(req->ignored[k], name) == 0)
            return 0;
    char path[4200];
    snprintf(path, sizeof path, "%s/%s", req->run_dir, name);
    return access(path, F_OK) == 0;
}

static int draw_all(const struct render_request *req, struct render_output *out)
{
    struct render_renderer *renderer = NULL;
    int status = SC_OK;
    if (render_input_present(req, "spray.h5"))
        SC_CHECK(status, render_spray_figures(req, &renderer, out), done);
    if (render_input_present(req, "impact.h5"))
        SC_CHECK(status, render_impact_figures(req, &renderer, out), done);
    if (render_input_present(req, "vcrit.h5"))
        SC_CHECK(status, render_vcrit_figures(req, out), done);
    if (render_input_present(req, "calibrate.h5"))
        SC_CHECK(status, render_calibrate_figures(req, out), done);
    if (render_input_present(req, "sweep.h5"))
        SC_CHECK(status, render_sweep_figures(req, out), done);
done:
    render_renderer_destroy(renderer);
    return status;
}

int render_run_dir(const struct render_request *req, struct render_output *out)
{
    memset(out, 0, sizeof *out);
    if (!render_input_present(req, "spray.h5") && !render_input_present(req, "impact.h5") &&
        !render_input_present(req, "vcrit.h5") && !render_input_present(req, "calibrate.h5") &&
        !render_input_present(req, "sweep.h5"))
        SC_FAIL(SC_EIO,
                "render: %s holds no output to draw (spray.h5, impact.h5, vcrit.h5, calibrate.h5 or sweep.h5); run "
                "a stage first",
                req->run_dir);
    char dir[4200];
    render_figures_dir(req->run_dir, dir, sizeof dir);
    SC_TRY(make_folder(dir));
    SC_TRY(draw_all(req, out));
    SC_TRY(render_write_report(req, out));
    log_info("render: %d figures and %d frames in %s, report %s/report.html", out->count, out->frames, dir,
             req->run_dir);
    return SC_OK;
}
