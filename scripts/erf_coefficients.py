#!/usr/bin/env python3
"""Coefficients of fm_erf_from_gauss (core/fastmath_special.h), printed for pasting into it.

|x| < 3/4: the Maclaurin series erf(x) = 2/sqrt(pi) sum_n (-1)^n x^(2n+1) / (n! (2n+1)), to n = 16.
|x| >= 3/4: erfc(t) = exp(-t^2) g(y) / (1 + 2 t), y = (t - K)/(t + K), K = 2, t = |x| in [3/4, 6], g a
Chebyshev series in y over [y(3/4), y(6)] (the map of Weideman, SIAM J. Numer. Anal. 31 (1994) 1497, which makes
e^(t^2) erfc(t) (1 + 2 t) smooth and slowly varying in y).  The samples of g are taken at Chebyshev nodes from
math.erfc and a 50-digit exp(t^2) (decimal), so g is good to about 1 ulp."""
import math
from decimal import Decimal, getcontext

getcontext().prec = 50
K = 2.0
T_LO, T_HI = 0.75, 6.0
DEGREE = 17
NODES = 64


def g_of_t(t):
    return float((Decimal(t) * Decimal(t)).exp() * Decimal(math.erfc(t)) * (1 + 2 * Decimal(t)))


def y_of_t(t):
    return (t - K) / (t + K)


def chebyshev(f, a, b, n):
    xs = [math.cos(math.pi * (k + 0.5) / n) for k in range(n)]
    fs = [f(0.5 * (b - a) * x + 0.5 * (b + a)) for x in xs]
    return [2.0 * math.fsum(fs[k] * math.cos(math.pi * j * (k + 0.5) / n) for k in range(n)) / n for j in range(n)]


def main():
    ya, yb = y_of_t(T_LO), y_of_t(T_HI)
    coeff = chebyshev(lambda y: g_of_t(K * (1 + y) / (1 - y)), ya, yb, NODES)[: DEGREE + 1]
    coeff[0] *= 0.5
    print("/* y range */ %.17g, %.17g" % (ya, yb))
    print("/* Chebyshev coefficients of g, c0 halved */")
    for c in coeff:
        print("    %.17g," % c)
    print("/* Maclaurin coefficients 2/sqrt(pi) (-1)^n / (n! (2n+1)) */")
    for n in range(17):
        print("    %.17g," % (2.0 / math.sqrt(math.pi) * (-1) ** n / (math.factorial(n) * (2 * n + 1))))


if __name__ == "__main__":
    main()
