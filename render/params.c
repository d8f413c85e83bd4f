/* The [render] keys and their resolution.  Every key is CFG_NOT_HASHED: pictures do not change the results, so a
 * new picture size never makes `spraycoat run` repeat a simulation stage. */
#include <math.h>

#include "core/error.h"
#include "render/render.h"

const struct cfg_key render_case_keys[] = {
    {"render", "field", CFG_CHOICE, "", "eps_p", 0, 0, CFG_NOT_HASHED, "eps_p|T|D_bond|speed",
     "colour of the material points: effective plastic strain, temperature, bond parameter D, speed |v|"},
    {"render", "view", CFG_CHOICE, "", "section", 0, 0, CFG_NOT_HASHED, "iso|section|top",
     "view of the frame sequence: iso, section (the half y >= section_y, cut through the impact axis), top"},
    {"render", "width", CFG_INT, "px", "1280", 64, 8192, CFG_NOT_HASHED, NULL, "width of 3-D pictures and frames"},
    {"render", "height", CFG_INT, "px", "720", 64, 8192, CFG_NOT_HASHED, NULL, "height of 3-D pictures and frames"},
    {"render", "every", CFG_INT, "snapshots", "1", 0, 1e9, CFG_NOT_HASHED, NULL,
     "films: every Nth snapshot (and the last) as PNG frames, the spray plume into figures/film_plume/, each "
     "impact run into figures/film_impact*/; 0: none (command line: --every N)"},
    {"render", "range_min", CFG_REAL, "unit of field", "auto", -1e300, 1e300, CFG_NOT_HASHED, "auto",
     "value drawn with the low end of viridis; auto: the smallest over the snapshots drawn"},
    {"render", "range_max", CFG_REAL, "unit of field", "auto", -1e300, 1e300, CFG_NOT_HASHED, "auto",
     "value drawn with the high end of viridis; auto: the largest over the snapshots drawn"},
    {"render", "point_radius", CFG_REAL, "m", "auto", 0, 1, CFG_MIN_EXCLUSIVE | CFG_NOT_HASHED, "auto",
     "radius of the material-point spheres; auto: sqrt(3)/2 x the [impact] spacing the run used (no see-through gaps)"},
    {"render", "section_y", CFG_REAL, "m", "0", -1, 1, CFG_NOT_HASHED, NULL,
     "section view: the cut plane y = section_y (the impact axis of a single particle lies in y = 0)"},
    {"render", "deposit_color", CFG_CHOICE, "", "diameter", 0, 0, CFG_NOT_HASHED, "diameter|speed",
     "colour of deposited particles in the deposit picture: diameter or impact speed"},
    {"render", "plot_width", CFG_INT, "px", "800", 200, 8192, CFG_NOT_HASHED, NULL,
     "width of 2-D plots (PNG px, SVG pt)"},
    {"render", "plot_height", CFG_INT, "px", "500", 150, 8192, CFG_NOT_HASHED, NULL,
     "height of 2-D plots (PNG px, SVG pt)"},
    {"render", "bins", CFG_INT, "-", "30", 2, 1000, CFG_NOT_HASHED, NULL, "number of bins of the histograms"},
    {NULL, NULL, 0, NULL, NULL, 0, 0, 0, NULL, NULL},
};

static double real_or_auto(const struct case_file *c, const char *key)
{
    return case_is(c, "render", key, "auto") ? NAN : case_real(c, "render", key);
}

int render_config_load(const struct case_file *c, struct render_config *cfg)
{
    static const char *const fields[] = {"eps_p", "T", "D_bond", "speed"};
    static const char *const views[] = {"iso", "section", "top"};
    for (int i = 0; i < 4; i++)
        if (case_is(c, "render", "field", fields[i]))
            cfg->field = (enum render_field)i;
    for (int i = 0; i < 3; i++)
        if (case_is(c, "render", "view", views[i]))
            cfg->view = i == 0 ? RENDER_VIEW_ISO : i == 1 ? RENDER_VIEW_SECTION : RENDER_VIEW_TOP;
    cfg->width = (int)case_int(c, "render", "width");
    cfg->height = (int)case_int(c, "render", "height");
    cfg->plot_width = (int)case_int(c, "render", "plot_width");
    cfg->plot_height = (int)case_int(c, "render", "plot_height");
    cfg->every = case_int(c, "render", "every");
    cfg->bins = (int)case_int(c, "render", "bins");
    cfg->range_min = real_or_auto(c, "range_min");
    cfg->range_max = real_or_auto(c, "range_max");
    cfg->point_radius = real_or_auto(c, "point_radius");
    cfg->section_y = case_real(c, "render", "section_y");
    cfg->deposit_by_speed = case_is(c, "render", "deposit_color", "speed");
    if (!isnan(cfg->range_min) && !isnan(cfg->range_max) && !(cfg->range_min < cfg->range_max))
        return case_invalid(c, "render", "range_max", "not above range_min = %g", cfg->range_min);
    return SC_OK;
}
