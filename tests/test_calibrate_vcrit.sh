#!/bin/sh
# `spraycoat calibrate` with [calibrate] method = vcrit (app/calibrate_vcrit.c) on a tiny case (8 and 10 um on a
# 2 um grid, 10 ns per run, v_crit to 25 m/s: about 3 s a search here):
#   1. the energy model's Gc between 300 and 1500 J/m2 so that v_crit of 10 and 8 um meets 850 and 800 m/s on
#      average within 15 m/s: calibrate.csv has the calibrated Gc inside the range with Gc_rate kept,
#      calibrate_vcrit.csv every search (the ends first, its last search the calibrated Gc with |mean residual|
#      <= 15), calibrate.h5 says method vcrit and the figure exists; and an independent `spraycoat vcrit` of the
#      case with that Gc written into [impact] gives v_crit whose mean residual (computed here) is within 15 m/s;
#   2. with its outputs removed, the calibration runs again from the searches' outputs: the same calibrate.csv and
#      no impact run;
#   2b. after another case's calibration fails writing calibrate.h5 (exit 3) in the same run directory, the first
#      case is calibrated again (from the searches' outputs) rather than found up to date beside the other's CSVs;
#   3. a range whose ends give residuals of one sign gives no calibrated value and says so (exit 0);
#   4. the searches' diameters given in [vcrit] as well are refused (exit 2, naming the key);
#   4b. --device gpu without a GPU is refused (exit 2) as `spraycoat vcrit` refuses it: the searches take the
#      command line's settings;
#   4c. stopped by SIGTERM in a search's run, it exits 143 and names the calibration's directory to resume;
#   5. with a tolerance finer than the residual's steps the iteration ends when the bracket is narrower than
#      fit_bracket of its middle: the value is that middle, between searches whose residuals change sign;
#   6. a search in which a size is not bracketed (it bonds already at v_low) stops the calibration with a message
#      naming the parameter, the size and the search's vcrit.csv, and leaves no calibrated value;
#   7. rate = fitted (Gc_rate between 2e10 and 1e11 J/m2/s, targets 700 and 725 m/s for 10 and 8 um, spread
#      tolerance 8 m/s): a calibrated pair strictly inside the rate's range (found by false position, not at an end),
#      the first search at both ranges' low ends, every search's Gc_rate in the range, searches at one Gc with
#      different Gc_rate giving different v_crit (the rate reaches the runs), and an independent `spraycoat vcrit`
#      with both values written into [impact] meeting the targets on average within 15 m/s and their difference
#      within 8 m/s (both computed here); the second fit starting at the value the first fitted; the same pair
#      replayed from the searches' outputs without an impact run; with targets 700 and 760 m/s, whose spread no
#      rate in the range meets, no calibrated value and a note that the spread residual has one sign.
# Prints "PASS name" / "FAIL name (reason)".  Run from the repository root with $SPRAYCOAT_BIN.
set -u
. tests/wait_lib.sh

spraycoat_bin
pass() { echo "PASS $1"; }
fail() { echo "FAIL $1 ($2)"; }
if [ ! -x "$BIN" ] || ! command -v h5dump >/dev/null 2>&1; then
    echo "FAIL calibrate_vcrit (no $BIN or h5dump; run from the repository root after make)"
    exit 1
fi
scratch_dir

TOL=15
impact_section() { # impact_section [EXTRA LINE]
    cat <<EOF
[run]
threads = 1

[impact]
grid = 2e-6
spacing = 1e-6
substrate_diameter = 20e-6
substrate_height = 6e-6
t_end = 10e-9
bonding = energy
$1
; verdicts settle within 10 ns (as tests/test_vcrit.sh's tiny case): far too coarse for physics, quick
settle_window = 2e-9
settle_vcom = 1e4
settle_pbcp = 1
vrest_filter = 1e4

[material.aluminium]

[vcrit]
v_low = 200
v_high = 1200
tolerance = 25
EOF
}
write_case() { # write_case FILE GC_MIN GC_MAX
    {
        impact_section ""
        cat <<EOF

[calibrate]
method = vcrit
diameters = 10e-6,8e-6
velocities = 850,800
Gc_min = $2
Gc_max = $3
fit_tolerance = $TOL
EOF
    } >"$1"
}

# ---- 1. the calibration and an independent check of its value ----------------------------------------------------
write_case "$T/cal.ini" 300 1500
RUN=$T/cal
if ! "$BIN" calibrate "$T/cal.ini" -o "$RUN" >"$T/cal.log" 2>&1; then
    fail calibrate_vcrit_fit "exit status $?: $(tail -n 3 "$T/cal.log")"
    exit 0
fi
gc=$(awk -F, 'NR == 2 && $3 == 1 { print $1 }' "$RUN/calibrate.csv")
why=""
[ "$(head -n 1 "$RUN/calibrate.csv")" = "Gc,Gc_rate,calibrated" ] || why="$why calibrate.csv header;"
[ -n "$gc" ] || why="$why no calibrated row in calibrate.csv: $(tail -n 1 "$RUN/calibrate.csv");"
if [ -n "$gc" ]; then
    awk -v g="$gc" 'BEGIN { exit !(g > 300 && g < 1500) }' || why="$why Gc $gc outside 300-1500;"
    awk -F, 'NR == 2 { exit !($2 == 2e11) }' "$RUN/calibrate.csv" || why="$why Gc_rate not kept at 2e11;"
    # the searches: the ends first; the last one at the calibrated Gc, within the tolerance
    awk -F, -v g="$gc" -v tol="$TOL" '
        NR == 1 { next }
        $1 == 1 && $2 != 300 { print "search 1 not at Gc_min"; bad = 1 }
        $1 == 2 && $2 != 1500 { print "search 2 not at Gc_max"; bad = 1 }
        { last = $1; p[$1] = $2; r[$1] = $7 }
        END {
            if (p[last] != g) print "the last search at Gc " p[last] ", calibrated " g
            if (r[last] > tol || r[last] < -tol) print "the last search misses by " r[last] " m/s"
        }' "$RUN/calibrate_vcrit.csv" >"$T/searches"
    [ -s "$T/searches" ] && why="$why $(tr '\n' ';' <"$T/searches")"
fi
h5dump -a /method "$RUN/calibrate.h5" 2>/dev/null | grep -q '"vcrit"' || why="$why calibrate.h5 has no method vcrit;"
[ -s "$RUN/figures/calibrate_vcrit.png" ] || why="$why no figures/calibrate_vcrit.png;"
if [ -z "$why" ]; then pass calibrate_vcrit_fit; else fail calibrate_vcrit_fit "$why"; fi

if [ -n "$gc" ]; then
    # the calibrated Gc in a plain v_crit search of the two sizes, and the mean residual computed here
    {
        impact_section "Gc = $gc"
        echo "diameters = 10e-6,8e-6"
    } >"$T/check.ini"
    if "$BIN" vcrit "$T/check.ini" -o "$T/check" >"$T/check.log" 2>&1; then
        residual=$(awk -F, 'NR > 1 && !/^#/ { t = ($1 + 0 == 1e-5) ? 850 : 800; s += $2 - t; n++ }
                            END { if (n == 2) printf "%.6g", s / n }' "$T/check/vcrit.csv")
        if [ -n "$residual" ] && awk -v r="$residual" -v tol="$TOL" 'BEGIN { exit !(r <= tol && r >= -tol) }'; then
            pass calibrate_vcrit_meets_targets
        else
            fail calibrate_vcrit_meets_targets "v_crit with Gc $gc misses the targets by '$residual' m/s on average"
        fi
    else
        fail calibrate_vcrit_meets_targets "the check search failed: $(tail -n 2 "$T/check.log")"
    fi
fi

# ---- 2. replayed from the searches' outputs ------------------------------------------------------------------------
cp "$RUN/calibrate.csv" "$T/first.csv"
rm -f "$RUN/calibrate.csv" "$RUN/calibrate.h5" "$RUN/calibrate_vcrit.csv"
if "$BIN" calibrate "$T/cal.ini" -o "$RUN" >"$T/again.log" 2>&1 && cmp -s "$T/first.csv" "$RUN/calibrate.csv"; then
    if grep -q 'vcrit: d = .* m/s .*: \(bonded\|rebounded\|unsettled\)' "$T/again.log"; then
        fail calibrate_vcrit_replay "impact runs made again: $(grep -m 1 'vcrit: d = ' "$T/again.log")"
    else
        pass calibrate_vcrit_replay
    fi
else
    fail calibrate_vcrit_replay "another calibrate.csv or a failure: $(tail -n 2 "$T/again.log")"
fi

# ---- 2b. a failed write damages nothing: another case (fit_tolerance 1000: its first search, done already, is the
# value) fails writing calibrate.h5 in the same run directory (the temporary's name blocked by a folder: exit 3); the
# first case's results stay whole, up to date with their own calibrate.csv (app.h stage_write_outputs) -------------
sed 's/^fit_tolerance = .*/fit_tolerance = 1000/' "$T/cal.ini" >"$T/loose.ini"
blocked_write "$RUN" calibrate.h5 "$T/loose.log" "$BIN" calibrate "$T/loose.ini" -o "$RUN"
"$BIN" calibrate "$T/cal.ini" -o "$RUN" >"$T/unmixed.log" 2>&1
again=$?
why=""
[ $blocked -eq 3 ] || why="$why the blocked write exited $blocked, not 3: $(tail -n 1 "$T/loose.log");"
[ $again -eq 0 ] || why="$why the first case again exited $again: $(tail -n 1 "$T/unmixed.log");"
grep -q "calibrate.h5 is up to date" "$T/unmixed.log" || why="$why the first case's results were damaged (not up to date);"
cmp -s "$T/first.csv" "$RUN/calibrate.csv" || why="$why calibrate.csv is not the first case's: $(tr '\n' ' ' <"$RUN/calibrate.csv");"
if [ -z "$why" ]; then pass calibrate_vcrit_failed_write_leaves_nothing_stale; else fail calibrate_vcrit_failed_write_leaves_nothing_stale "$why"; fi

# ---- 3. no root in the range ---------------------------------------------------------------------------------------
write_case "$T/high.ini" 1400 1500
if "$BIN" calibrate "$T/high.ini" -o "$T/high" >"$T/high.log" 2>&1 &&
    grep -q '^# no calibrated value: the mean residual has one sign' "$T/high/calibrate.csv" &&
    ! grep -q ',1$' "$T/high/calibrate.csv" && grep -q 'no calibrated Gc' "$T/high.log"; then
    pass calibrate_vcrit_no_root
else
    fail calibrate_vcrit_no_root "$(tail -n 2 "$T/high/calibrate.csv" 2>/dev/null) $(tail -n 1 "$T/high.log")"
fi

# ---- 4. the searches' diameters in two places ----------------------------------------------------------------------
sed 's/^tolerance = 25$/tolerance = 25\ndiameters = 10e-6/' "$T/cal.ini" >"$T/twice.ini"
"$BIN" calibrate "$T/twice.ini" -o "$T/twice" >"$T/twice.log" 2>&1
status=$?
if [ "$status" -eq 2 ] && grep -q '\[vcrit\] diameters' "$T/twice.log" && [ ! -e "$T/twice/calibrate.csv" ]; then
    pass calibrate_vcrit_refuses_two_diameter_lists
else
    fail calibrate_vcrit_refuses_two_diameter_lists "exit $status: $(tail -n 1 "$T/twice.log")"
fi
# ---- 4b. the command line reaches the searches: --device gpu on a build or machine without a GPU is refused (exit
# 2, nothing written) as `spraycoat vcrit` refuses it (the searches read the case file again and ran on the CPU) ---
if command -v nvidia-smi >/dev/null 2>&1 && nvidia-smi -L >/dev/null 2>&1; then
    echo "  a GPU is present: --device gpu may run here (calibrate_vcrit_device_reaches_searches not checked)"
else
    "$BIN" calibrate "$T/cal.ini" -o "$T/gpu" --device gpu >"$T/gpu.log" 2>&1
    status=$?
    if [ "$status" -eq 2 ] && grep -q '\[run\] device = gpu' "$T/gpu.log" && [ ! -e "$T/gpu" ]; then
        pass calibrate_vcrit_device_reaches_searches
    else
        fail calibrate_vcrit_device_reaches_searches "exit $status, run directory $([ -e "$T/gpu" ] && echo made || echo absent): $(tail -n 1 "$T/gpu.log")"
    fi
fi

# ---- 4c. a calibration stopped by SIGTERM in a search's run exits 143 and says to resume the calibration's directory
# (resuming the search's own, vcrit_01, finished that search only) --------------------------------------------------
"$BIN" calibrate "$T/cal.ini" -o "$T/stop" >"$T/stop.log" 2>&1 &
bg=$!
wait_until "$bg" 60 rows_at_least "$T/stop/vcrit_01/vcrit_runs.csv" 1
kill -TERM "$bg" 2>/dev/null
wait "$bg"
status=$?
bg=""
if [ "$status" -eq 143 ] && grep -q "continue with \`spraycoat resume $T/stop\`" "$T/stop.log"; then
    pass calibrate_vcrit_interrupted_names_its_directory
else
    fail calibrate_vcrit_interrupted_names_its_directory "exit $status (143 expected): $(grep -o 'continue with .*' "$T/stop.log")"
fi

# ---- 5. a tolerance finer than the residual's jumps: the bracket closes ----------------------------------------------
# v_crit lies on the bisection's lattice (200 + 1000 k / 64 m/s), so the mean residual against 851 and 801 m/s is
# -1 + 7.8125 j m/s and no search meets 0.5 m/s; the iteration ends when the bracket is narrower than 2 % of its
# middle, and that middle is the value: the searches just below and above it have residuals of opposite signs.
sed -e 's/^fit_tolerance = .*/fit_tolerance = 0.5\nfit_bracket = 0.02/' -e 's/^velocities = .*/velocities = 851,801/' \
    "$T/cal.ini" >"$T/bracket.ini"
if "$BIN" calibrate "$T/bracket.ini" -o "$T/bracket" >"$T/bracket.log" 2>&1; then
    c=$(awk -F, 'NR == 2 && $3 == 1 { print $1 }' "$T/bracket/calibrate.csv")
    why=$(awk -F, -v c="${c:-nan}" 'NR > 1 {
            if ($2 < c && (lo == "" || $2 > lo)) { lo = $2; rlo = $7 }
            if ($2 > c && (hi == "" || $2 < hi)) { hi = $2; rhi = $7 } }
        END {
            if (c == "nan") { print "no calibrated row"; exit }
            if (lo == "" || hi == "") { print "no search on each side of " c; exit }
            if (!(rlo < 0 && rhi > 0)) print "residuals " rlo " at " lo " and " rhi " at " hi " do not change sign"
            if (hi - lo > 0.02 * c) print "the bracket " lo " to " hi " is wider than 2 % of " c
            m = (lo + hi) / 2; if ((c - m) ^ 2 > (1e-9 * c) ^ 2) print c " is not the middle of " lo " to " hi
        }' "$T/bracket/calibrate_vcrit.csv")
    grep -q '^# the middle of the bracket' "$T/bracket/calibrate.csv" || why="$why no note of the bracket;"
    if [ -z "$why" ]; then pass calibrate_vcrit_bracket_closes; else fail calibrate_vcrit_bracket_closes "$why"; fi
else
    fail calibrate_vcrit_bracket_closes "exit status: $(tail -n 2 "$T/bracket.log")"
fi

# ---- 6. a size not bracketed in a search -----------------------------------------------------------------------------
sed -e 's/^v_low = .*/v_low = 1100/' "$T/cal.ini" >"$T/unbracketed.ini"
"$BIN" calibrate "$T/unbracketed.ini" -o "$T/unbracketed" >"$T/unbracketed.log" 2>&1
status=$?
if [ "$status" -ne 0 ] && grep -q 'at Gc = 300 the critical velocity of d = .* was not found in \[vcrit\] v_low to v_high' \
    "$T/unbracketed.log" && grep -q 'not bracketed' "$T/unbracketed/vcrit_01/vcrit.csv" &&
    ! grep -q ',1$' "$T/unbracketed/calibrate.csv" 2>/dev/null; then
    pass calibrate_vcrit_unbracketed_size
else
    fail calibrate_vcrit_unbracketed_size "exit $status: $(tail -n 1 "$T/unbracketed.log")"
fi

# ---- 7. the second parameter fitted too ------------------------------------------------------------------------------
sed -e 's/^velocities = .*/velocities = 700,725/' -e 's/^Gc_min = .*/Gc_min = 1000/' -e 's/^Gc_max = .*/Gc_max = 1600/' \
    -e 's/^fit_tolerance = .*/fit_tolerance = 15\nrate = fitted\nGc_rate_min = 2e10\nGc_rate_max = 1e11\nfit_spread_tolerance = 8/' \
    "$T/cal.ini" >"$T/rate.ini"
if "$BIN" calibrate "$T/rate.ini" -o "$T/rate" >"$T/rate.log" 2>&1; then
    pair=$(awk -F, 'NR == 2 && $3 == 1 { print $1, $2 }' "$T/rate/calibrate.csv")
    gc=${pair% *} rate=${pair#* }
    why=$(awk -F, -v g="${gc:-nan}" -v r="${rate:-nan}" '
        NR == 1 { next }
        $1 == 1 && !($2 == 1000 && $3 == 2e10) { print "search 1 at Gc " $2 ", Gc_rate " $3 }
        $3 < 2e10 || $3 > 1e11 { print "search " $1 " at Gc_rate " $3 " outside the range" }
        { key = $2 "," $4; if (key in v && rate_of[key] != $3 && v[key] != $5) moved = 1; v[key] = $5; rate_of[key] = $3 }
        # the second fit starts at the value the first fitted (its last search), not at an end of the range
        $3 == 2e10 { first_fit = $2 }
        $3 != 2e10 && second_start == "" { second_start = $2 }
        $2 == g && $3 == r { found = 1 }
        END {
            if (g == "nan") { print "no calibrated row"; exit }
            if (!(r > 2e10 && r < 1e11)) print "Gc_rate " r " not strictly inside 2e10-1e11"
            if (!(g >= 1000 && g <= 1600)) print "Gc " g " outside 1000-1600"
            if (!found) print "no search at the calibrated pair"
            if (!moved) print "no Gc searched at two Gc_rate with different v_crit"
            if (second_start != first_fit) print "the second fit starts at Gc " second_start ", the first fitted " first_fit
        }' "$T/rate/calibrate_vcrit.csv" | tr '\n' ';')
    if [ -n "$gc" ]; then
        {
            impact_section "Gc = $gc
Gc_rate = $rate"
            echo "diameters = 10e-6,8e-6"
        } >"$T/rate_check.ini"
        if "$BIN" vcrit "$T/rate_check.ini" -o "$T/rate_check" >"$T/rate_check.log" 2>&1; then
            why="$why$(awk -F, 'NR > 1 && !/^#/ { if ($1 + 0 == 1e-5) a = $2; else b = $2; n++ }
                END {
                    if (n != 2) { print "the check has " n " sizes"; exit }
                    m = (a - 700 + b - 725) / 2; s = (a - b) - (700 - 725)
                    if (m > 15 || m < -15) print "mean residual " m " m/s"
                    if (s > 8 || s < -8) print "spread residual " s " m/s"
                }' "$T/rate_check/vcrit.csv" | tr '\n' ';')"
        else
            why="$why the check search failed: $(tail -n 1 "$T/rate_check.log")"
        fi
    fi
    # the figure with its panel of the fits' spread residuals (render/calibrate_figures.c)
    [ -s "$T/rate/figures/calibrate_vcrit.png" ] || why="$why no figures/calibrate_vcrit.png;"
    if [ -z "$why" ]; then pass calibrate_vcrit_rate_fitted; else fail calibrate_vcrit_rate_fitted "$why"; fi
else
    fail calibrate_vcrit_rate_fitted "exit status: $(tail -n 2 "$T/rate.log")"
fi
# replayed from the searches' outputs, as in 2
cp "$T/rate/calibrate.csv" "$T/rate_first.csv"
rm -f "$T/rate/calibrate.csv" "$T/rate/calibrate.h5" "$T/rate/calibrate_vcrit.csv"
if "$BIN" calibrate "$T/rate.ini" -o "$T/rate" >"$T/rate_again.log" 2>&1 && cmp -s "$T/rate_first.csv" "$T/rate/calibrate.csv" &&
    ! grep -q 'vcrit: d = .* m/s .*: \(bonded\|rebounded\|unsettled\)' "$T/rate_again.log"; then
    pass calibrate_vcrit_rate_replay
else
    fail calibrate_vcrit_rate_replay "another calibrate.csv, impact runs made again or a failure: $(tail -n 1 "$T/rate_again.log")"
fi
sed -e 's/^velocities = .*/velocities = 700,760/' "$T/rate.ini" >"$T/rate_none.ini"
if "$BIN" calibrate "$T/rate_none.ini" -o "$T/rate_none" >"$T/rate_none.log" 2>&1 &&
    grep -q '^# no calibrated value: the spread residual has one sign over Gc_rate' "$T/rate_none/calibrate.csv" &&
    ! grep -q ',1$' "$T/rate_none/calibrate.csv"; then
    pass calibrate_vcrit_rate_no_root
else
    fail calibrate_vcrit_rate_no_root "$(tail -n 1 "$T/rate_none/calibrate.csv" 2>/dev/null) $(tail -n 1 "$T/rate_none.log")"
fi
exit 0
