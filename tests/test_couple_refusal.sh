#!/bin/sh
# A case the couple stage refuses leaves a finished run directory as it was: case.ini and stages byte for byte, no
# couple.h5, and `spraycoat resume` of the earlier case still works.  A review: `spraycoat couple` with [couple]
# runs = 100000 over a spray of 2000 particles exited 2, but only after case.ini and stages had been replaced with the
# refused case's, so that `resume` of the directory failed on it for ever.
#  - more seeds (runs * bodies_per_run) than the spray injects at most ([spray] max_injected): refused from the case,
#    by `spraycoat check` too;
#  - more seeds than spray.h5 has particles that reached the target (fewer than max_injected here: the spray ends
#    while particles are still in flight): known from spray.h5 only, so check passes the case, and `spraycoat
#    couple`, `spraycoat run` (whose spray stage finds spray.h5 up to date) and `run --stages couple` refuse it
#    before the run directory is written.
# Prints "PASS name" / "FAIL name: why".  Run from the repository root.
set -u
bin=${SPRAYCOAT_BIN:-build/spraycoat}
T=$(mktemp -d) || { echo "FAIL couple_refusal_setup: mktemp -d failed"; exit 1; }
trap 'rm -rf "$T"' EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

# tests/fixtures/pipeline_small.ini sprayed for 0.2 ms: 400 particles injected (max_injected = 1500), about 300 at the
# target
sed 's/^t_end = 8e-4$/t_end = 2e-4/' tests/fixtures/pipeline_small.ini >"$T/short.ini"
with_runs() { sed "s/^runs = 4\$/runs = $1/" "$T/short.ini" >"$2"; }
with_runs 1000 "$T/reached.ini"
with_runs 100000 "$T/injected.ini"
line=$(grep -n '^runs = ' "$T/reached.ini" | cut -d: -f1)

if ! "$bin" spray "$T/short.ini" -o "$T/finished" --threads 1 >"$T/spray.out" 2>&1; then
    echo "FAIL couple_refusal_setup: the spray exited $?: $(tail -n 1 "$T/spray.out")"
    exit 0
fi

# refused NAME TEXT... -- COMMAND...: COMMAND (its -o the copy $T/NAME of the finished spray) exits 2, stderr holds
# every TEXT, and the copy's case.ini and stages are those of the finished spray, with nothing new beside them
refused() {
    name=$1
    shift
    why=""
    cp -a "$T/finished" "$T/$name"
    texts=""
    while [ "$1" != "--" ]; do
        texts="$texts$1
"
        shift
    done
    shift
    "$@" -o "$T/$name" >"$T/$name.out" 2>"$T/$name.err"
    status=$?
    [ "$status" -eq 2 ] || why="exit status $status, not 2 ($(tail -n 1 "$T/$name.err"));"
    printf '%s' "$texts" >"$T/$name.texts"
    while IFS= read -r text; do
        grep -qF -- "$text" "$T/$name.err" || why="$why stderr lacks \"$text\";"
    done <"$T/$name.texts"
    cmp -s "$T/finished/case.ini" "$T/$name/case.ini" || why="$why case.ini was replaced;"
    cmp -s "$T/finished/stages" "$T/$name/stages" || why="$why stages was replaced ($(cat "$T/$name/stages"));"
    new=$(cd "$T/$name" && ls -A | grep -v -x -e case.ini -e stages -e spray.h5 -e spray.xdmf | tr '\n' ' ')
    [ -z "$new" ] || why="$why left in the run directory: $new;"
    if "$bin" resume "$T/$name" >"$T/$name.resume" 2>&1; then
        grep -q "spray.h5 is up to date" "$T/$name.resume" || why="$why resume did not find the spray up to date;"
    else
        why="$why resume of the earlier case exited $?: $(tail -n 1 "$T/$name.resume");"
    fi
    if [ -z "$why" ]; then echo "PASS $name"; else echo "FAIL $name: $why"; fi
}

# more seeds than the spray injects: refused from the case alone, at check time
"$bin" check "$T/injected.ini" >"$T/check_injected.out" 2>"$T/check_injected.err"
status=$?
why=""
[ "$status" -eq 2 ] || why="exit status $status, not 2;"
for text in "injected.ini:$line: [couple] runs" "at most 1500 particles ([spray] max_injected)" \
    "allowed: runs * bodies_per_run <= 1500"; do
    grep -qF -- "$text" "$T/check_injected.err" || why="$why stderr lacks \"$text\";"
done
if [ -z "$why" ]; then echo "PASS couple_check_refuses_seeds_above_max_injected"; else
    echo "FAIL couple_check_refuses_seeds_above_max_injected: $why $(head -c 300 "$T/check_injected.err")"
fi
refused couple_above_max_injected_keeps_run_dir "injected.ini:$line: [couple] runs" "[spray] max_injected" -- \
    "$bin" couple "$T/injected.ini"

# more seeds than reached the target: only spray.h5 tells, so check passes the case
if "$bin" check "$T/reached.ini" >/dev/null 2>"$T/check_reached.err"; then
    echo "PASS couple_check_passes_seeds_within_max_injected"
else
    echo "FAIL couple_check_passes_seeds_within_max_injected: exit $?: $(head -c 300 "$T/check_reached.err")"
fi
reached="particles that reached the target; allowed: runs * bodies_per_run <="
refused couple_above_reached_keeps_run_dir "reached.ini:$line: [couple] runs" "$reached" -- \
    "$bin" couple "$T/reached.ini"
refused run_above_reached_keeps_run_dir "reached.ini:$line: [couple] runs" "$reached" -- "$bin" run "$T/reached.ini"
refused run_stages_couple_above_reached_keeps_run_dir "reached.ini:$line: [couple] runs" "$reached" -- \
    "$bin" run "$T/reached.ini" --stages couple

# the runs the spray does hold are seeded (the refusal above is of the number, not of the spray)
n=$(sed -n 's/.*spray.h5 has \([0-9]*\) particles that reached the target.*/\1/p' "$T/couple_above_reached_keeps_run_dir.err")
with_runs "${n:-0}" "$T/all.ini"
why=""
if [ -z "$n" ]; then
    why="no count of the particles at the target in the refusal"
elif ! "$bin" couple "$T/all.ini" -o "$T/finished" >"$T/all.out" 2>&1; then
    why="runs = $n exited $?: $(tail -n 1 "$T/all.out")"
fi
if [ -z "$why" ]; then echo "PASS couple_seeds_every_particle_at_target"; else
    echo "FAIL couple_seeds_every_particle_at_target: $why"
fi
exit 0
