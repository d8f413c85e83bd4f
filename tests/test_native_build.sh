#!/bin/sh
# One build, every instruction-set level, the same bits.  The kernels of the impact and the spray run with the
# best x86-64 level the CPU has (core/isa.h, app/isa_dispatch.c); SPRAYCOAT_ISA=v2|v3|v4 forces a level.  On
# whatever CPU runs the suite: every level it runs gives the level-2 results bit for bit, some code taking other
# paths at the higher levels (AVX2 and AVX-512 vector widths in the stress update and the spray's integration;
# with AVX-512, the impact's transfers in runs of points, mpm/grid.c TRILINEAR_RUNS).  The impact demo for 4 ns
# and the demo's spray for 0.6 ms (deposits, pair and deposit contacts): every dataset and attribute the same
# (tests/pipeline_lib.sh same_h5), level 2 on 1 thread against each higher level on 2.  Also: --version names the
# level in use, unset means the best, and a level the CPU lacks or a word that is no level is refused (exit 2).
# A build with one instruction set (not x86-64 / gcc >= 12, or `make ISA_LEVELS=`) has nothing to compare.
set -u
BIN=${SPRAYCOAT_BIN:-build/spraycoat}
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
. tests/pipeline_lib.sh
pass() { echo "PASS $1"; }
fail() { echo "FAIL $1: $2"; }

# isa_line [LEVEL]: the isa line of --version with SPRAYCOAT_ISA=LEVEL ("" unsets it); its exit status
isa_line() { SPRAYCOAT_ISA=${1:-} "$BIN" --version 2>"$T/isa.err" | sed -n 's/^ *isa *//p'; }

default=$(isa_line)
case "$default" in
"one build"*)
    echo "  $BIN has one instruction set ($default): nothing to compare"
    exit 0 ;;
x86-64-v[234]*) ;;
*)
    fail isa_version "--version names no instruction-set level: \"$default\""
    exit 1 ;;
esac

# the levels this CPU runs: those --version accepts; the others must be refused with exit status 2
levels=""
why=""
for level in v2 v3 v4; do
    if line=$(SPRAYCOAT_ISA=$level "$BIN" --version 2>"$T/isa.err"); then
        levels="$levels $level"
        echo "$line" | grep -q "^ *isa *x86-64-$level (SPRAYCOAT_ISA=$level;" ||
            why="$why SPRAYCOAT_ISA=$level: --version does not say x86-64-$level;"
    else
        status=$?
        [ "$status" -eq 2 ] && grep -q 'SPRAYCOAT_ISA="'$level'": this CPU cannot run that level' "$T/isa.err" ||
            why="$why SPRAYCOAT_ISA=$level refused with status $status and \"$(head -n 1 "$T/isa.err")\";"
    fi
done
best=${levels##* }
case "$default" in
"x86-64-$best (the best"*) ;;
*) why="$why unset, the level is \"$default\", not the best this CPU runs (x86-64-$best);" ;;
esac
SPRAYCOAT_ISA=v9 "$BIN" --version >/dev/null 2>"$T/isa.err"
status=$?
[ "$status" -eq 2 ] && grep -q 'not an instruction-set level' "$T/isa.err" ||
    why="$why SPRAYCOAT_ISA=v9 gave status $status and \"$(head -n 1 "$T/isa.err")\";"
echo "  this CPU runs the levels:$levels"
if [ -z "$why" ]; then pass isa_levels; else fail isa_levels "$why"; fi

# same_outputs NAME STAGE FILE CASE: level 2 on 1 thread against every higher level the CPU runs on 2 threads
same_outputs() {
    SPRAYCOAT_ISA=v2 "$BIN" "$2" "$4" -o "$T/$1_v2" --threads 1 >"$T/$1_v2.log" 2>&1 ||
        { fail "$1" "level 2 failed: $(tail -n 2 "$T/$1_v2.log" | tr '\n' ' ')"; return; }
    for level in $levels; do
        [ "$level" = v2 ] && continue
        SPRAYCOAT_ISA=$level "$BIN" "$2" "$4" -o "$T/$1_$level" --threads 2 >"$T/$1_$level.log" 2>&1 ||
            { fail "$1_$level" "level $level failed: $(tail -n 2 "$T/$1_$level.log" | tr '\n' ' ')"; continue; }
        if same_h5 "$T/$1_v2/$3" "$T/$1_$level/$3"; then pass "$1_$level"; else fail "$1_$level" "$why"; fi
    done
}

if [ "$levels" = " v2" ]; then
    echo "  this CPU runs level 2 only: no other level to compare"
    exit 0
fi
sed 's/^t_end = .*/t_end = 4e-9/' cases/impact_demo.ini >"$T/impact.ini"
same_outputs isa_levels_impact impact impact.h5 "$T/impact.ini"
awk '/^\[/ { section = $0 } section == "[spray]" && /^t_end = / { $0 = "t_end = 6e-4" } { print }' \
    cases/demo.ini >"$T/spray.ini"
cp cases/vcrit_al.csv "$T/" # the demo's v_crit(d) table, a path relative to the case
same_outputs isa_levels_spray spray spray.h5 "$T/spray.ini"
