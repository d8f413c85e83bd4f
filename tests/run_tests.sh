#!/bin/sh
# Run every test program (BUILD/tests/test_*) and shell test (tests/test_*.sh) from the repository root,
# count the PASS/FAIL lines they print, and end with "N passed, N failed".
# A program that exits non-zero without printing a FAIL line counts as one failure.
set -u
build=${1:-build}
cd "$(dirname "$0")/.."
export SPRAYCOAT_BIN="$build/spraycoat"
export SPRAYCOAT_VERIFICATION="${SPRAYCOAT_VERIFICATION:-../shared/verification}"
passed=0
failed=0
log=$(mktemp)
for t in "$build"/tests/test_* tests/test_*.sh; do
    if [ ! -x "$t" ]; then
        # a shell test without its exec bit would otherwise be skipped without a word (three were)
        case "$t" in *.sh)
            echo "FAIL $(basename "$t") (not executable: chmod +x it and git update-index --chmod=+x it)"
            failed=$((failed + 1)) ;;
        esac
        continue
    fi
    case "$t" in *.o|*.d) continue ;; esac
    name=$(basename "$t")
    start=$(date +%s)
    "$t" >"$log" 2>&1
    status=$?
    p=$(grep -c '^PASS ' "$log")
    f=$(grep -c '^FAIL ' "$log")
    if [ "$status" -ne 0 ] && [ "$f" -eq 0 ]; then
        f=1
        echo "FAIL $name (exit status $status)" >>"$log"
    fi
    passed=$((passed + p))
    failed=$((failed + f))
    echo "== $name: $p passed, $f failed ($(( $(date +%s) - start )) s)"
    if [ "$f" -ne 0 ]; then
        cat "$log"
    fi
done
rm -f "$log"
echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
