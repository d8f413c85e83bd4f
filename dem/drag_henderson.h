/* Module-private (dem/): Henderson's (1976) drag coefficient of a sphere in continuum and rarefied, subsonic and
 * supersonic flow (AIAA J. 14:707-708), as inline arithmetic (core/fastmath.h's exp, sqrt correctly rounded), for the
 * particles in the nozzle (dem/nozzle.c) and in the jet with [jet] drag = henderson (dem/gas_eval.h).
 * Re and M are the slip's; S = M sqrt(gamma/2) is the molecular speed ratio, tr = T_p/T_g the sphere's temperature
 * over the gas's. */
#ifndef SPRAYCOAT_DEM_DRAG_HENDERSON_H
#define SPRAYCOAT_DEM_DRAG_HENDERSON_H

#include <math.h>

#include "core/fastmath.h"

/* Below M = 1. */
FM_INLINE double henderson_subsonic(double re, double mach, double tr, double gamma)
{
    double s = mach * sqrt(0.5 * gamma), root_re = sqrt(re), poly = 0.03 * re + 0.48 * root_re;
    double m2 = mach * mach, m4 = m2 * m2;
    double viscous = 24.0 / (re + s * (4.33 + (3.65 - 1.53 * tr) / (1.0 + 0.353 * tr) * fm_exp(-0.247 * re / s)));
    double pressure = fm_exp(-0.5 * mach / root_re) * ((4.5 + 0.38 * poly) / (1.0 + poly) + 0.1 * m2 + 0.2 * m4 * m4);
    return viscous + pressure + (1.0 - fm_exp(-mach / re)) * 0.6 * s;
}

/* From M = 1.75. */
FM_INLINE double henderson_supersonic(double re, double mach, double tr, double gamma)
{
    double s = mach * sqrt(0.5 * gamma), s2 = s * s, root = 1.86 * sqrt(mach / re);
    double bracket = 2.0 + 2.0 / s2 + 1.058 / s * sqrt(tr) - 1.0 / (s2 * s2);
    return (0.9 + 0.34 / (mach * mach) + root * bracket) / (1.0 + root);
}

/* Between M = 1 and 1.75 Henderson interpolates linearly in M between the two formulas' values at those ends (at
 * the same Reynolds number). */
FM_INLINE double henderson_drag_coefficient(double re, double mach, double tr, double gamma)
{
    if (mach <= 1.0)
        return henderson_subsonic(re, mach, tr, gamma);
    if (mach >= 1.75)
        return henderson_supersonic(re, mach, tr, gamma);
    double at_one = henderson_subsonic(re, 1.0, tr, gamma);
    double at_end = henderson_supersonic(re, 1.75, tr, gamma);
    return at_one + (mach - 1.0) / 0.75 * (at_end - at_one);
}

#endif
