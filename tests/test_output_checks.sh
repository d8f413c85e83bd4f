#!/bin/sh
# The stages check what they read (issue 24): every dataset of every output carries a Fletcher32 checksum, so
# one flipped bit in spray.h5 or couple.h5 stops the stage that reads it with exit status 3 and a message naming
# the file and the checksum (it flowed into couple.h5 with exit 0 before); and an input made by another case
# (another seed) is refused by couple and by render with exit status 3, naming the file and the stage to rerun
# (render drew it without a word before); but another case's outputs of stages the case does not have (a spray-only
# case run into a pipeline's directory) are left out of the figures and the report, not refused.
#
# A diameter couple.h5 should not hold (NaN, or too small for the grid) is blamed on couple.h5 and its row, not on
# the [impact] diameter of the case (issue 24, item 12).
#
# Run from the repository root with $SPRAYCOAT_BIN (tests/run_tests.sh sets it).  Needs h5dump, h5repack, python3.
# About 6 s.
set -u

BIN=${SPRAYCOAT_BIN:-build/spraycoat}
case $BIN in
/*) ;;
*/*) BIN=$(pwd)/$BIN ;;
esac
CASE=tests/fixtures/pipeline_small.ini

failures=0
pass() { echo "PASS $1"; }
fail() {
    echo "FAIL $1 ($2)"
    failures=$((failures + 1))
}

for tool in h5dump h5repack python3; do
    if ! command -v "$tool" >/dev/null 2>&1; then
        echo "FAIL output_checks ($tool not found)"
        exit 1
    fi
done
if [ ! -x "$BIN" ] || [ ! -r "$CASE" ]; then
    echo "FAIL output_checks (no $BIN or $CASE; run from the repository root after make)"
    exit 1
fi

T=$(mktemp -d) || exit 1
trap 'rm -rf "$T"' EXIT
trap 'exit 1' HUP INT TERM

sed -e 's/^seed *=.*/seed = 12345/' "$CASE" >"$T/other.ini"
if ! grep -q '^seed = 12345$' "$T/other.ini"; then
    echo "FAIL output_checks ($CASE no longer has the line seed this test rewrites)"
    exit 1
fi
if ! "$BIN" run "$CASE" --stages spray,couple -o "$T/ref" >"$T/ref.log" 2>&1; then
    echo "FAIL output_checks (the spray and couple stages failed: $(tail -n 3 "$T/ref.log" | tr '\n' ' '))"
    exit 1
fi

# flip_bit FILE DATASET: invert one bit in the middle of DATASET's stored values (found in FILE by their bytes)
flip_bit() {
    h5dump -d "$2" -b LE -o "$T/raw.bin" "$1" >/dev/null 2>&1 || return 1
    python3 - "$1" "$T/raw.bin" <<'EOF'
import sys
data = bytearray(open(sys.argv[1], "rb").read())
raw = open(sys.argv[2], "rb").read()
middle = len(raw) // 2 // 8 * 8
pattern = raw[middle:middle + 16]
at = data.find(pattern)
if len(pattern) < 16 or at < 0:
    sys.exit("the values are not stored as they are in the file")
while at >= 0:  # another dataset may hold the same values (/seeds/v and /flight/v_end): damage every copy
    data[at + 3] ^= 0x10
    at = data.find(pattern, at + 16)
open(sys.argv[1], "wb").write(data)
EOF
}

# expect NAME STATUS PATTERN...: the last command's status was 3 and its stderr ($T/err) matches every pattern
expect() {
    name=$1
    status=$2
    shift 2
    message=$(grep 'spraycoat:' "$T/err" | head -n 1)
    if [ "$status" -ne 3 ]; then
        fail "$name" "exit status $status, expected 3: $(tail -n 2 "$T/err" | tr '\n' ' ')"
        return
    fi
    for pattern in "$@"; do
        if ! printf '%s\n' "$message" | grep -q -- "$pattern"; then
            fail "$name" "the message does not say '$pattern': $message"
            return
        fi
    done
    pass "$name"
}

# ---- a flipped bit in spray.h5: couple refuses it ---------------------------------------------------------------
cp -R "$T/ref" "$T/flip_spray"
rm -f "$T/flip_spray/couple.h5"
if flip_bit "$T/flip_spray/spray.h5" /impacts/v_in; then
    "$BIN" couple "$CASE" -o "$T/flip_spray" >/dev/null 2>"$T/err"
    expect couple_spray_checksum $? 'spray.h5' 'checksum'
    [ -e "$T/flip_spray/couple.h5" ] && fail couple_spray_checksum_no_output "couple.h5 was written"
else
    fail couple_spray_checksum "cannot damage /impacts/v_in of spray.h5"
fi

# ---- a flipped bit in couple.h5: impact refuses it --------------------------------------------------------------
cp -R "$T/ref" "$T/flip_couple"
if flip_bit "$T/flip_couple/couple.h5" /seeds/v; then
    "$BIN" impact "$CASE" -o "$T/flip_couple" >/dev/null 2>"$T/err"
    expect impact_couple_checksum $? 'couple.h5' 'checksum'
else
    fail impact_couple_checksum "cannot damage /seeds/v of couple.h5"
fi

# ---- another case's spray.h5: couple and render refuse it --------------------------------------------------------
cp -R "$T/ref" "$T/other"
rm -f "$T/other/couple.h5"
"$BIN" couple "$T/other.ini" -o "$T/other" >/dev/null 2>"$T/err"
expect couple_other_case $? 'spray.h5' 'made by another case' 'rerun the spray stage'
"$BIN" render "$T/other.ini" -o "$T/other" >/dev/null 2>"$T/err"
expect render_other_case $? 'spray.h5' 'made by another case' 'rerun the spray stage'
[ -e "$T/other/report.html" ] && fail render_other_case_no_report "report.html was written"

# ---- a spray-only case run into the directory of a pipeline (a review: `spraycoat run` of it exited 3, render
# refusing the pipeline's impact.h5 as another case's with the advice "rerun the impact stage", which a case without
# [impact] cannot follow; `run` again refused the same).  The outputs of stages the case does not have, made by
# another case, are left out: exit 0, a log line naming each, and a report that neither draws nor lists them ----
test=render_ignores_other_case_stages
sed '/^\[couple\]$/,$d' "$CASE" >"$T/spray_only.ini"
if grep -q '^\[spray\]$' "$T/spray_only.ini" && ! grep -q '^\[impact\]\|^\[couple\]\|^\[material' "$T/spray_only.ini"; then
    cp -R "$T/ref" "$T/mixed"
    # the pipeline's own report too: the spray-only case's spray.h5 is the same (its keys are), so a fingerprint
    # blind to what is left out found that report, which shows the impact runs, up to date
    if ! "$BIN" run "$CASE" --stages impact,render -o "$T/mixed" >"$T/mixed_impact.log" 2>&1; then
        fail "$test" "the pipeline's impact stage failed: $(tail -n 1 "$T/mixed_impact.log")"
    else
        "$BIN" run "$T/spray_only.ini" -o "$T/mixed" >"$T/mixed.log" 2>&1
        status=$?
        report=$T/mixed/report.html
        why=""
        [ "$status" -eq 0 ] || why="$why exit status $status: $(tail -n 1 "$T/mixed.log");"
        for f in couple.h5 impact.h5; do
            grep -q "render: .*/$f is not this case's.*left out" "$T/mixed.log" || why="$why no log line leaving out $f;"
            grep -q "<td>$f</td>" "$report" 2>/dev/null && why="$why the report's provenance lists $f;"
        done
        grep -q 'Impact results\|impact_run_0000_pbcp.png' "$report" 2>/dev/null && why="$why the report shows the other case's impact runs;"
        grep -q "impact.h5 in the run directory is another case's result" "$report" 2>/dev/null || why="$why the report does not say impact.h5 is left out;"
        grep -q 'spray_diameter.png' "$report" 2>/dev/null || why="$why no spray figure in the report;"
        if [ -z "$why" ]; then pass "$test"; else fail "$test" "$why"; fi
    fi
else
    fail "$test" "$CASE no longer ends with [couple], [impact] and the material, which this test cuts off"
fi

# ---- a seed diameter couple.h5 should not hold: the message names couple.h5 and the row, not [impact] diameter ----
# set_seed_d DIR ROW VALUE: /seeds/d[ROW] (and the same values in /flight/d) of DIR/couple.h5 becomes VALUE, the
# file rewritten without filters so that no checksum catches it (a couple stage that wrote a bad value)
set_seed_d() {
    h5repack -f NONE "$1/couple.h5" "$1/plain.h5" >/dev/null 2>&1 &&
        h5dump -d /seeds/d -b LE -o "$T/d.bin" "$1/plain.h5" >/dev/null 2>&1 &&
        python3 - "$1/plain.h5" "$T/d.bin" "$2" "$3" <<'EOF' && mv "$1/plain.h5" "$1/couple.h5"
import struct, sys
data = bytearray(open(sys.argv[1], "rb").read())
raw = open(sys.argv[2], "rb").read()
row, value = int(sys.argv[3]), float(sys.argv[4])
at = data.find(raw)
if at < 0:
    sys.exit("/seeds/d is not stored as it is in the file")
while at >= 0:
    data[at + 8 * row:at + 8 * row + 8] = struct.pack("<d", value)
    at = data.find(raw, at + 1)
open(sys.argv[1], "wb").write(data)
EOF
}
for bad in nan tiny; do
    cp -R "$T/ref" "$T/seed_$bad"
    value=nan
    [ "$bad" = tiny ] && value=1e-7 # finite, but no material point fits in it at [impact] spacing = 1e-6
    if ! set_seed_d "$T/seed_$bad" 1 "$value"; then
        fail "impact_seed_$bad" "cannot set /seeds/d row 1 of couple.h5 to $value"
        continue
    fi
    "$BIN" impact "$CASE" -o "$T/seed_$bad" >/dev/null 2>"$T/err"
    status=$?
    if grep -q '\[impact\] diameter' "$T/err"; then
        fail "impact_seed_$bad" "the message blames [impact] diameter: $(grep 'spraycoat:' "$T/err" | head -n 1)"
    elif [ "$bad" = nan ]; then
        expect impact_seed_nan "$status" 'couple.h5' '/seeds/d' 'row 1' 'nan' 'rerun the couple stage'
    elif [ "$status" -eq 2 ] && grep 'spraycoat:' "$T/err" | grep 'couple.h5' | grep -q 'row 1'; then
        pass impact_seed_tiny
    else
        fail impact_seed_tiny "exit status $status, expected 2 naming couple.h5 and row 1: $(tail -n 1 "$T/err")"
    fi
done

[ "$failures" -eq 0 ]
