/* Particle diameters, Mukherjee & Zohdi Section 4.2: the Weibull (Rosin-Rammler) law of Eq. (36), its
 * scale set from the median by Eq. (37), sampled by inverse transform. */
#include "dem/sizes.h"

#include <math.h>

/* Eq. (37): D_median = lambda ln(2)^(1/n). */
double dem_weibull_scale(double median_diameter, double shape)
{
    return median_diameter / pow(log(2.0), 1.0 / shape);
}

/* F(d) = 1 - exp(-(d/lambda)^n); -expm1 keeps the small-d tail accurate. */
double dem_weibull_cdf(double d, double scale, double shape)
{
    if (!(d > 0.0))
        return 0.0;
    return -expm1(-pow(d / scale, shape));
}

/* Eq. (36): f(d) = n/lambda (d/lambda)^(n-1) exp(-(d/lambda)^n), zero for d < 0. */
double dem_weibull_pdf(double d, double scale, double shape)
{
    if (d < 0.0)
        return 0.0;
    double ratio = d / scale;
    return shape / scale * pow(ratio, shape - 1.0) * exp(-pow(ratio, shape));
}

/* F^-1(u) = lambda (-ln(1 - u))^(1/n); log1p keeps small u accurate. */
double dem_weibull_quantile(double u, double scale, double shape)
{
    return scale * pow(-log1p(-u), 1.0 / shape);
}

/* Inverse-transform sampling of the Weibull law truncated to [d_min, d_max]: u in (0, 1) is mapped
 * linearly onto [F(d_min), F(d_max)], so every draw is accepted (no rejection loop, and one uniform per
 * particle keeps the counter-based random stream simple).  The result is clamped into [d_min, d_max]
 * against round-off in F^-1(F(.)). */
double dem_sizes_sample(const struct dem_size_distribution *dist, double u)
{
    if (dist->monodisperse)
        return dist->median_diameter;
    double scale = dem_weibull_scale(dist->median_diameter, dist->shape);
    double cdf_low = dem_weibull_cdf(dist->d_min, scale, dist->shape);
    double cdf_high = isinf(dist->d_max) ? 1.0 : dem_weibull_cdf(dist->d_max, scale, dist->shape);
    double d = dem_weibull_quantile(cdf_low + u * (cdf_high - cdf_low), scale, dist->shape);
    return fmin(fmax(d, dist->d_min), dist->d_max);
}
