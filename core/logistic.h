/* Logistic regression by Newton's method (iteratively reweighted least squares), for the bonding calibration of
 * Tang (2021) Section 4.1.2: a second-order model in two variables (Eqs. 4.10-4.12) fitted to bonded (1) /
 * rebounded (0) outcomes by minimising the cost of Eq. 4.13, whose gradient is Eq. 4.14.
 *
 * Deterministic outcomes on a parameter grid are often separable: the maximum-likelihood coefficients are then
 * infinite (the cost keeps falling as |theta| grows) and the boundary Z = 0 may lie anywhere in the gap between
 * the two outcomes.  An optional ridge term (lambda/2) |theta_2..n|^2 added to m J keeps them finite and picks one
 * boundary in that gap; lambda = 0 is the plain maximum likelihood.  The fit says when the outcomes are separable,
 * whatever lambda (logistic_fit.separable). */
#ifndef SPRAYCOAT_CORE_LOGISTIC_H
#define SPRAYCOAT_CORE_LOGISTIC_H

#include <stddef.h>

#define LOGISTIC_MAX_TERMS 6

/* The six terms of Eq. 4.12 at (x1, x2): 1, x1, x2, x1^2, x1 x2, x2^2. */
void logistic_quadratic_terms(double x1, double x2, double terms[LOGISTIC_MAX_TERMS]);
/* Z = X(x1, x2) theta (Eq. 4.12) of the second-order model. */
double logistic_quadratic_z(const double theta[LOGISTIC_MAX_TERMS], double x1, double x2);

struct logistic_fit {
    int terms;                        /* p: the number of coefficients */
    double theta[LOGISTIC_MAX_TERMS]; /* the fit */
    double se[LOGISTIC_MAX_TERMS];    /* standard errors: sqrt of the diagonal of the inverse Hessian */
    double covariance[LOGISTIC_MAX_TERMS * LOGISTIC_MAX_TERMS]; /* the inverse Hessian (p x p, row-major) */
    double cost;                                                /* J of Eq. 4.13 at theta (without the ridge term) */
    int iterations, converged; /* converged: the Newton step fell below 1e-10 (relative) */
    int separable; /* 1 when the sign of Z at theta gives every outcome (Z > 0 for y = 1, Z < 0 for y = 0): the
                    * outcomes are separable; without a ridge term |theta| grew without bound, with one the boundary
                    * Z = 0 is one of many in the gap the outcomes leave, placed there by lambda */
};

/* Fit y[i] in {0, 1} (i < m) against the rows X[i p .. i p + p - 1] (p <= LOGISTIC_MAX_TERMS, the first column
 * normally 1) with ridge parameter lambda >= 0 (not applied to the first coefficient).  SC_EINPUT when m < 1 or p
 * is out of range; SC_ESIM when the Hessian is singular (a column that is zero or repeats another). */
int logistic_fit(const double *X, const int *y, size_t m, int p, double lambda, struct logistic_fit *fit);

/* The speed (or any one variable x) at which success and failure are equally likely, h = 0.5 of the first-order
 * model h = sigma(theta_0 + theta_1 (x - center) / scale) (Eq. 4.12 with one variable, scale > 0 only conditions
 * the fit):
 * - outcomes that overlap (a failure above a success): the maximum-likelihood fit, x50 = center - scale theta_0 /
 *   theta_1, its standard error by the delta method from the inverse Hessian, and width = the x span from h = 0.1
 *   to 0.9 (2 ln 9 scale / theta_1);
 * - separable outcomes (every failure at or below every success): no finite fit exists; x50 is the midpoint of the
 *   gap between the highest failure and the lowest success, which is where the ridge-regularised fit's boundary
 *   tends as the ridge term vanishes (Rosset, Zhu & Hastie 2003: the maximum-margin separator); se and width NaN.
 * x50 is NaN (rising = 0) when one outcome is missing or the fit falls with x (theta_1 <= 0). */
struct logistic_threshold {
    double x50, se, width;
    int separable, rising;
    struct logistic_fit fit; /* the fit, when not separable */
};
int logistic_threshold_fit(const double *x, const int *y, size_t m, double center, double scale,
                           struct logistic_threshold *out);

/* The Wilson score interval of a proportion (Wilson 1927; method 3 of Newcombe 1998): `successes` of `trials`
 * independent outcomes, at z standard normal deviates (1.96: 95 %), into [*lo, *hi]; [0, 1] for no trials.  Unlike
 * p +- z sqrt(p (1 - p) / n) it stays within [0, 1] and is not empty at 0 or n successes. */
void logistic_wilson_interval(size_t successes, size_t trials, double z, double *lo, double *hi);
/* The same where `unknown` of the trials have no outcome yet (unsettled verdicts): from the lower end with them all
 * failures to the upper end with them all successes, so that the interval covers both the sampling error and
 * whichever way they go; the Wilson interval when unknown is 0. */
void logistic_wilson_bounds(size_t successes, size_t unknown, size_t trials, double z, double *lo, double *hi);

#endif
