#!/bin/sh
# `make validate`: long validations that do not fit in `make test`.
#   1. The paper's full Table 1 case (cases/mz2015_table1.ini): 50,050 particles, 125,000 steps.
#      Prints its accounting, contact counts and deposit metrics (Section 5.2) for comparison with the
#      paper's Figs. 6-9; checks the particle accounting and that the final files are complete.
#   2. The bonding calibration (docs/physics.md "Bonding calibration"): the four single-particle impacts of the
#      experimental bracket (Tang Section 4.1.2) with the shipped Al defaults of G_c and its rate, on the
#      calibration grid; each verdict must be the calibrated one: 14 um rebounds at 750 m/s and bonds at 810,
#      30 um rebounds at 710 and bonds at 770.
#   3. Fuzzing (`make fuzz`): the libFuzzer harnesses of the case reader and the two CSV readers (tests/fuzz/)
#      for FUZZ_SECONDS (600) each; any crash fails.  Needs clang (scripts/bootstrap installs it).
# VALIDATE_ONLY=table1|bonding|fuzz runs one of them.
set -eu
build=${1:-build}
bin="$build/spraycoat"
only=${VALIDATE_ONLY:-all}
failed=0

validate_table1() {
    run=${VALIDATE_DIR:-runs/validate_table1}
    echo "validate: the Table 1 case into $run (about a minute on 2 idle cores)"
    "$bin" spray cases/mz2015_table1.ini -o "$run"
    "$bin" info "$run"
    injected=$(h5dump -a /stats/injected "$run/spray.h5" | sed -n 's/^ *(0): *//p')
    if [ "$injected" -ne 50050 ]; then
        echo "validate: FAIL: injected $injected particles, the schedule asks for 50050"
        failed=1
        return
    fi
    echo "validate: Table 1 case done: 50050 injected"
}

# The default of an [impact] key, from the key registry (`spraycoat keys` prints docs/keys.md).
impact_default() {
    "$bin" keys | awk -F'|' -v key="\`$1\`" '$2 ~ key { gsub(/ /, "", $5); print $5; exit }'
}

validate_bonding() {
    gc=$(impact_default Gc)
    rate=$(impact_default Gc_rate)
    echo "validate: bonding calibration with the shipped defaults Gc = $gc J/m2, Gc_rate = $rate J/m2/s (4 impacts, minutes)"
    table=$(mktemp)
    "$(dirname "$0")/calibrate_bonding.sh" "$build" "$gc" "$rate" | tee "$table"
    # expected verdicts: diameter,velocity,bonded
    for expect in "14e-6,750,0" "14e-6,810,1" "30e-6,710,0" "30e-6,770,1"; do
        d=${expect%%,*}
        rest=${expect#*,}
        v=${rest%%,*}
        want=${rest#*,}
        got=$(awk -F, -v d="$d" -v v="$v" '$3 == d && $4 == v { print $5 }' "$table")
        if [ "$got" != "$want" ]; then
            echo "validate: FAIL: bonding at d = $d m, v = $v m/s: bonded = '$got', the calibration needs $want"
            failed=1
        fi
    done
    rm -f "$table"
    [ "$failed" -ne 0 ] || echo "validate: bonding calibration: all four verdicts as calibrated"
}

validate_fuzz() {
    seconds=${FUZZ_SECONDS:-600}
    echo "validate: fuzzing the case reader and the two CSV readers, $seconds s each (make fuzz)"
    if ! command -v clang >/dev/null 2>&1; then
        echo "validate: FAIL: fuzzing needs clang (Debian package clang; scripts/bootstrap installs it)"
        failed=1
        return
    fi
    if ! make -s fuzz-build || ! FUZZ_SECONDS="$seconds" tests/fuzz/run.sh; then
        echo "validate: FAIL: a fuzz harness crashed (see above for its input)"
        failed=1
        return
    fi
    echo "validate: fuzzing: no crash"
}

case $only in
    all) validate_table1; validate_bonding; validate_fuzz ;;
    table1) validate_table1 ;;
    bonding) validate_bonding ;;
    fuzz) validate_fuzz ;;
    *) echo "validate: VALIDATE_ONLY must be table1, bonding or fuzz, not '$only'" >&2; exit 2 ;;
esac
if [ "$failed" -ne 0 ]; then
    echo "validate: FAILED"
    exit 1
fi
echo "validate: all passed"
