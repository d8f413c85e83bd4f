#!/bin/sh
# Run every test program (BUILD/tests/test_*) and shell test (tests/test_*.sh) from the repository root,
# count the PASS/FAIL lines they print, and end with "N passed, N failed".
# A program that exits non-zero without printing a FAIL line counts as one failure.
#
# TEST_JOBS tests run at once (default: the online cores): most tests compute on one thread (their cases say
# threads = 1, or they build, fuzz or wait), so a second lane halves the suite's time on 2 cores.  Each test keeps
# its own temporary directory and writes nothing shared; a test's lines are printed when it ends (its log too when
# it failed), so their order follows the finishing order.  TEST_JOBS=1 runs them one after the other in name order.
set -u
build=${1:-build}
cd "$(dirname "$0")/.."
export SPRAYCOAT_BIN="$build/spraycoat"
export SPRAYCOAT_VERIFICATION="${SPRAYCOAT_VERIFICATION:-../shared/verification}"
jobs=${TEST_JOBS:-$(getconf _NPROCESSORS_ONLN 2>/dev/null || echo 1)}
case $jobs in '' | *[!0-9]* | 0) jobs=1 ;; esac
# Two OpenMP programs that spin while they wait (libgomp's default) on cores they share slow each other several-fold
# (a test of 51 s alone took 386 s beside another): with lanes, the tests' threads sleep while they wait, as
# spraycoat's own on a busy machine (app/main.c).  A policy the caller set is kept.
if [ "$jobs" -gt 1 ] && [ -z "${OMP_WAIT_POLICY:-}" ]; then
    export OMP_WAIT_POLICY=passive
fi

results=$(mktemp -d) || { echo "FAIL run_tests: mktemp -d failed"; exit 1; }
trap 'rm -rf "$results"' EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

# run_one TEST: runs it, writes RESULTS/NAME.count ("passed failed"), prints its line (and its log when it failed)
# under a lock so that two lanes' output does not interleave.
run_one() {
    t=$1
    name=$(basename "$t")
    log="$results/$name.log"
    start=$(date +%s)
    "$t" </dev/null >"$log" 2>&1
    status=$?
    p=$(grep -c '^PASS ' "$log")
    f=$(grep -c '^FAIL ' "$log")
    if [ "$status" -ne 0 ] && [ "$f" -eq 0 ]; then
        f=1
        echo "FAIL $name (exit status $status)" >>"$log"
    fi
    echo "$p $f" >"$results/$name.count"
    {
        flock 9
        echo "== $name: $p passed, $f failed ($(($(date +%s) - start)) s)"
        [ "$f" -eq 0 ] || cat "$log"
    } 9>"$results/.lock"
}

# The tests in the order they start: the longest measured first (tests/run_tests.sh's lanes then end together; a
# name not found here is simply not started early), the rest in name order.
longest="tests/test_fuzz.sh tests/test_calibrate_vcrit.sh $build/tests/test_mpm_bonding tests/test_mpi.sh
$build/tests/test_mpm_contact tests/test_pipeline.sh tests/test_restart.sh tests/test_gpu_emulated.sh
tests/test_cuda_build.sh"
list="$results/.list"
: >"$list"
for t in $longest "$build"/tests/test_* tests/test_*.sh; do
    case "$t" in *.o | *.d) continue ;; esac
    [ -e "$t" ] || continue
    grep -qxF "$t" "$list" || echo "$t" >>"$list"
done

failed=0
started=0
while read -r t; do
    if [ ! -x "$t" ]; then
        # a shell test without its exec bit would otherwise be skipped without a word (three were)
        case "$t" in *.sh)
            echo "FAIL $(basename "$t") (not executable: chmod +x it and git update-index --chmod=+x it)"
            failed=$((failed + 1)) ;;
        esac
        continue
    fi
    if [ "$jobs" -le 1 ]; then
        run_one "$t"
        continue
    fi
    # a lane is free when fewer than TEST_JOBS of the tests started have written their count
    while [ $((started - $(find "$results" -name '*.count' | wc -l))) -ge "$jobs" ]; do
        sleep 0.2
    done
    started=$((started + 1))
    run_one "$t" &
done <"$list"
wait

passed=0
for c in "$results"/*.count; do
    [ -e "$c" ] || continue
    read -r p f <"$c"
    passed=$((passed + p))
    failed=$((failed + f))
done
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
