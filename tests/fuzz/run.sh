#!/bin/sh
# Run the libFuzzer harnesses (built by `make fuzz-build` into FUZZ_BUILD) for FUZZ_SECONDS each, starting from
# the kept corpus tests/fuzz/corpus/TARGET/.  New inputs go to a temporary folder (the kept corpus is only read);
# a crash leaves its input as FUZZ_ARTIFACTS/TARGET-crash-... (default: a temporary folder, printed) and fails.
# Usage: tests/fuzz/run.sh [TARGET...]   (default: all three).  Run from the repository root.
set -u
build=${FUZZ_BUILD:-build-fuzz}
seconds=${FUZZ_SECONDS:-600}
targets=${*:-fuzz_case fuzz_particles_csv fuzz_bodies_csv}
artifacts=${FUZZ_ARTIFACTS:-$(mktemp -d)}
mkdir -p "$artifacts"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
failed=0
for t in $targets; do
    corpus=tests/fuzz/corpus/${t#fuzz_}
    mkdir -p "$work/$t"
    echo "fuzz: $t for $seconds s from $corpus"
    # -rss_limit_mb: the readers hold a file in memory; -max_len: long lines (the CSV readers had a 4 KiB buffer)
    # lsan.supp: leaks inside UDUNITS-2 (its file says which and why)
    if ASAN_OPTIONS=detect_leaks=1 LSAN_OPTIONS="suppressions=$(pwd)/tests/fuzz/lsan.supp:print_suppressions=0" UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
        "$build/$t" -max_total_time="$seconds" -max_len=16384 -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
        -artifact_prefix="$artifacts/$t-" "$work/$t" "$corpus" >"$work/$t.log" 2>&1; then
        echo "fuzz: $t: no crash ($(grep -o 'stat::number_of_executed_units: *[0-9]*' "$work/$t.log" | grep -o '[0-9]*$') runs)"
    else
        echo "fuzz: $t: FAILED; the input is in $artifacts; the end of its log:"
        tail -n 40 "$work/$t.log"
        failed=1
    fi
done
exit $failed
