/* Logistic regression by Newton's method (core/logistic.h): Tang (2021) Eqs. 4.10-4.14. */
#include "core/logistic.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"

#define MAX_ITERATIONS 200

void logistic_quadratic_terms(double x1, double x2, double terms[LOGISTIC_MAX_TERMS])
{
    terms[0] = 1.0;
    terms[1] = x1;
    terms[2] = x2;
    terms[3] = x1 * x1;
    terms[4] = x1 * x2;
    terms[5] = x2 * x2;
}

double logistic_quadratic_z(const double theta[LOGISTIC_MAX_TERMS], double x1, double x2)
{
    double terms[LOGISTIC_MAX_TERMS], z = 0;
    logistic_quadratic_terms(x1, x2, terms);
    for (int j = 0; j < LOGISTIC_MAX_TERMS; j++)
        z += terms[j] * theta[j];
    return z;
}

/* -log(sigma(z)) and -log(1 - sigma(z)) without overflow: log(1 + e^-z) and log(1 + e^z). */
static double log1pexp(double z)
{
    return z > 0 ? z + log1p(exp(-z)) : log1p(exp(z));
}

/* m J (Eq. 4.13 times m) and, when lambda > 0, the ridge term. */
static double penalised_cost(const double *X, const int *y, size_t m, int p, double lambda, const double *theta,
                             double *plain)
{
    double sum = 0;
    for (size_t i = 0; i < m; i++) {
        double z = 0;
        for (int j = 0; j < p; j++)
            z += X[i * (size_t)p + (size_t)j] * theta[j];
        sum += y[i] ? log1pexp(-z) : log1pexp(z);
    }
    if (plain)
        *plain = sum / (double)m;
    for (int j = 1; j < p; j++)
        sum += 0.5 * lambda * theta[j] * theta[j];
    return sum;
}

/* Gradient (m times Eq. 4.14, plus the ridge term) and Hessian X^T W X (+ lambda) at theta. */
static void gradient_hessian(const double *X, const int *y, size_t m, int p, double lambda, const double *theta,
                             double *g, double *H)
{
    memset(g, 0, (size_t)p * sizeof *g);
    memset(H, 0, (size_t)(p * p) * sizeof *H);
    for (size_t i = 0; i < m; i++) {
        const double *row = X + i * (size_t)p;
        double z = 0;
        for (int j = 0; j < p; j++)
            z += row[j] * theta[j];
        double h = 1.0 / (1.0 + exp(-z)), w = h * (1.0 - h);
        for (int j = 0; j < p; j++) {
            g[j] += row[j] * (h - y[i]);
            for (int k = 0; k < p; k++)
                H[j * p + k] += w * row[j] * row[k];
        }
    }
    for (int j = 1; j < p; j++) {
        g[j] += lambda * theta[j];
        H[j * p + j] += lambda;
    }
}

/* Cholesky factor L (lower, in place) of the symmetric positive definite A; -1 when it is not. */
static int cholesky(double *A, int p)
{
    for (int j = 0; j < p; j++) {
        double d = A[j * p + j];
        for (int k = 0; k < j; k++)
            d -= A[j * p + k] * A[j * p + k];
        if (!(d > 1e-300))
            return -1;
        A[j * p + j] = sqrt(d);
        for (int i = j + 1; i < p; i++) {
            double s = A[i * p + j];
            for (int k = 0; k < j; k++)
                s -= A[i * p + k] * A[j * p + k];
            A[i * p + j] = s / A[j * p + j];
        }
    }
    return 0;
}

/* x = (L L^T)^-1 b. */
static void cholesky_solve(const double *L, int p, const double *b, double *x)
{
    for (int i = 0; i < p; i++) {
        double s = b[i];
        for (int k = 0; k < i; k++)
            s -= L[i * p + k] * x[k];
        x[i] = s / L[i * p + i];
    }
    for (int i = p - 1; i >= 0; i--) {
        double s = x[i];
        for (int k = i + 1; k < p; k++)
            s -= L[k * p + i] * x[k];
        x[i] = s / L[i * p + i];
    }
}

/* One damped Newton step: the full step, halved until the penalised cost does not rise.  Returns the step's
 * largest relative change, or -1 when the Hessian is singular. */
static double newton_step(const double *X, const int *y, size_t m, int p, double lambda, double *theta, double *cost)
{
    double g[LOGISTIC_MAX_TERMS], H[LOGISTIC_MAX_TERMS * LOGISTIC_MAX_TERMS], step[LOGISTIC_MAX_TERMS];
    gradient_hessian(X, y, m, p, lambda, theta, g, H);
    if (cholesky(H, p) != 0)
        return -1;
    cholesky_solve(H, p, g, step);
    double trial[LOGISTIC_MAX_TERMS], scale = 1.0, change = 0;
    for (int halvings = 0; halvings < 40; halvings++, scale *= 0.5) {
        for (int j = 0; j < p; j++)
            trial[j] = theta[j] - scale * step[j];
        double c = penalised_cost(X, y, m, p, lambda, trial, NULL);
        if (c <= *cost) {
            *cost = c;
            break;
        }
    }
    for (int j = 0; j < p; j++) {
        change = fmax(change, fabs(trial[j] - theta[j]) / (1.0 + fabs(theta[j])));
        theta[j] = trial[j];
    }
    return change;
}

/* Standard errors from the inverse of the (penalised) Hessian at the fit. */
static int standard_errors(const double *X, const int *y, size_t m, int p, double lambda, struct logistic_fit *fit)
{
    double g[LOGISTIC_MAX_TERMS], H[LOGISTIC_MAX_TERMS * LOGISTIC_MAX_TERMS];
    gradient_hessian(X, y, m, p, lambda, fit->theta, g, H);
    if (cholesky(H, p) != 0) {
        for (int j = 0; j < p; j++)
            fit->se[j] = INFINITY;
        for (int j = 0; j < p * p; j++)
            fit->covariance[j] = INFINITY;
        return SC_OK;
    }
    for (int j = 0; j < p; j++) {
        double e[LOGISTIC_MAX_TERMS] = {0}, column[LOGISTIC_MAX_TERMS];
        e[j] = 1.0;
        cholesky_solve(H, p, e, column);
        fit->se[j] = sqrt(column[j]);
        for (int k = 0; k < p; k++)
            fit->covariance[k * p + j] = column[k];
    }
    return SC_OK;
}

/* 1 when the sign of Z = X theta (Tang Eq. 4.12) gives every outcome: Z > 0 for each success, Z < 0 for each
 * failure (an outcome at Z = 0 is on neither side). */
static int separates(const double *X, const int *y, size_t m, int p, const double *theta)
{
    for (size_t i = 0; i < m; i++) {
        double z = 0;
        for (int j = 0; j < p; j++)
            z += X[i * (size_t)p + (size_t)j] * theta[j];
        if (!(y[i] ? z > 0 : z < 0))
            return 0;
    }
    return 1;
}

int logistic_fit(const double *X, const int *y, size_t m, int p, double lambda, struct logistic_fit *fit)
{
    memset(fit, 0, sizeof *fit);
    if (m < 1 || p < 1 || p > LOGISTIC_MAX_TERMS || !(lambda >= 0))
        SC_FAIL(SC_EINPUT,
                "logistic fit: %zu outcomes, %d terms, lambda %g; allowed: m >= 1, 1 <= p <= %d, lambda >= 0", m, p,
                lambda, LOGISTIC_MAX_TERMS);
    fit->terms = p;
    double cost = penalised_cost(X, y, m, p, lambda, fit->theta, NULL);
    for (fit->iterations = 1; fit->iterations <= MAX_ITERATIONS; fit->iterations++) {
        double change = newton_step(X, y, m, p, lambda, fit->theta, &cost);
        if (change < 0 && penalised_cost(X, y, m, p, 0.0, fit->theta, NULL) < 1e-6 * (double)m)
            break; /* separated: the weights h (1 - h) underflow as |Z| grows */
        if (change < 0)
            SC_FAIL(SC_ESIM,
                    "logistic fit: the Hessian is singular at iteration %d (a term that is zero or repeats "
                    "another over the %zu outcomes)",
                    fit->iterations, m);
        if (change < 1e-10) {
            fit->converged = 1;
            break;
        }
    }
    penalised_cost(X, y, m, p, lambda, fit->theta, &fit->cost);
    /* separated data: without a ridge term the likelihood tends to 1 while theta runs away; with one the fit
     * converges, but its boundary may lie anywhere in the gap the outcomes leave, placed by lambda: either way the
     * fit's own Z shows it */
    fit->separable = separates(X, y, m, p, fit->theta);
    return standard_errors(X, y, m, p, lambda, fit);
}

/* The highest failure and the lowest success among the outcomes (-INFINITY / INFINITY when there is none). */
static void outcome_ranges(const double *x, const int *y, size_t m, double *highest_failure, double *lowest_success)
{
    *highest_failure = -INFINITY;
    *lowest_success = INFINITY;
    for (size_t i = 0; i < m; i++) {
        if (y[i])
            *lowest_success = fmin(*lowest_success, x[i]);
        else
            *highest_failure = fmax(*highest_failure, x[i]);
    }
}

int logistic_threshold_fit(const double *x, const int *y, size_t m, double center, double scale,
                           struct logistic_threshold *out)
{
    memset(out, 0, sizeof *out);
    out->x50 = out->se = out->width = NAN;
    if (!(scale > 0) || !isfinite(center))
        SC_FAIL(SC_EINPUT, "logistic threshold: center %g, scale %g; allowed: finite center, scale > 0", center, scale);
    double highest_failure, lowest_success;
    outcome_ranges(x, y, m, &highest_failure, &lowest_success);
    if (isinf(highest_failure) || isinf(lowest_success))
        return SC_OK;
    out->rising = 1;
    if (highest_failure <= lowest_success) {
        out->separable = 1;
        out->x50 = 0.5 * (highest_failure + lowest_success);
        return SC_OK;
    }
    double *X = malloc(2 * m * sizeof *X);
    if (!X)
        SC_FAIL_OOM(2 * m * sizeof *X, "the logistic threshold fit");
    for (size_t i = 0; i < m; i++) {
        X[2 * i] = 1.0;
        X[2 * i + 1] = (x[i] - center) / scale;
    }
    int status = logistic_fit(X, y, m, 2, 0.0, &out->fit);
    free(X);
    SC_TRY(status);
    const double *theta = out->fit.theta, *cov = out->fit.covariance;
    if (!(theta[1] > 0)) {
        out->rising = 0;
        return SC_OK;
    }
    out->x50 = center - scale * theta[0] / theta[1];
    /* delta method: the gradient of x50 in (theta_0, theta_1) */
    double g0 = -scale / theta[1], g1 = scale * theta[0] / (theta[1] * theta[1]);
    out->se = sqrt(g0 * g0 * cov[0] + 2 * g0 * g1 * cov[1] + g1 * g1 * cov[3]);
    out->width = 2 * log(9.0) * scale / theta[1];
    return SC_OK;
}

void logistic_wilson_interval(size_t successes, size_t trials, double z, double *lo, double *hi)
{
    if (trials == 0) {
        *lo = 0.0, *hi = 1.0;
        return;
    }
    double n = (double)trials, p = (double)successes / n, z2 = z * z;
    double centre = (p + z2 / (2.0 * n)) / (1.0 + z2 / n);
    double half = z / (1.0 + z2 / n) * sqrt(p * (1.0 - p) / n + z2 / (4.0 * n * n));
    /* at no success (every one) the lower (upper) bound is exactly 0 (1): centre and half agree there, but their
     * difference in floating point left 5.6e-17, printed "5.55e-15 %" (a review) */
    *lo = successes == 0 ? 0.0 : fmax(0.0, centre - half);
    *hi = successes == trials ? 1.0 : fmin(1.0, centre + half);
}

void logistic_wilson_bounds(size_t successes, size_t unknown, size_t trials, double z, double *lo, double *hi)
{
    double ignored;
    logistic_wilson_interval(successes, trials, z, lo, &ignored);
    logistic_wilson_interval(successes + unknown, trials, z, &ignored, hi);
}
