#!/bin/sh
# The build for this CPU gives the portable build's bits.  Some code runs only with AVX-512: the impact's
# particle-to-grid, re-projection and grid-to-points in runs of points (mpm/grid.c, TRILINEAR_RUNS); the
# spray's integration takes other vector widths.  The suite runs the portable build (-march=x86-64-v2), so on
# a CPU with AVX-512 `make test` also builds `make bench`'s binary (SPRAYCOAT_NATIVE_BIN) and this test runs
# the impact demo for 4 ns and the demo's spray for 0.6 ms (deposits, pair and deposit contacts) with both:
# every dataset and attribute the same bit for bit (tests/pipeline_lib.sh same_h5), 2 threads against 1.
# Without AVX-512 or without that binary it checks nothing and says so.
set -u
BIN=${SPRAYCOAT_BIN:-build/spraycoat}
NATIVE=${SPRAYCOAT_NATIVE_BIN:-build-bench/spraycoat}
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
. tests/pipeline_lib.sh
pass() { echo "PASS $1"; }
fail() { echo "FAIL $1: $2"; }

if ! grep -qw avx512f /proc/cpuinfo 2>/dev/null || [ ! -x "$NATIVE" ]; then
    echo "  no AVX-512 CPU or no $NATIVE: nothing to compare"
    exit 0
fi

# same_outputs NAME STAGE FILE CASE: the portable build on 1 thread against the native one on 2
same_outputs() {
    "$BIN" "$2" "$4" -o "$T/$1_portable" --threads 1 >"$T/$1_portable.log" 2>&1 ||
        { fail "$1" "the portable build failed: $(tail -n 2 "$T/$1_portable.log" | tr '\n' ' ')"; return; }
    "$NATIVE" "$2" "$4" -o "$T/$1_native" --threads 2 >"$T/$1_native.log" 2>&1 ||
        { fail "$1" "the native build failed: $(tail -n 2 "$T/$1_native.log" | tr '\n' ' ')"; return; }
    if same_h5 "$T/$1_portable/$3" "$T/$1_native/$3"; then pass "$1"; else fail "$1" "$why"; fi
}

sed 's/^t_end = .*/t_end = 4e-9/' cases/impact_demo.ini >"$T/impact.ini"
same_outputs native_build_impact impact impact.h5 "$T/impact.ini"
awk '/^\[/ { section = $0 } section == "[spray]" && /^t_end = / { $0 = "t_end = 6e-4" } { print }' \
    cases/demo.ini >"$T/spray.ini"
cp cases/vcrit_al_calibration_grid.csv "$T/" # the demo's v_crit(d) table, a path relative to the case
same_outputs native_build_spray spray spray.h5 "$T/spray.ini"
