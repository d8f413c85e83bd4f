#!/bin/sh
# Results of another build (docs/architecture.md "Another build"): every output and checkpoint carries the root
# attribute sources_id, the digest of the sources that compute results; BUILD/tests/spraycoat-other-sources is the
# same program with another sources_id (as if built from edited sources).  A stage's output made by the other build
# is computed again, not found up to date (and then carries this build's sources_id; the same sources give the same
# datasets; `spraycoat info` says which outputs are another build's); a checkpoint of the other build is refused (exit 2, the checkpoint kept) and resumed by the build that
# wrote it; a stage that reads an input of the other build warns; a vcrit record of the runs made by the other build
# is not reused and is kept aside as vcrit_runs.csv.kept-1, not overwritten.
# Run from the repository root with $SPRAYCOAT_BIN (tests/run_tests.sh sets it).  Needs h5dump and h5diff.
# Prints "PASS name" / "FAIL name (reason)".
set -u
. tests/wait_lib.sh

spraycoat_bin
OTHER=$(dirname "$BIN")/tests/spraycoat-other-sources
DEMO=cases/mz2015_demo.ini

pass() { echo "PASS $1"; }
fail() { echo "FAIL $1 ($2)"; }

for tool in h5dump h5diff; do
    command -v "$tool" >/dev/null 2>&1 || {
        echo "FAIL build_identity ($tool not found: install hdf5-tools)"
        exit 1
    }
done
if [ ! -x "$BIN" ] || [ ! -x "$OTHER" ] || [ ! -r "$DEMO" ]; then
    echo "FAIL build_identity (no $BIN, $OTHER or $DEMO; run from the repository root after make)"
    exit 1
fi
scratch_dir

# sources_id FILE: the root attribute sources_id ("" when absent)
sources_id() { h5dump -a /sources_id "$1" 2>/dev/null | sed -n 's/^ *(0): "\(.*\)"$/\1/p'; }
# built_from BIN: the sources_id that BIN's --version prints
built_from() { "$1" --version | awk '$1 == "sources_id" { print $2 }'; }
created() { h5dump -a /created "$1" 2>/dev/null | sed -n 's/^ *(0): "\(.*\)"$/\1/p'; }

MINE=$(built_from "$BIN")
THEIRS=$(built_from "$OTHER")
if [ -z "$MINE" ] || [ -z "$THEIRS" ] || [ "$MINE" = "$THEIRS" ]; then
    echo "FAIL build_identity (--version gives sources_id '$MINE' and '$THEIRS' for the two builds)"
    exit 1
fi

t_end=2e-3
[ -n "${SPRAYCOAT_SANITIZED:-}" ] && t_end=1e-3
CASE=$T/short.ini
sed -e "s/^t_end *=.*/t_end = $t_end/" -e "s/^checkpoint_steps *=.*/checkpoint_steps = 100/" "$DEMO" >"$CASE"
grep -q "^t_end = $t_end\$" "$CASE" && grep -q '^checkpoint_steps = 100$' "$CASE" || {
    echo "FAIL build_identity ($DEMO no longer has the lines t_end and checkpoint_steps this test rewrites)"
    exit 1
}

# ---- 1. an output of the other build is computed again ------------------------------------------------------------
RUN=$T/run
"$OTHER" spray "$CASE" -o "$RUN" >"$T/other.log" 2>&1
"$BIN" spray "$CASE" -o "$T/mine" >"$T/mine.log" 2>&1
theirs_created=$(created "$RUN/spray.h5")
"$BIN" info "$RUN" >"$T/info_theirs.txt" 2>&1
# the report drawn by this build over the other's spray.h5 says so among its warnings
cp -r "$RUN" "$T/theirs_report"
"$BIN" render "$CASE" -o "$T/theirs_report" >"$T/theirs_report.log" 2>&1
sed -n '/<section id="warnings">/,/<\/section>/p' "$T/theirs_report/report.html" >"$T/theirs_warnings.html"
"$BIN" spray "$CASE" -o "$RUN" >"$T/again.log" 2>&1
status=$?
why=""
[ "$(sources_id "$T/mine/spray.h5")" = "$MINE" ] || why="$why this build's spray.h5 has sources_id '$(sources_id "$T/mine/spray.h5")', not '$MINE';"
[ $status -eq 0 ] || why="$why the run after the other build's exited $status;"
grep -q 'made by another build of spraycoat' "$T/again.log" || why="$why the log does not say the output is another build's;"
grep -q 'up to date' "$T/again.log" && why="$why the other build's spray.h5 was taken as up to date;"
[ "$(sources_id "$RUN/spray.h5")" = "$MINE" ] || why="$why spray.h5 has sources_id '$(sources_id "$RUN/spray.h5")' after the rerun;"
[ "$(created "$RUN/spray.h5")" != "$theirs_created" ] || why="$why spray.h5 was not written again;"
grep -q '^stage spray: done (made by another build of spraycoat' "$T/info_theirs.txt" || why="$why spraycoat info does not say spray.h5 is another build's: $(grep '^stage spray' "$T/info_theirs.txt");"
grep -q "spray.h5 was made by another build of spraycoat (sources $THEIRS, this build's $MINE)" "$T/theirs_warnings.html" ||
    why="$why the report's warnings do not say spray.h5 is another build's;"
"$BIN" info "$RUN" >"$T/info_mine.txt" 2>&1
"$BIN" render "$CASE" -o "$RUN" >"$T/mine_report.log" 2>&1
grep -q 'another build' "$RUN/report.html" && why="$why the report of this build's own spray.h5 speaks of another build;"
grep -q '^stage spray: done$' "$T/info_mine.txt" || why="$why after the rerun spraycoat info says $(grep '^stage spray' "$T/info_mine.txt");"
# the same sources compute the same results: the impacts of both builds agree to the bit
h5diff -d 0 "$RUN/spray.h5" "$T/mine/spray.h5" /impacts /impacts >/dev/null 2>&1 || why="$why /impacts differs from this build's own run;"
if [ -z "$why" ]; then pass other_build_output_computed_again; else fail other_build_output_computed_again "$why"; fi

# this build's own output is up to date
"$BIN" spray "$CASE" -o "$RUN" >"$T/same.log" 2>&1
if grep -q 'up to date' "$T/same.log"; then pass own_output_up_to_date; else fail own_output_up_to_date "$(tail -n 3 "$T/same.log")"; fi

# ---- 2. a stage that reads the other build's output warns, once -------------------------------------------------
"$OTHER" spray "$CASE" -o "$T/couple" >/dev/null 2>&1
"$BIN" couple "$CASE" -o "$T/couple" >"$T/couple.log" 2>&1
status=$?
# once: the command checks its stages' inputs before it starts, and the stage again
if [ $status -eq 0 ] && [ "$(grep -c 'spray.h5 was made by another build of spraycoat' "$T/couple.log")" -eq 1 ]; then
    pass other_build_input_warned
else
    fail other_build_input_warned "exit $status; $(grep -i 'another build\|error' "$T/couple.log" | head -n 2)"
fi

# ---- 3. a checkpoint of the other build is refused, and resumed by the build that wrote it --------------------------
LONG=$T/long.ini
sed -e "s/^t_end *=.*/t_end = 0.05/" "$CASE" >"$LONG"
"$OTHER" spray "$LONG" -o "$T/ck" >"$T/ck.log" 2>&1 &
bg=$!
has_checkpoint() { exists "$T/ck/checkpoints/spray_*.h5"; }
wait_until "$bg" 60 has_checkpoint
kill -TERM "$bg" 2>/dev/null
wait "$bg" 2>/dev/null
status=$?
bg=""
before=$(ls "$T/ck/checkpoints/" 2>/dev/null | tr '\n' ' ')
"$BIN" resume "$T/ck" >"$T/refused.log" 2>&1
refused=$?
after=$(ls "$T/ck/checkpoints/" 2>/dev/null | tr '\n' ' ')
why=""
[ $status -eq 143 ] || why="$why the other build's run exited $status on SIGTERM, not 143;"
[ -n "$before" ] || why="$why no checkpoint was written;"
[ $refused -eq 2 ] || why="$why resuming with this build exited $refused, not 2;"
grep -q 'written by another build of spraycoat' "$T/refused.log" || why="$why the refusal does not name another build: $(grep -i error "$T/refused.log" | head -n 1);"
[ "$before" = "$after" ] || why="$why the checkpoints changed from '$before' to '$after';"
[ -e "$T/ck/spray.h5" ] && why="$why spray.h5 was written;"
if [ -z "$why" ]; then pass other_build_checkpoint_refused; else fail other_build_checkpoint_refused "$why"; fi

# the build that wrote it resumes it (stopped again at its next checkpoint: the whole run is not needed)
"$OTHER" resume "$T/ck" >"$T/resumed.log" 2>&1 &
bg=$!
resumed() { grep -q 'spray: resuming from' "$T/resumed.log" && ! grep -q 'another build' "$T/resumed.log"; }
wait_until "$bg" 60 resumed
ok=$?
kill -TERM "$bg" 2>/dev/null
wait "$bg" 2>/dev/null
status=$?
bg=""
if [ $ok -eq 0 ] && { [ $status -eq 143 ] || [ $status -eq 0 ]; }; then
    pass other_build_resumes_its_checkpoint
else
    fail other_build_resumes_its_checkpoint "exit $status; $(tail -n 3 "$T/resumed.log")"
fi

# ---- 4. a vcrit record of the other build: not reused, kept aside ------------------------------------------------
VCASE=$T/vcrit.ini
cat tests/fixtures/vcrit_tiny.ini - >"$VCASE" <<EOF

[vcrit]
diameters = 8e-6
v_low = 200
v_high = 1200
tolerance = 400
EOF
V=$T/vcrit
"$OTHER" vcrit "$VCASE" -o "$V" >"$T/v_other.log" 2>&1
cp "$V/vcrit_runs.csv" "$T/theirs_runs.csv" 2>/dev/null
theirs_runs=$(grep -c '^[0-9]' "$T/theirs_runs.csv" 2>/dev/null)
"$BIN" vcrit "$VCASE" -o "$V" >"$T/v_mine.log" 2>&1
status=$?
mine_runs=$(grep -c '^[0-9]' "$V/vcrit_runs.csv" 2>/dev/null)
why=""
[ "${theirs_runs:-0}" -gt 0 ] || why="$why the other build recorded no runs;"
[ $status -eq 0 ] || why="$why this build's search exited $status;"
grep -q 'reused' "$T/v_mine.log" && why="$why the other build's runs were reused;"
[ "${mine_runs:-0}" -eq "${theirs_runs:-0}" ] || why="$why this build made ${mine_runs:-no} runs, the other ${theirs_runs:-no};"
grep -q "sources $MINE\$" "$V/vcrit_runs.csv" || why="$why vcrit_runs.csv does not name this build's sources;"
cmp -s "$V/vcrit_runs.csv.kept-1" "$T/theirs_runs.csv" || why="$why the other build's record was not kept as vcrit_runs.csv.kept-1;"
if [ -z "$why" ]; then pass other_build_records_kept_not_reused; else fail other_build_records_kept_not_reused "$why"; fi
