#!/usr/bin/env python3
"""Write cases/tang2021_ten_particles.csv: ten 14 um Al spheres at 810 m/s towards the substrate, at random
positions above it, none overlapping (random sequential addition with a fixed seed, so the file is the same
every time).  The lowest one touches the substrate (centre 7 um above z = 0); the others have their centres
9 to 60 um above it and within 18 um of the axis (the substrate of cases/tang2021_ten_particles.ini is 60 um
across).  Pairs keep at least 0.5 um between their surfaces.  Run from the repository root:
    python3 scripts/tang2021_ten_particles.py
"""
import math
import random

D = 14e-6
R = D / 2
GAP = 0.5e-6
rng = random.Random(20210810)
centres = []
while len(centres) < 10:
    first = not centres
    r = 18e-6 * math.sqrt(rng.random())
    phi = 2 * math.pi * rng.random()
    x, y = r * math.cos(phi), r * math.sin(phi)
    z = R if first else rng.uniform(9e-6, 60e-6)
    if all(math.dist((x, y, z), c) >= D + GAP for c in centres):
        centres.append((x, y, z))
for i, a in enumerate(centres):  # the check the file promises
    assert a[2] - R >= -1e-15
    for b in centres[i + 1:]:
        assert math.dist(a, b) >= D + GAP
with open("cases/tang2021_ten_particles.csv", "w") as out:
    out.write("shape,x,y,z,vx,vy,vz,d,h,material\n")
    for x, y, z in sorted(centres, key=lambda c: c[2]):
        out.write("sphere,%.4e,%.4e,%.4e,0,0,-810,14e-6,0,aluminium\n" % (x, y, z))
