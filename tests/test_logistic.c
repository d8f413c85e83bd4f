/* Logistic regression (core/logistic.c; Tang 2021 Eqs. 4.10-4.14): the maximum-likelihood fit of a small data set
 * against statsmodels, the ridge fit against scipy, recovery of known coefficients from many outcomes, and the
 * behaviour on separable outcomes (the usual case of a deterministic calibration grid). */
#include "core/logistic.h"
#include "tests/check.h"

#include <stdint.h>
#include <stdlib.h>

/* 40 outcomes drawn from the second-order model theta = (-1, 2, 1, -1.5, 1, 0.5) (numpy default_rng(7)).
 * Reference fits: scripts/logistic_reference.py, run once with Debian's python3-statsmodels 0.13.5 (Logit, Newton,
 * tol 1e-14: converged) and scipy 1.10.1 (BFGS on the ridge cost, gtol 1e-12). */
static const double small_x1[] = {0.63, 0.90, 0.78, 0.23, 0.30, 0.87, 0.01, 0.82, 0.80, 0.47, 0.30, 0.28, 0.25, 0.45,
                                  0.50, 0.55, 1.00, 0.79, 0.62, 0.99, 0.22, 0.16, 0.61, 0.04, 0.04, 0.51, 0.47, 0.92,
                                  0.63, 0.51, 0.50, 0.25, 0.01, 0.19, 0.69, 0.20, 0.37, 0.00, 0.83, 0.15};
static const double small_x2[] = {0.27, 0.88, 0.51, 0.85, 0.64, 0.74, 0.09, 0.54, 0.51, 0.87, 0.36, 0.60, 0.06, 0.39,
                                  0.32, 0.15, 0.82, 0.38, 0.98, 0.59, 0.61, 0.64, 0.68, 0.15, 0.44, 0.24, 0.40, 0.10,
                                  0.97, 0.22, 0.67, 0.30, 0.87, 0.66, 0.13, 0.85, 0.94, 0.90, 0.57, 0.15};
static const int small_y[] = {1, 0, 1, 1, 0, 1, 0, 1, 1, 1, 1, 0, 0, 1, 1, 0, 1, 1, 1, 1,
                              0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 0, 1, 0, 1, 0, 0, 1, 1, 0};
#define SMALL_N 40
static const double statsmodels_theta[] = {-6.620101896311481, 10.113047210050476, 10.926229366244566,
                                           -1.220822518097533, -8.358665156217802, -4.185608585055139};
static const double statsmodels_se[] = {4.032272711224031, 8.22305822699972,  9.006976556394111,
                                        5.481602728890614, 6.822645343029864, 6.352653175219944};
static const double statsmodels_loglik = -20.928788825038918;
static const double scipy_ridge_theta[] = {-1.4634702494352374, 1.246961442588085,   0.7110507607676592,
                                           1.1144798817298605,  0.46828876754072185, 0.5044116824704818};

static void quadratic_rows(const double *x1, const double *x2, size_t n, double *X)
{
    for (size_t i = 0; i < n; i++)
        logistic_quadratic_terms(x1[i], x2[i], X + 6 * i);
}

static void test_small_data_set_against_statsmodels(void)
{
    double X[6 * SMALL_N];
    quadratic_rows(small_x1, small_x2, SMALL_N, X);
    struct logistic_fit fit;
    CHECK(logistic_fit(X, small_y, SMALL_N, 6, 0.0, &fit) == 0, "fit failed");
    CHECK(fit.converged && !fit.separable, "converged %d separable %d", fit.converged, fit.separable);
    for (int j = 0; j < 6; j++) {
        CHECK_CLOSE(fit.theta[j], statsmodels_theta[j], 1e-7, 1e-9, "theta");
        CHECK_CLOSE(fit.se[j], statsmodels_se[j], 1e-6, 1e-9, "standard error");
    }
    CHECK_CLOSE(-fit.cost * SMALL_N, statsmodels_loglik, 1e-10, 0, "log-likelihood (-m J, Eq. 4.13)");
}

static void test_ridge_against_scipy(void)
{
    double X[6 * SMALL_N];
    quadratic_rows(small_x1, small_x2, SMALL_N, X);
    struct logistic_fit fit;
    CHECK(logistic_fit(X, small_y, SMALL_N, 6, 0.5, &fit) == 0, "fit failed");
    CHECK(fit.converged && !fit.separable, "converged %d separable %d (the outcomes overlap)", fit.converged,
          fit.separable);
    for (int j = 0; j < 6; j++)
        CHECK_CLOSE(fit.theta[j], scipy_ridge_theta[j], 1e-5, 1e-7, "ridge theta (lambda 0.5)");
}

/* splitmix64: uniform doubles in [0, 1) */
static double uniform(uint64_t *state)
{
    uint64_t z = (*state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    z ^= z >> 31;
    return (double)(z >> 11) * 0x1.0p-53;
}

/* 40,000 outcomes drawn from known coefficients: each coefficient recovered within 3 of its standard errors (the
 * standard errors themselves a few per cent of the coefficients: the check can miss). */
static void test_known_coefficients_recovered(void)
{
    enum { N = 40000 };
    static const double theta[6] = {-2.0, 3.0, 1.5, -2.5, 2.0, 1.0};
    double *X = malloc(6 * N * sizeof *X), x1[1], x2[1];
    int *y = malloc(N * sizeof *y);
    uint64_t state = 20261203u;
    for (size_t i = 0; i < N; i++) {
        x1[0] = 2 * uniform(&state) - 0.5, x2[0] = 2 * uniform(&state) - 0.5;
        quadratic_rows(x1, x2, 1, X + 6 * i);
        double p = 1.0 / (1.0 + exp(-logistic_quadratic_z(theta, x1[0], x2[0])));
        y[i] = uniform(&state) < p;
    }
    struct logistic_fit fit;
    CHECK(logistic_fit(X, y, N, 6, 0.0, &fit) == 0, "fit failed");
    CHECK(fit.converged, "not converged");
    for (int j = 0; j < 6; j++) {
        CHECK(fabs(fit.theta[j] - theta[j]) < 3 * fit.se[j], "theta[%d] = %.4f +- %.4f, true %.4f", j, fit.theta[j],
              fit.se[j], theta[j]);
        CHECK(fit.se[j] < 0.15 * fabs(theta[j]), "se[%d] = %.4f too large to test anything", j, fit.se[j]);
    }
    free(X);
    free(y);
}

/* Outcomes of a grid separated by the circle (x1 - 0.5)^2 + (x2 - 0.5)^2 = 0.095 (bonded outside): without a
 * ridge term the fit says separable; with one it converges, still says separable (its boundary is one of many in
 * the gap, placed by the ridge: calibrate.csv and calibrate.h5 say so), and its boundary h = 0.5 (Z = 0) separates
 * every point, passing within half a grid step of the true circle on its axes.  A tie (a success and a failure at
 * the same point) is not separable. */
static void test_separable_grid(void)
{
    enum { K = 11 };
    double X[6 * K * K], x1[K * K], x2[K * K];
    int y[K * K];
    for (int i = 0; i < K * K; i++) {
        x1[i] = (i % K) / (K - 1.0), x2[i] = (i / K) / (K - 1.0);
        y[i] = (x1[i] - 0.5) * (x1[i] - 0.5) + (x2[i] - 0.5) * (x2[i] - 0.5) > 0.095;
    }
    quadratic_rows(x1, x2, K * K, X);
    struct logistic_fit fit;
    CHECK(logistic_fit(X, y, K * K, 6, 0.0, &fit) == 0, "fit without ridge failed");
    CHECK(fit.separable, "separable data not flagged (cost %g, converged %d)", fit.cost, fit.converged);
    CHECK(logistic_fit(X, y, K * K, 6, 1e-3, &fit) == 0, "fit with ridge failed");
    CHECK(fit.converged && fit.separable, "ridge fit: converged %d separable %d", fit.converged, fit.separable);
    int wrong = 0;
    for (int i = 0; i < K * K; i++)
        wrong += (logistic_quadratic_z(fit.theta, x1[i], x2[i]) > 0) != y[i];
    CHECK(wrong == 0, "%d of %d grid points on the wrong side of Z = 0", wrong, K * K);
    /* along x2 = 0.5 the boundary crosses x1 = 0.192 and 0.808 (true radius 0.308; grid step 0.1) */
    double lo = 0, hi = 0.5;
    for (int k = 0; k < 60; k++) {
        double mid = 0.5 * (lo + hi);
        (logistic_quadratic_z(fit.theta, mid, 0.5) > 0 ? (lo = mid) : (hi = mid));
    }
    CHECK(fabs(lo - 0.192) <= 0.05, "boundary at x1 = %.4f on x2 = 0.5; the circle is at 0.192 (+- 0.05)", lo);
    /* one variable: failures at -1 and 0, successes at 0 and 1 */
    const double tie_X[] = {1, -1, 1, 0, 1, 0, 1, 1};
    const int tie_y[] = {0, 0, 1, 1};
    CHECK(logistic_fit(tie_X, tie_y, 4, 2, 1e-3, &fit) == 0, "fit of the tie failed");
    CHECK(fit.converged && !fit.separable, "tie: converged %d separable %d", fit.converged, fit.separable);
}

static void test_refuses_bad_arguments(void)
{
    double X[6] = {1, 0, 0, 0, 0, 0};
    int y[1] = {1};
    struct logistic_fit fit;
    CHECK(logistic_fit(X, y, 0, 6, 0, &fit) != 0, "no outcomes accepted");
    CHECK(logistic_fit(X, y, 1, 7, 0, &fit) != 0, "7 terms accepted");
    CHECK(logistic_fit(X, y, 1, 6, -1, &fit) != 0, "negative lambda accepted");
}

/* The threshold of a first-order fit in one variable (logistic_threshold_fit), on outcomes whose maximum-likelihood
 * fit is known in closed form: 1 of 4 successes at 800 and 3 of 4 at 810 are fitted exactly (the model is
 * saturated), logit h = -ln 3 and +ln 3, so x50 = 805, the 10-90 % width is 2 ln 9 / (2 ln 3 / 10) = 20, and the
 * delta-method standard error from the inverse Hessian (weights 4 h (1 - h) = 3/4 at both speeds) is
 * 10 / (ln 3 sqrt 6) = 3.716. */
static void test_threshold_closed_form(void)
{
    const double x[8] = {800, 800, 800, 800, 810, 810, 810, 810};
    const int y[8] = {1, 0, 0, 0, 1, 1, 0, 1};
    struct logistic_threshold t;
    CHECK(logistic_threshold_fit(x, y, 8, 790, 10, &t) == 0, "fit failed");
    CHECK(t.rising && !t.separable, "rising %d separable %d", t.rising, t.separable);
    CHECK_CLOSE(t.x50, 805.0, 1e-9, 0, "x50");
    CHECK_CLOSE(t.width, 20.0, 1e-8, 0, "10-90 % width");
    CHECK_CLOSE(t.se, 10.0 / (log(3.0) * sqrt(6.0)), 1e-7, 0, "standard error of x50 (delta method)");
}

/* 20,000 outcomes at speeds uniform in 700-900 m/s from h = sigma((v - 780) / 8): the fitted threshold within 3 of
 * its standard errors of 780 (the standard error itself under 1 m/s: the check can miss), the width within 5 % of
 * 2 ln 9 x 8 = 35.2 m/s. */
static void test_threshold_recovered(void)
{
    enum { N = 20000 };
    double *x = malloc(N * sizeof *x);
    int *y = malloc(N * sizeof *y);
    uint64_t state = 20261205u;
    for (size_t i = 0; i < N; i++) {
        x[i] = 700 + 200 * uniform(&state);
        y[i] = uniform(&state) < 1.0 / (1.0 + exp(-(x[i] - 780) / 8));
    }
    struct logistic_threshold t;
    CHECK(logistic_threshold_fit(x, y, N, 800, 10, &t) == 0, "fit failed");
    CHECK(fabs(t.x50 - 780) < 3 * t.se && t.se < 1.0, "x50 = %.3f +- %.3f, true 780", t.x50, t.se);
    CHECK_CLOSE(t.width, 2 * log(9.0) * 8, 0.05, 0, "width");
    free(x);
    free(y);
}

/* Separable outcomes have no finite fit: x50 is the middle of the gap between the highest failure and the lowest
 * success; a tie at one speed puts it there.  Outcomes that fall with x, or all of one kind, have no threshold. */
static void test_threshold_separable_and_none(void)
{
    const double x[6] = {500, 700, 780, 790, 850, 1200};
    const int y[6] = {0, 0, 0, 1, 1, 1}, tie[6] = {0, 0, 1, 0, 1, 1}, falling[6] = {1, 1, 1, 0, 1, 0},
              none[6] = {0, 0, 0, 0, 0, 0};
    const double x_tie[6] = {500, 700, 780, 780, 850, 1200};
    struct logistic_threshold t;
    CHECK(logistic_threshold_fit(x, y, 6, 800, 10, &t) == 0 && t.separable, "separable not found");
    CHECK_CLOSE(t.x50, 785.0, 1e-12, 0, "x50 of separable outcomes");
    CHECK(isnan(t.se) && isnan(t.width), "se %g width %g of separable outcomes", t.se, t.width);
    CHECK(logistic_threshold_fit(x_tie, tie, 6, 800, 10, &t) == 0 && t.separable, "tie not separable");
    CHECK_CLOSE(t.x50, 780.0, 1e-12, 0, "x50 at a tie");
    CHECK(logistic_threshold_fit(x, falling, 6, 800, 10, &t) == 0, "falling fit failed");
    CHECK(!t.rising && isnan(t.x50), "falling outcomes: rising %d x50 %g", t.rising, t.x50);
    CHECK(logistic_threshold_fit(x, none, 6, 800, 10, &t) == 0, "one-sided fit failed");
    CHECK(!t.rising && isnan(t.x50), "no success: rising %d x50 %g", t.rising, t.x50);
    CHECK(logistic_threshold_fit(x, y, 6, 800, 0, &t) != 0, "scale 0 accepted");
}

/* The Wilson score interval against Newcombe (1998), Table II, method 3 (95 %, to his four decimals): 81/263
 * 0.2553-0.3662, 15/148 0.0624-0.1605, 0/20 0-0.1611, 1/29 0.0061-0.1718; no trials: [0, 1]. */
static void test_wilson_interval_against_newcombe(void)
{
    const struct {
        size_t k, n;
        double lo, hi;
    } table[] = {{81, 263, 0.2553, 0.3662}, {15, 148, 0.0624, 0.1605}, {0, 20, 0.0, 0.1611}, {1, 29, 0.0061, 0.1718}};
    for (size_t i = 0; i < sizeof table / sizeof table[0]; i++) {
        double lo, hi;
        logistic_wilson_interval(table[i].k, table[i].n, 1.959964, &lo, &hi);
        printf("  %zu/%zu: %.4f-%.4f (Newcombe %.4f-%.4f)\n", table[i].k, table[i].n, lo, hi, table[i].lo, table[i].hi);
        CHECK_CLOSE(lo, table[i].lo, 0.0, 0.5e-4, "lower bound");
        CHECK_CLOSE(hi, table[i].hi, 0.0, 0.5e-4, "upper bound");
    }
    double lo, hi;
    logistic_wilson_interval(0, 0, 1.96, &lo, &hi);
    CHECK(lo == 0.0 && hi == 1.0, "no trials: [%g, %g]", lo, hi);
    /* unknown outcomes (unsettled verdicts) taken either way: 0 of 4 with 4 unknown is [0, 1]; 1 of 4 with 2
     * unknown spans Wilson's 1 of 4 below and 3 of 4 above (Newcombe's method 3 by hand: 0.0456 and 0.9544); none
     * unknown is the Wilson interval */
    logistic_wilson_bounds(0, 4, 4, 1.959964, &lo, &hi);
    CHECK(lo == 0.0 && hi == 1.0, "0 of 4, 4 unknown: [%g, %g]", lo, hi);
    logistic_wilson_bounds(1, 2, 4, 1.959964, &lo, &hi);
    CHECK_CLOSE(lo, 0.0456, 0.0, 0.5e-4, "1 of 4, 2 unknown: lower bound");
    CHECK_CLOSE(hi, 0.9544, 0.0, 0.5e-4, "1 of 4, 2 unknown: upper bound");
    double wlo, whi;
    logistic_wilson_bounds(81, 0, 263, 1.959964, &lo, &hi);
    logistic_wilson_interval(81, 263, 1.959964, &wlo, &whi);
    CHECK(lo == wlo && hi == whi, "none unknown: [%g, %g], Wilson [%g, %g]", lo, hi, wlo, whi);
    /* none and all of a few (the demo's 3 runs): the bound at the end is that end exactly (0 of 3 gave 5.55e-17) */
    for (size_t n = 1; n <= 8; n++) {
        logistic_wilson_interval(0, n, 1.959964, &lo, &hi);
        CHECK(lo == 0.0, "0 of %zu: lower bound %g, not 0", n, lo);
        logistic_wilson_interval(n, n, 1.959964, &lo, &hi);
        CHECK(hi == 1.0, "%zu of %zu: upper bound 1 - %g, not 1", n, n, 1.0 - hi);
    }
}

int main(void)
{
    RUN(test_small_data_set_against_statsmodels);
    RUN(test_ridge_against_scipy);
    RUN(test_known_coefficients_recovered);
    RUN(test_separable_grid);
    RUN(test_refuses_bad_arguments);
    RUN(test_threshold_closed_form);
    RUN(test_threshold_recovered);
    RUN(test_threshold_separable_and_none);
    RUN(test_wilson_interval_against_newcombe);
    return check_finish();
}
