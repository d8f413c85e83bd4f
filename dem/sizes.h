/* Module-private (dem/): particle sizes, Mukherjee & Zohdi Section 4.2, Eqs. (36)-(37). */
#ifndef SPRAYCOAT_DEM_SIZES_H
#define SPRAYCOAT_DEM_SIZES_H

#include "dem/dem.h" /* struct dem_size_distribution */

/* lambda = D_median / ln(2)^(1/n), Eq. (37) */
double dem_weibull_scale(double median_diameter, double shape);
double dem_weibull_cdf(double d, double scale, double shape);
double dem_weibull_pdf(double d, double scale, double shape);
double dem_weibull_quantile(double u, double scale, double shape);

/* Diameter for a uniform u in (0, 1) by inverse-transform sampling of the (truncated) Weibull law:
 * u is mapped into [F(d_min), F(d_max)] so that truncation needs no rejection. */
double dem_sizes_sample(const struct dem_size_distribution *dist, double u);

#endif
