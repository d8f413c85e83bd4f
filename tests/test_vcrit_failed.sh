#!/bin/sh
# A run that fails as a simulation (NaN or blow-up, SC_ESIM) ends only its own search, never the stage
# (app/vcrit_stage.c note_failed, calibrate_stage.c counted_as).  The set-up: tests/fixtures/vcrit_tiny.ini with
# cfl = 1 (the time step as long as allowed) and vrest_threshold = 1000 m/s (a fast particle with PBCP 100 % counts
# as bonded), 200 to 12000 m/s: the 8 um particle bonds at 12000 m/s and its search brackets, the 10 um one blows up
# at 12000 m/s within 60 steps (the stress update's non-finite state, naming its step and body), a second a search.
#   1. vcrit over both diameters exits 0; vcrit.csv has the 10 um row as a '#' line with the note "run at 12000 m/s
#      failed (...): no v_crit", and the 8 um v_crit equal to that of the 8 um search alone (finite); vcrit_runs.csv
#      holds the failed run (verdict 3, NaN PBCP, its message), vcrit_cor.csv calls it failed, the log warns naming
#      the pair, the speed and the step, and `spraycoat info` shows the note;
#   2. `spraycoat resume` with the outputs removed replays the search from the records: no run (0 runs in this
#      process), the same vcrit.csv, vcrit_cor.csv and vcrit.h5 /search;
#   3. calibrate over a grid where the 10 um runs at Gc = 720 fail: exits 0, the two failed runs left out of the fit
#      and counted apart (log, calibrate.csv, calibrate_outcomes.csv, calibrate.h5 /size/001 attribute failed = 2),
#      and a resume makes no run;
#   4. calibrate method = vcrit whose first search has the failed size stops as an unbracketed size does (exit 1),
#      with a message naming the failure, and the search's vcrit.csv holds the '#' row.
#   5. with an MPI build (SPRAYCOAT_MPI_BIN, as tests/test_mpi.sh), `mpirun -np 2` of the vcrit case: the pairs
#      shared out, rank 0 replays the failed pair from the other rank's records: the same vcrit.csv and vcrit_cor.csv
#      as one process.
# Before this, each of these ended the stage at the failed run with exit status 1 and no outputs.
# Prints "PASS name" / "FAIL name (reason)".  Run from the repository root with $SPRAYCOAT_BIN.
set -u
. tests/wait_lib.sh

spraycoat_bin
pass() { echo "PASS $1"; }
fail() { echo "FAIL $1 ($2)"; }
if [ ! -x "$BIN" ] || ! command -v h5dump >/dev/null 2>&1; then
    echo "FAIL vcrit_failed (no $BIN or h5dump; run from the repository root after make)"
    exit 1
fi
scratch_dir

impact() { # the tiny set-up with the long time step and the lenient v_rest
    awk '{ print } /^\[impact\]/ { print "cfl = 1"; print "vrest_threshold = 1000" }' tests/fixtures/vcrit_tiny.ini
}
vcrit_case() { # vcrit_case FILE DIAMETERS
    { impact; printf '\n[vcrit]\ndiameters = %s\nv_low = 200\nv_high = 12000\ntolerance = 1500\n' "$2"; } >"$1"
}

# ---- 1. one pair fails, the other's search goes on ---------------------------------------------------------------
vcrit_case "$T/both.ini" "8e-6,10e-6"
vcrit_case "$T/alone.ini" "8e-6"
RUN=$T/both
"$BIN" vcrit "$T/alone.ini" -o "$T/alone" >"$T/alone.log" 2>&1 || fail vcrit_failed_pair "the 8 um search alone exited $?"
alone=$(grep '^8e-06,' "$T/alone/vcrit.csv" 2>/dev/null | cut -d, -f2)
"$BIN" vcrit "$T/both.ini" -o "$RUN" >"$T/both.log" 2>&1
status=$?
why=""
[ "$status" -eq 0 ] || why="$why exit status $status, expected 0: $(grep '^spraycoat:' "$T/both.log");"
case "$alone" in '' | nan | *[!0-9.e+-]*) why="$why the 8 um search alone has no finite v_crit ($alone);" ;; esac
both=$(grep '^8e-06,' "$RUN/vcrit.csv" 2>/dev/null | cut -d, -f2)
[ -n "$both" ] && [ "$both" = "$alone" ] || why="$why 8 um v_crit '$both' beside the failed pair, '$alone' alone;"
grep -q '^# 1e-05,nan,nan,nan,2  run at 12000 m/s failed (impact: step [0-9]* .* of body 1: .*): no v_crit$' \
    "$RUN/vcrit.csv" 2>/dev/null || why="$why no '#' row with the failure's note: $(grep '^#' "$RUN/vcrit.csv" 2>/dev/null);"
grep -q '^1e-05,12000,720,200000000000,3,nan,nan,nan,[0-9]*,0,"impact: step .*"$' "$RUN/vcrit_runs.csv" 2>/dev/null ||
    why="$why vcrit_runs.csv holds no failed record (its error quoted);"
# a CSV reader (Python's, RFC 4180) sees the error as the one last field (after the title line)
csv_fields=$(python3 -c 'import csv, sys
rows = list(csv.reader(open(sys.argv[1], newline="")))[1:]
print(" ".join(sorted(set(str(len(r)) for r in rows))), sum(1 for r in rows[1:] if r[4] == "3" and r[10].startswith("impact: step ")))' \
    "$RUN/vcrit_runs.csv" 2>&1)
[ "$csv_fields" = "11 1" ] || why="$why vcrit_runs.csv read as CSV: field counts and failed rows '$csv_fields', expected '11 1';"
grep -q '^1e-05,12000,failed,nan,nan,nan$' "$RUN/vcrit_cor.csv" 2>/dev/null || why="$why vcrit_cor.csv does not call it failed;"
grep -q 'warning: vcrit: d = 10 um at 12000 m/s .*failed after [0-9]* steps: impact: step ' "$T/both.log" ||
    why="$why no warning naming the pair, the speed and the error;"
"$BIN" info "$RUN" >"$T/info.log" 2>&1
grep -q 'd = 1e-05 m: run at 12000 m/s failed' "$T/info.log" || why="$why spraycoat info does not show the note;"
if [ -z "$why" ]; then pass vcrit_failed_pair; else fail vcrit_failed_pair "$why"; fi

# ---- 2. the records replayed: the failed run is not made again --------------------------------------------------
mkdir -p "$T/first"
cp "$RUN/vcrit.csv" "$RUN/vcrit_cor.csv" "$RUN/vcrit.h5" "$T/first/" 2>/dev/null
rm -f "$RUN/vcrit.csv" "$RUN/vcrit_cor.csv" "$RUN/vcrit.h5"
"$BIN" resume "$RUN" >"$T/resume.log" 2>&1
status=$?
why=""
[ "$status" -eq 0 ] || why="$why resume exited $status: $(grep '^spraycoat:' "$T/resume.log");"
grep -q '7 runs recorded' "$T/resume.log" || why="$why the 7 records were not reused;"
grep -q '(0 runs in this process' "$T/resume.log" || why="$why runs were made again: $(grep 'runs in this process' "$T/resume.log");"
for f in vcrit.csv vcrit_cor.csv; do
    cmp -s "$T/first/$f" "$RUN/$f" || why="$why $f differs after the resume;"
done
h5diff -d 0 "$T/first/vcrit.h5" "$RUN/vcrit.h5" /search /search >/dev/null 2>&1 || why="$why vcrit.h5:/search differs;"
# a record file written before the error was quoted (the rest of the line) is replayed alike
sed 's/,"\(impact: step .*\)"$/,\1/' "$RUN/vcrit_runs.csv" >"$T/unquoted.csv" && cp "$T/unquoted.csv" "$RUN/vcrit_runs.csv"
grep -q ',0,impact: step ' "$RUN/vcrit_runs.csv" || why="$why the unquoted record was not made;"
rm -f "$RUN/vcrit.csv" "$RUN/vcrit_cor.csv" "$RUN/vcrit.h5"
"$BIN" resume "$RUN" >"$T/resume2.log" 2>&1 || why="$why the resume of the unquoted records exited $?;"
grep -q '(0 runs in this process' "$T/resume2.log" || why="$why the unquoted records' runs were made again;"
cmp -s "$T/first/vcrit.csv" "$RUN/vcrit.csv" || why="$why vcrit.csv differs after the resume of the unquoted records;"
# a quoted message with commas and doubled quotes (RFC 4180) is read back whole
sed 's/,0,impact: step .*$/,0,"impact: step 58, a ""crafted"" message, with commas"/' "$T/unquoted.csv" >"$RUN/vcrit_runs.csv"
rm -f "$RUN/vcrit.csv" "$RUN/vcrit_cor.csv" "$RUN/vcrit.h5"
"$BIN" resume "$RUN" >"$T/resume3.log" 2>&1 || why="$why the resume of the crafted record exited $?;"
grep -q '(0 runs in this process' "$T/resume3.log" || why="$why the crafted record's runs were made again;"
grep -q '^# 1e-05,nan,nan,nan,2  run at 12000 m/s failed (impact: step 58, a "crafted" message, with commas): no v_crit$' \
    "$RUN/vcrit.csv" || why="$why the crafted message was not read back whole: $(grep '^#' "$RUN/vcrit.csv" 2>/dev/null);"
if [ -z "$why" ]; then pass vcrit_failed_resume_reuses; else fail vcrit_failed_resume_reuses "$why"; fi

# ---- 3. calibrate over a grid: failed runs left out of the fit and counted -----------------------------------------
{ impact; printf '\n[calibrate]\ndiameters = 8e-6,10e-6\nvelocities = 12000,12000\nsubstrate_diameters = 20e-6,20e-6\n'
  printf 'Gc_min = 720\nGc_max = 1500\nGc_count = 2\nGc_rate_min = 1e11\nGc_rate_max = 2e11\nGc_rate_count = 2\n'; } >"$T/grid.ini"
CAL=$T/grid
"$BIN" calibrate "$T/grid.ini" -o "$CAL" >"$T/grid.log" 2>&1
status=$?
why=""
[ "$status" -eq 0 ] || why="$why exit status $status, expected 0: $(grep '^spraycoat:' "$T/grid.log");"
[ "$(grep -c '^1.0000000000000001e-05,12000,720,[0-9e]*,failed,nan,nan,nan$' "$CAL/calibrate_outcomes.csv" 2>/dev/null)" = 2 ] ||
    why="$why calibrate_outcomes.csv has not the 2 failed runs;"
grep -q 'calibrate: d = 10 um at 12000 m/s: 2 bonded, 0 rebounded, 0 unsettled, 2 failed' "$T/grid.log" ||
    why="$why the log does not count 2 failed;"
grep -q '^# d = 1e-05 m: 2 runs failed as simulations' "$CAL/calibrate.csv" 2>/dev/null || why="$why calibrate.csv does not say so;"
failed=$(h5dump -a /size/001/failed "$CAL/calibrate.h5" 2>/dev/null | awk '/\(0\):/ { print $2 }')
none=$(h5dump -a /size/000/failed "$CAL/calibrate.h5" 2>/dev/null | awk '/\(0\):/ { print $2 }')
[ "$failed" = 2 ] && [ "$none" = 0 ] || why="$why /size/NNN failed: '$none' and '$failed', expected 0 and 2;"
rm -f "$CAL/calibrate.h5"
"$BIN" resume "$CAL" >"$T/grid_resume.log" 2>&1 || why="$why resume exited $?;"
grep -q '(0 runs in this process' "$T/grid_resume.log" || why="$why the resume made runs again;"
if [ -z "$why" ]; then pass calibrate_failed_runs_counted; else fail calibrate_failed_runs_counted "$why"; fi

# ---- 4. calibrate method = vcrit: a search whose size failed stops it as an unbracketed size does -------------------
{ impact; printf '\n[vcrit]\nv_low = 200\nv_high = 12000\ntolerance = 1500\n\n[calibrate]\nmethod = vcrit\n'
  printf 'diameters = 10e-6,8e-6\nvelocities = 850,800\nGc_min = 720\nGc_max = 1500\n'; } >"$T/fit.ini"
"$BIN" calibrate "$T/fit.ini" -o "$T/fit" >"$T/fit.log" 2>&1
status=$?
why=""
[ "$status" -eq 1 ] || why="$why exit status $status, expected 1;"
grep -q '^spraycoat: calibrate: at Gc = 720 the critical velocity of d = 1e-05 m was not found: run at 12000 m/s failed (impact: step' \
    "$T/fit.log" || why="$why the message does not name the failure: $(grep '^spraycoat:' "$T/fit.log");"
grep -q '^# 1e-05,nan,.*no v_crit$' "$T/fit/vcrit_01/vcrit.csv" 2>/dev/null || why="$why the search's vcrit.csv has no '#' row;"
if [ -z "$why" ]; then pass calibrate_vcrit_failed_search; else fail calibrate_vcrit_failed_search "$why"; fi

# ---- 5. two processes: rank 0 replays the other rank's failed pair from its records ----------------------------------
MPI_BIN=${SPRAYCOAT_MPI_BIN:-}
if [ -n "$MPI_BIN" ] && [ -x "$MPI_BIN" ] && command -v mpirun >/dev/null 2>&1; then
    export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
    mpirun -np 2 --oversubscribe "$MPI_BIN" vcrit "$T/both.ini" -o "$T/two" >"$T/two.log" 2>&1
    status=$?
    why=""
    [ "$status" -eq 0 ] || why="$why mpirun exited $status: $(grep '^spraycoat:' "$T/two.log" | head -n 1);"
    for f in vcrit.csv vcrit_cor.csv; do
        cmp -s "$T/first/$f" "$T/two/$f" || why="$why $f differs from one process's;"
    done
    if [ -z "$why" ]; then pass vcrit_failed_mpi_replay; else fail vcrit_failed_mpi_replay "$why"; fi
else
    echo "  note: no MPI build (SPRAYCOAT_MPI_BIN): vcrit_failed_mpi_replay not run"
fi
