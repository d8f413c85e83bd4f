#!/bin/sh
# Large inputs within the documented limits load in near-linear time (issue 24, item 9): many [material.NAME]
# sections (their slots were found by a linear search and re-sorted per section: quadratic), and a bodies CSV of
# many spheres (every pair was tested for overlap: quadratic).  No assertion on wall time: each input must be
# checked within a generous `timeout` that the quadratic code could not meet (on 2 cores it took 6 s for 2,000
# sections, so over 10 minutes for these 20,000, and 4 s for 30,000 bodies, so about 7 minutes for these
# 300,000; now a few seconds), and the overlap test must still find one overlap planted among them.
# Prints "PASS name" / "FAIL name: why".  Run from the repo root.
set -u
bin=${SPRAYCOAT_BIN:-build/spraycoat}
limit=${SCALE_TIMEOUT:-90}

tmp=$(mktemp -d) || { echo "FAIL scale_setup: mktemp -d failed"; exit 1; }
trap 'rm -rf "$tmp"' EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

if [ ! -x "$bin" ]; then
    echo "FAIL scale_setup: no executable $bin (SPRAYCOAT_BIN)"
    exit 1
fi

first_error_line() { grep '^spraycoat: ' "$1" | head -n 1 | cut -c1-300; }

# 20,000 [material.NAME] sections, each with a value of its own.
awk 'BEGIN { print "[run]\nseed = 7\n"; for (i = 0; i < 20000; i++) printf "[material.m%05d]\ndensity = %d\n\n", i, 1000 + i }' \
    >"$tmp/materials.ini"
timeout "$limit" "$bin" check "$tmp/materials.ini" >"$tmp/out" 2>"$tmp/err"
status=$?
why=""
[ "$status" -eq 0 ] || why="$why; exit status $status (124: not done within $limit s): $(first_error_line "$tmp/err")"
grep -q '^\[material\.m19999\] density *= 20999 ' "$tmp/out" || why="$why; no '[material.m19999] density = 20999' line"
grep -q '^\[material\.m00000\] density *= 1000 ' "$tmp/out" || why="$why; no '[material.m00000] density = 1000' line"
if [ -z "$why" ]; then echo "PASS scale_20000_material_sections"; else echo "FAIL scale_20000_material_sections:${why#;}"; fi

# 300,000 spheres of 2 um, 3 um apart on a 100 x 100 x 30 lattice above the substrate: no two overlap.
bodies_case() { # bodies_case NAME: the impact case reading NAME.csv
    printf '[run]\nseed = 7\n\n[impact]\ngrid = 2e-6\nspacing = 1e-6\nsubstrate_diameter = 20e-6\n' >"$tmp/$1.ini"
    printf 'substrate_height = 6e-6\nt_end = 2e-9\nbodies = %s.csv\n\n[material.aluminium]\n' "$1" >>"$tmp/$1.ini"
}
# awk: row r (0-based) is sphere r; rows PLANT_A and PLANT_B (if set) are moved to overlap
make_bodies() { # make_bodies NAME [PLANT_A PLANT_B]
    awk -v a="${2:--1}" -v b="${3:--1}" 'BEGIN {
        print "shape,x,y,z,vx,vy,vz,d,h,material"
        for (r = 0; r < 300000; r++) {
            x = (r % 100) * 3e-6; y = (int(r / 100) % 100) * 3e-6; z = 5e-6 + int(r / 10000) * 3e-6
            if (r == b) { x = (a % 100) * 3e-6 + 1e-6; y = (int(a / 100) % 100) * 3e-6; z = 5e-6 + int(a / 10000) * 3e-6 }
            printf "sphere,%.9g,%.9g,%.9g,0,0,-500,2e-6,0,aluminium\n", x, y, z
        }
    }' >"$tmp/$1.csv"
    bodies_case "$1"
}
# `check` seeds every body and sizes the grid (one layer per body): 300,000 bodies in one MPM run would need tens
# of terabytes, and `check` must say so, in time, naming the memory (not an overlap, which there is none of).
make_bodies many
timeout "$limit" "$bin" check "$tmp/many.ini" >"$tmp/out" 2>"$tmp/err"
status=$?
why=""
[ "$status" -eq 2 ] || why="$why; exit status $status, expected 2 (124: not done within $limit s)"
grep -q 'the run would need .* GB' "$tmp/err" || why="$why; the message is not the memory's: $(first_error_line "$tmp/err")"
grep -q 'overlap' "$tmp/err" && why="$why; an overlap reported where there is none"
if [ -z "$why" ]; then echo "PASS scale_300000_bodies"; else echo "FAIL scale_300000_bodies:${why#;}"; fi

# The same with sphere 234,567 (data row 234568) moved 1 um from sphere 123,456 (row 123457): found and named.
make_bodies planted 123456 234567
timeout "$limit" "$bin" check "$tmp/planted.ini" >"$tmp/out" 2>"$tmp/err"
status=$?
why=""
[ "$status" -eq 2 ] || why="$why; exit status $status, expected 2 (124: not done within $limit s)"
grep -q 'data rows 123457 and 234568: the spheres overlap' "$tmp/err" ||
    why="$why; the message does not name data rows 123457 and 234568: $(first_error_line "$tmp/err")"
if [ -z "$why" ]; then echo "PASS scale_overlap_found_among_300000"; else echo "FAIL scale_overlap_found_among_300000:${why#;}"; fi
exit 0
