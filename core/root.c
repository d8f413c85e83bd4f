/* Illinois false position (core/root.h). */
#include "core/root.h"

#include "core/error.h"

int root_bracket_start(struct root_bracket *b, double lo, double f_lo, double hi, double f_hi)
{
    if (!(lo < hi))
        SC_FAIL(SC_EINPUT, "root bracket: the ends %g and %g are not in order", lo, hi);
    if (f_lo * f_hi > 0)
        SC_FAIL(SC_EINPUT, "root bracket: the values %g at %g and %g at %g have the same sign", f_lo, lo, f_hi, hi);
    *b = (struct root_bracket){lo, hi, f_lo, f_hi, 0};
    return SC_OK;
}

double root_bracket_next(const struct root_bracket *b)
{
    if (b->f_lo == b->f_hi) /* both zero: any point is a root */
        return 0.5 * (b->lo + b->hi);
    double x = b->hi - b->f_hi * (b->hi - b->lo) / (b->f_hi - b->f_lo);
    return x < b->lo ? b->lo : x > b->hi ? b->hi : x;
}

void root_bracket_update(struct root_bracket *b, double x, double f)
{
    if ((f < 0) == (b->f_lo < 0)) { /* x replaces lo; hi is kept */
        b->lo = x, b->f_lo = f;
        if (b->kept == 1)
            b->f_hi *= 0.5; /* the Illinois step: hi kept twice running */
        b->kept = 1;
    } else {
        b->hi = x, b->f_hi = f;
        if (b->kept == -1)
            b->f_lo *= 0.5;
        b->kept = -1;
    }
}
