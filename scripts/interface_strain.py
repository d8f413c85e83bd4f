#!/usr/bin/env python3
"""The interface's plastic strain and temperature of impact runs, for the resolution study of `make validate`
(part interface_strain; docs/physics.md "Why the calibration moves with the grid").

Usage: scripts/interface_strain.py SNAPSHOT LABEL=RUN_DIR ...

For each run, from snapshot SNAPSHOT of RUN_DIR/impact.h5 (docs/files.md "impact.h5"): the particle is body 1;
its interface is its surface points (`surface` = 1) below its centre of mass.  Prints one CSV row per run:
label, time (ns), interface points, the 50th/90th/95th/99th percentiles of their effective plastic strain
`eps_p`, the hottest particle point and the hottest substrate point (K).  Needs python3-h5py and numpy
(scripts/bootstrap --analysis).
"""
import sys

import h5py
import numpy as np


def interface_row(label, run, snapshot):
    with h5py.File(run + "/impact.h5", "r") as f:
        g = f["snapshots/%06d" % snapshot]
        x, eps_p, T = g["x"][()], g["eps_p"][()], g["T"][()]
        body, surface = g["body"][()], g["surface"][()].astype(bool)
        t = g.attrs["t"]
    particle = body == 1
    below = x[:, 2] < x[particle, 2].mean()
    interface = eps_p[particle & surface & below]
    q = np.quantile(interface, [0.5, 0.9, 0.95, 0.99])
    return "%s,%.3f,%d,%s,%.0f,%.0f" % (label, t * 1e9, interface.size, ",".join("%.4f" % v for v in q),
                                       T[particle].max(), T[body == 0].max())


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    snapshot = int(sys.argv[1])
    print("run,t_ns,interface_points,eps_p_50,eps_p_90,eps_p_95,eps_p_99,T_max_particle,T_max_substrate")
    for item in sys.argv[2:]:
        label, run = item.split("=", 1)
        print(interface_row(label, run, snapshot))


if __name__ == "__main__":
    main()
