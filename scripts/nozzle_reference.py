#!/usr/bin/env python3
"""Reference values for tests/test_nozzle.c, computed apart from the C code (python3, standard library only).

Henderson (1976), "Drag coefficients of spheres in continuum and rarefied flows", AIAA J. 14:707-708:
  subsonic (M <= 1):
    C_D = 24 / (Re + S [4.33 + (3.65 - 1.53 Tw/T) / (1 + 0.353 Tw/T) exp(-0.247 Re / S)])
        + exp(-M / (2 sqrt(Re))) [(4.5 + 0.38 (0.03 Re + 0.48 sqrt(Re))) / (1 + 0.03 Re + 0.48 sqrt(Re))
                                  + 0.1 M^2 + 0.2 M^8]
        + [1 - exp(-M / Re)] 0.6 S
  supersonic (M >= 1.75):
    C_D = (0.9 + 0.34 / M^2 + 1.86 sqrt(M / Re) [2 + 2 / S^2 + 1.058 sqrt(Tw/T) / S - 1 / S^4])
          / (1 + 1.86 sqrt(M / Re))
  between: C_D(1) + (4/3) (M - 1) [C_D(1.75) - C_D(1)], both at the same Re;  S = M sqrt(gamma / 2).

The particle's rates in the nozzle (docs/nozzle.md): at the throat of the item-6 nozzle (N2, p0 6.55 MPa, T0 698.15
K; M = 1, T = T0 / 1.2, p = p0 1.2^-3.5), a 20 um Al particle (2700 kg/m3, 896 J/kg/K) at v = 300 m/s and T_p =
400 K: dv/dx = F / (m v), dT_p/dx = Q / (m c_p v), dt/dx = 1 / v, with F = rho C_D (pi d^2 / 8) |u - v| (u - v),
Q = Nu k pi d (T_r - T_p), Nu = 2 + 0.6 Re^(1/2) Pr^(1/3) (Ranz & Marshall 1952), k = mu c_p,gas / Pr,
T_r = T + Pr^(1/3) (u - v)^2 / (2 c_p,gas); mu from Sutherland's law mu0 (T/T0)^(3/2) (T0 + S) / (T + S) with
White's N2 constants 1.663e-5 Pa s, 273 K, 107 K; R = 296.80 J/kg/K, gamma 1.4, Pr 0.72.

Run: python3 scripts/nozzle_reference.py (prints the values the test holds, 17 digits).
"""
import math


def henderson_subsonic(re, m, tr, g):
    s = m * math.sqrt(g / 2)
    viscous = 24 / (re + s * (4.33 + (3.65 - 1.53 * tr) / (1 + 0.353 * tr) * math.exp(-0.247 * re / s)))
    b = 0.03 * re + 0.48 * math.sqrt(re)
    pressure = math.exp(-m / (2 * math.sqrt(re))) * ((4.5 + 0.38 * b) / (1 + b) + 0.1 * m ** 2 + 0.2 * m ** 8)
    return viscous + pressure + (1 - math.exp(-m / re)) * 0.6 * s


def henderson_supersonic(re, m, tr, g):
    s = m * math.sqrt(g / 2)
    a = 1.86 * math.sqrt(m / re)
    return (0.9 + 0.34 / m ** 2 + a * (2 + 2 / s ** 2 + 1.058 / s * math.sqrt(tr) - 1 / s ** 4)) / (1 + a)


def henderson(re, m, tr, g):
    if m <= 1:
        return henderson_subsonic(re, m, tr, g)
    if m >= 1.75:
        return henderson_supersonic(re, m, tr, g)
    low, high = henderson_subsonic(re, 1.0, tr, g), henderson_supersonic(re, 1.75, tr, g)
    return low + 4 / 3 * (m - 1) * (high - low)


def throat_rates():
    g, r, pr = 1.4, 296.80, 0.72
    t0, p0 = 698.15, 6.55e6
    t = t0 / 1.2
    p = p0 * 1.2 ** -3.5
    rho = p / (r * t)
    u = math.sqrt(g * r * t)
    mu = 1.663e-5 * (t / 273.0) ** 1.5 * (273.0 + 107.0) / (t + 107.0)
    d, v, tp, rho_p, c_p = 20e-6, 300.0, 400.0, 2700.0, 896.0
    slip = u - v
    re = rho * abs(slip) * d / mu
    cd = henderson(re, abs(slip) / math.sqrt(g * r * t), tp / t, g)
    force = rho * cd * math.pi * d * d / 8 * abs(slip) * slip
    cp_gas = g * r / (g - 1)
    k = mu * cp_gas / pr
    nu = 2 + 0.6 * math.sqrt(re) * pr ** (1 / 3)
    t_rec = t + pr ** (1 / 3) * slip * slip / (2 * cp_gas)
    q = nu * k * math.pi * d * (t_rec - tp)
    m = rho_p * math.pi * d ** 3 / 6
    return force / (m * v), q / (m * c_p * v), 1 / v


if __name__ == "__main__":
    for re, m, tr, g in [(100, 0.5, 1, 1.4), (1000, 0.5, 1, 1.4), (500, 1.3, 1, 1.4), (100, 2.0, 2, 1.4),
                         (1172, 1.08, 1, 1.4), (10, 0.2, 1.5, 5 / 3)]:
        print(f"C_D(Re {re}, M {m}, Tw/T {tr}, gamma {g:.6g}) = {henderson(re, m, tr, g):.17g}")
    print("throat rates dv/dx, dT/dx, dt/dx = %.17g, %.17g, %.17g" % throat_rates())
