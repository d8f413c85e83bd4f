#!/bin/sh
# `make bench`, render part: about 1e6 material points to a 1920 x 1080 PNG (OSMesa llvmpipe + Cairo), per view,
# from points in memory (tests/bench/render_bench.c), then `spraycoat render` end to end on the same points as an
# impact.h5 (read, three views, plots, report).  Usage: scripts/bench_render.sh BUILD_DIR
set -eu
build=${1:-build}
bin="$build/spraycoat"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# shellcheck disable=SC2046 # pkg-config prints several words
cc -std=c17 -O2 -I. $(pkg-config --cflags hdf5-serial osmesa cairo) -D_DEFAULT_SOURCE -D_POSIX_C_SOURCE=200809L \
    tests/bench/render_bench.c "$build/libspraycoat.a" $(pkg-config --libs hdf5-serial inih osmesa cairo) \
    -lsundials_cvode -lsundials_nvecserial -lsundials_sunlinsoldense -lsundials_sunmatrixdense -ludunits2 -ldl -lm \
    -fopenmp \
    -o "$work/render_bench"

echo "render: 1920 x 1080 px, LP_NUM_THREADS=${LP_NUM_THREADS:-default} (llvmpipe threads)"
echo "| view                     |    points | draw s    | + PNG s  |"
echo "| ------------------------ | --------- | --------- | -------- |"
mkdir "$work/run"
cat >"$work/case.ini" <<INI
[render]
width = 1920
height = 1080
every = 0
point_radius = 0.125e-6
INI
"$work/render_bench" "$work/run" "$work/case.ini"
start=$(date +%s.%N)
"$bin" render "$work/case.ini" -o "$work/run" -q
end=$(date +%s.%N)
awk -v s="$start" -v e="$end" 'BEGIN { printf "| %-24s | %9s | %9s | %8.3f |\n", "spraycoat render (3 views)", "1e6", "-", e - s }'
