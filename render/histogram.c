/* Histograms: the counts a figure plots, kept so that checks can compare them with the run. */
#include <math.h>
#include <stdlib.h>

#include "core/error.h"
#include "render/render.h"

static void finite_range(const double *values, size_t n, double *lo, double *hi)
{
    *lo = INFINITY, *hi = -INFINITY;
    for (size_t i = 0; i < n; i++)
        if (isfinite(values[i])) {
            *lo = fmin(*lo, values[i]);
            *hi = fmax(*hi, values[i]);
        }
    if (!(*lo <= *hi))
        *lo = 0, *hi = 1;
    if (*lo == *hi) { /* one distinct value: a bin around it */
        double half = *lo != 0 ? 0.05 * fabs(*lo) : 0.5;
        *lo -= half, *hi += half;
    }
}

int render_histogram_fill(const double *values, size_t n, int bins, double lo, double hi, struct render_histogram *h)
{
    if (bins < 1)
        SC_FAIL(SC_EINPUT, "render: a histogram needs at least one bin, not %d", bins);
    if (!(lo < hi))
        finite_range(values, n, &lo, &hi);
    h->counts = calloc((size_t)bins, sizeof *h->counts);
    if (!h->counts)
        SC_FAIL_OOM((size_t)bins * sizeof *h->counts, "a histogram");
    h->bins = bins, h->lo = lo, h->hi = hi, h->total = 0, h->outside = 0;
    for (size_t i = 0; i < n; i++) {
        double v = values[i];
        if (!isfinite(v) || v < lo || v > hi) {
            h->outside++;
            continue;
        }
        int b = (int)((v - lo) / (hi - lo) * bins);
        h->counts[b >= bins ? bins - 1 : b]++;
        h->total++;
    }
    return SC_OK;
}

void render_histogram_free(struct render_histogram *h)
{
    free(h->counts);
    h->counts = NULL;
    h->bins = 0;
}
