/* A bracketed root of a function of one variable that is expensive and somewhat noisy to evaluate (each value a
 * search of many impact runs): the Illinois variant of false position (Dowell & Jarratt 1971,
 * docs/references.md).  The caller evaluates; this module keeps the bracket and proposes the next point, so that
 * the iteration can be replayed from recorded values after a restart.  False position keeps a bracket (a noisy
 * value cannot throw it out of the interval, unlike the secant method), and the Illinois step halves the value
 * kept at an end that has stayed twice running, which gives superlinear convergence where plain false position
 * stalls at one end. */
#ifndef SPRAYCOAT_CORE_ROOT_H
#define SPRAYCOAT_CORE_ROOT_H

struct root_bracket {
    double lo, hi;     /* the ends, lo < hi */
    double f_lo, f_hi; /* their values (the kept one scaled by the Illinois step), of opposite signs */
    int kept;          /* -1: lo was kept by the last update, +1: hi was, 0: neither yet */
};

/* The bracket [lo, hi] with values f_lo, f_hi.  SC_EINPUT when lo >= hi or the values do not differ in sign
 * (a zero value counts as either sign: the root is that end). */
int root_bracket_start(struct root_bracket *b, double lo, double f_lo, double hi, double f_hi);
/* The next point to evaluate: where the chord through the ends crosses zero, inside [lo, hi]. */
double root_bracket_next(const struct root_bracket *b);
/* Replace the end whose value has the sign of f (x from root_bracket_next, lo < x < hi). */
void root_bracket_update(struct root_bracket *b, double x, double f);

#endif
