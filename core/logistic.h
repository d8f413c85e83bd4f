/* Logistic regression by Newton's method (iteratively reweighted least squares), for the bonding calibration of
 * Tang (2021) Section 4.1.2: a second-order model in two variables (Eqs. 4.10-4.12) fitted to bonded (1) /
 * rebounded (0) outcomes by minimising the cost of Eq. 4.13, whose gradient is Eq. 4.14.
 *
 * Deterministic outcomes on a parameter grid are often separable: the maximum-likelihood coefficients are then
 * infinite (the cost keeps falling as |theta| grows) although the boundary Z = 0 is well defined.  An optional
 * ridge term (lambda/2) |theta_2..n|^2 added to m J keeps them finite; lambda = 0 is the plain maximum likelihood. */
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
    double cost;                      /* J of Eq. 4.13 at theta (without the ridge term) */
    int iterations, converged;        /* converged: the Newton step fell below 1e-10 (relative) */
    int separable;                    /* 1 when, without a ridge term, |theta| grew without bound */
};

/* Fit y[i] in {0, 1} (i < m) against the rows X[i p .. i p + p - 1] (p <= LOGISTIC_MAX_TERMS, the first column
 * normally 1) with ridge parameter lambda >= 0 (not applied to the first coefficient).  SC_EINPUT when m < 1 or p
 * is out of range; SC_ESIM when the Hessian is singular (a column that is zero or repeats another). */
int logistic_fit(const double *X, const int *y, size_t m, int p, double lambda, struct logistic_fit *fit);

#endif
