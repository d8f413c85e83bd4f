#!/bin/sh
# Bonding-parameter sweep (issue: impact stage, "Bonding parameters"): for each (Gc, Gc_rate) pair, single Al
# particle impacts at the experimental bracket of Tang Section 4.1.2 -- 14 um at 750 and 810 m/s, 30 um at 710
# and 770 m/s -- on the calibration grid (2.0 um / 0.667 um, up to 100 ns: each run ends once its verdict settled),
# with the verdict of the impact stage and every other [impact] key at its default.
# A pair is calibrated when the 14 um particle bonds at 810 and not at 750, and the 30 um one at 770 and not
# at 710.  One CSV row per run on stdout.
#   usage: scripts/calibrate_bonding.sh BUILD "Gc1 Gc2 ..." "rate1 rate2 ..."
set -eu
build=$1
bin="$build/spraycoat"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# the last body's value (the particle) of a /summary dataset
value() { h5dump -y -w 0 -d "$2" "$1" | grep -m1 -A1 'DATA {' | tail -1 | tr ',' ' ' | awk '{ print $NF }'; }
echo "Gc,Gc_rate,diameter,velocity,bonded,pbcp,v_rest"
for gc in $2; do
    for rate in $3; do
        for run in "14e-6 750 30e-6" "14e-6 810 30e-6" "30e-6 710 50e-6" "30e-6 770 50e-6"; do
            set -- $run
            cat > "$work/case.ini" <<INI
[impact]
grid = 2e-6
spacing = 0.667e-6
diameter = $1
velocity = $2
substrate_diameter = $3
t_end = 100e-9
snapshot_every = 1
bonding = energy
Gc = $gc
Gc_rate = $rate
[material.aluminium]
INI
            rm -rf "$work/run"
            "$bin" impact "$work/case.ini" -o "$work/run" -q
            echo "$gc,$rate,$1,$2,$(value "$work/run/impact.h5" /summary/bonded),$(value "$work/run/impact.h5" /summary/pbcp),$(value "$work/run/impact.h5" /summary/v_rest)"
        done
    done
done
