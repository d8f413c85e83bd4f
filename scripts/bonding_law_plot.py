#!/usr/bin/env python3
"""docs/bonding_law.svg: the bonding increment per step against the rate ratio, the thesis's printed law
(Eqs. 4.16-4.17; Eqs. 4.3-4.5 have the same shape) and the bounded law of mpm/bonding.c (bonding_floor 0.5).

Both laws as functions of the rate ratio r = dG/(dG_c/dt dt) (energy) or eps_dot/eps_dot_c (strain), in units of
the step's critical increment (dG_c/dt dt / G_c, or eps_dot_c dt / eps_c): dD = r / (1 - ln r) as printed (0 where
1 - ln r <= 0, the code before), dD = r / max(1 - ln r, floor) bounded.  tests/test_bonding_law.c checks the code
against these formulas.  Plain SVG, no plotting library: python3 scripts/bonding_law_plot.py > docs/bonding_law.svg
"""
import math

FLOOR = 0.5
W, H, L, R, T, B = 640, 420, 70, 20, 40, 60  # size and margins (px)
XMIN, XMAX, YMIN, YMAX = -2.0, 3.0, -2.0, 3.0  # log10 ranges


def printed(r):
    f = 1.0 - math.log(r)
    return r / f if f > 0 else None


def bounded(r):
    return r / max(1.0 - math.log(r), FLOOR)


def px(lx, ly):
    x = L + (lx - XMIN) / (XMAX - XMIN) * (W - L - R)
    y = T + (YMAX - ly) / (YMAX - YMIN) * (H - T - B)
    return x, y


def polyline(points, style):
    pts = " ".join("%.1f,%.1f" % px(a, b) for a, b in points)
    return '<polyline fill="none" %s points="%s"/>' % (style, pts)


def curve(law):
    segments, current = [], []
    for k in range(2001):
        lr = XMIN + (XMAX - XMIN) * k / 2000
        d = law(10 ** lr)
        if d is None or d <= 0 or math.log10(d) > YMAX:
            if current and d is not None and d > 0:  # leaving the top of the plot (the printed law: to +inf at e)
                current.append((lr, YMAX))
            if current:
                segments.append(current)
            current = []
            continue
        current.append((lr, max(math.log10(d), YMIN)))
    if current:
        segments.append(current)
    return segments


out = ['<svg xmlns="http://www.w3.org/2000/svg" width="%d" height="%d" font-family="sans-serif" font-size="12">' % (W, H),
       '<rect width="100%" height="100%" fill="white"/>']
for d in range(int(XMIN), int(XMAX) + 1):
    x, _ = px(d, YMIN)
    out.append('<line x1="%.1f" y1="%d" x2="%.1f" y2="%d" stroke="#ddd"/>' % (x, T, x, H - B))
    out.append('<text x="%.1f" y="%d" text-anchor="middle">1e%d</text>' % (x, H - B + 16, d))
for d in range(int(YMIN), int(YMAX) + 1):
    _, y = px(XMIN, d)
    out.append('<line x1="%d" y1="%.1f" x2="%d" y2="%.1f" stroke="#ddd"/>' % (L, y, W - R, y))
    out.append('<text x="%d" y="%.1f" text-anchor="end">1e%d</text>' % (L - 6, y + 4, d))
out.append('<rect x="%d" y="%d" width="%d" height="%d" fill="none" stroke="black"/>' % (L, T, W - L - R, H - T - B))
xe, _ = px(math.log10(math.e), YMIN)
out.append('<line x1="%.1f" y1="%d" x2="%.1f" y2="%d" stroke="#999" stroke-dasharray="4 3"/>' % (xe, T, xe, H - B))
out.append('<text x="%.1f" y="%d" fill="#666">r = e</text>' % (xe + 4, T + 14))
xj, _ = px(math.log10(math.exp(1 - FLOOR)), YMIN)
out.append('<line x1="%.1f" y1="%d" x2="%.1f" y2="%d" stroke="#bbb" stroke-dasharray="2 3"/>' % (xj, T, xj, H - B))
out.append('<text x="%.1f" y="%d" fill="#666" text-anchor="end">e^(1-floor)</text>' % (xj - 4, T + 28))
for seg in curve(printed):
    out.append(polyline(seg, 'stroke="#d62728" stroke-width="2" stroke-dasharray="6 3"'))
xz0, yz = px(math.log10(math.e), YMIN)
xz1, _ = px(XMAX, YMIN)
out.append('<line x1="%.1f" y1="%.1f" x2="%.1f" y2="%.1f" stroke="#d62728" stroke-width="4" stroke-dasharray="6 3"/>'
           % (xz0, yz - 2, xz1, yz - 2))
for seg in curve(bounded):
    out.append(polyline(seg, 'stroke="#1f77b4" stroke-width="2"'))
out.append('<text x="%d" y="%d" text-anchor="middle">rate ratio r = dG / (dG_c/dt dt)  (strain model: eps_dot / eps_dot_c)'
           '</text>' % ((W + L) // 2, H - 18))
out.append('<text transform="translate(16,%d) rotate(-90)" text-anchor="middle">dD per step / (dG_c/dt dt / G_c)</text>'
           % ((H + T - B) // 2))
out.append('<text x="%d" y="%d" fill="#d62728">printed Eqs. 4.16-4.17: r / (1 - ln r), 0 above e (drawn on the axis)</text>'
           % (L + 10, T + 50))
out.append('<text x="%d" y="%d" fill="#1f77b4">bounded: r / max(1 - ln r, %.1f)  (mpm/bonding.c)</text>'
           % (L + 10, T + 66, FLOOR))
out.append('</svg>')
print("\n".join(out))
