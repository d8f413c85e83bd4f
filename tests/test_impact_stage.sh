#!/bin/sh
# shellcheck disable=SC2012 # ls lists files this test made, named without blanks
# The impact stage through the command line (docs/files.md, "impact.h5"): `spraycoat impact` on
# cases/impact_demo.ini (shortened to 10 ns) writes impact.h5 with /snapshots/NNNNNN, /series, /summary and
# /stats, and impact.xdmf naming only datasets that exist; 1 and 2 threads give identical datasets; a run
# stopped by SIGTERM (exit 143, after a checkpoint) or killed by SIGKILL and then continued with
# `spraycoat resume` ends with datasets identical to an uninterrupted run's; `info` shows a checkpoint and the
# results; a second `impact` of the same case does nothing; with `conduction = on` (heat exchanged whenever the
# time crosses a multiple of its interval) a SIGTERM and resume end identically too.
#
# "Identical": h5diff -d 0 of /snapshots, /series, /summary and /stats (groups compared object by object with
# their attributes; the root attributes `created` and `program_version` are left out, since Debian's h5diff 1.10
# cannot skip attributes, and case_hash is compared on its own).
# Run from the repository root with $SPRAYCOAT_BIN (tests/run_tests.sh sets both).  Needs h5ls, h5diff, h5dump.
set -u
. tests/wait_lib.sh

spraycoat_bin
DEMO=cases/impact_demo.ini

pass() { echo "PASS $1"; }
fail() { echo "FAIL $1 ($2)"; }

for tool in h5ls h5diff h5dump; do
    if ! command -v "$tool" >/dev/null 2>&1; then
        echo "FAIL impact_stage ($tool not found: install hdf5-tools)"
        exit 1
    fi
done
if [ ! -x "$BIN" ] || [ ! -r "$DEMO" ]; then
    echo "FAIL impact_stage (no $BIN or $DEMO; run from the repository root after make)"
    exit 1
fi

scratch_dir

# the demo shortened to 10 ns, a checkpoint every 40 steps (about 9 in the run), a snapshot every 2.5 ns
CASE=$T/impact_short.ini
sed -e 's/^t_end *=.*/t_end = 10e-9/' -e 's/^checkpoint_steps *=.*/checkpoint_steps = 40/' \
    -e 's/^snapshot_every *=.*/snapshot_every = 2.5e-9/' "$DEMO" >"$CASE"
if ! grep -q '^t_end = 10e-9$' "$CASE" || ! grep -q '^checkpoint_steps = 40$' "$CASE" ||
    ! grep -q '^snapshot_every = 2.5e-9$' "$CASE"; then
    echo "FAIL impact_stage ($DEMO no longer has the lines t_end, checkpoint_steps and snapshot_every this test rewrites)"
    exit 1
fi

datasets() { h5ls -r "$1" 2>/dev/null | awk '$2 == "Dataset" { print $1 }' | LC_ALL=C sort; }

# same_results DIR_A DIR_B: 0 when the two impact.h5 hold identical groups; else 1 with the reason in $differs
# (not $why, which the callers collect their other findings in: setting it here emptied those of section 5)
same_results() {
    differs=""
    for f in "$1/impact.h5" "$2/impact.h5"; do
        [ -f "$f" ] || { differs="$f does not exist"; return 1; }
    done
    datasets "$1/impact.h5" >"$T/names_a"
    datasets "$2/impact.h5" >"$T/names_b"
    if ! cmp -s "$T/names_a" "$T/names_b"; then
        differs="the dataset names differ: $(diff "$T/names_a" "$T/names_b" | grep '^[<>]' | head -n 4 | tr '\n' ' ')"
        return 1
    fi
    for group in /snapshots /series /summary /stats; do
        if ! h5diff -d 0 "$1/impact.h5" "$2/impact.h5" "$group" "$group" >"$T/h5diff.out" 2>&1; then
            differs="$group differs: $(grep -v '^$' "$T/h5diff.out" | head -n 6 | tr '\n' ' ')"
            return 1
        fi
    done
    return 0
}

root_attribute() { h5dump -a "/$2" "$1" 2>&1 | grep '(0)'; }

# verdict_words RUN_DIR: an extended regular expression of the particle's (body 1's) verdict and settling as the
# logs and info print them, from impact.h5 /summary/verdict and t_settled: the printed words must be the stored ones
# (0 rebounded, or held when at rest; 1 bonded; 2 unsettled; t_settled NaN: not settled)
verdict_words() {
    verdict=$(h5dump -y -w 0 -d /summary/verdict "$1/impact.h5" 2>/dev/null | sed -n '/DATA {/,/}/p' | sed '1d;$d' |
        tr ',' '\n' | awk 'NF { n++ } n == 2 { print $1; exit }')
    t_settled=$(h5dump -y -w 0 -d /summary/t_settled "$1/impact.h5" 2>/dev/null | sed -n '/DATA {/,/}/p' | sed '1d;$d' |
        tr ',' '\n' | awk 'NF { n++ } n == 2 { print $1; exit }')
    case $verdict in
    0) words='(rebounded|held)' ;;
    1) words='bonded' ;;
    2) words='unsettled' ;;
    *) words="no verdict '$verdict' in $1/impact.h5" ;;
    esac
    case $t_settled in
    nan | NaN | -nan) echo "$words \\(not settled" ;;
    *) echo "$words \\(settled at" ;;
    esac
}

checkpoint_count() { ls "$1"/checkpoints/impact_*.h5 2>/dev/null | wc -l | tr -d ' '; }

# Poll until RUN_DIR $1 holds at least $2 impact checkpoints (1 when the program ended first or 60 s passed).
checkpoints_at_least() {
    [ "$(checkpoint_count "$1")" -ge "$2" ]
}
wait_for_checkpoints() {
    wait_until "$bg" 60 checkpoints_at_least "$1" "$2"
}

# Runs use one thread except the comparison with two: on a busy 2-core machine the OpenMP barriers of a
# 2-thread run can wait for a descheduled thread at every parallel region and run many times slower.
# ---- 1. the reference run (1 thread) --------------------------------------------------------------------------
REF=$T/ref
if "$BIN" impact "$CASE" -o "$REF" --threads 1 >"$T/ref.log" 2>&1; then
    why=""
    for d in /snapshots/000000/x /snapshots/000000/eps_p /series/t /series/pbcp /summary/bonded /summary/pbcp \
        /summary/v_rest; do
        h5ls "$REF/impact.h5$d" >/dev/null 2>&1 || why="$why no $d;"
    done
    h5ls "$REF/impact.h5/stats" >/dev/null 2>&1 || why="$why no /stats;"
    [ -d "$REF/impact_snapshots" ] && why="$why the snapshot folder was left behind;"
    [ "$(checkpoint_count "$REF")" -eq 0 ] || why="$why checkpoints were left behind;"
    [ "$(cat "$REF/stages" 2>/dev/null)" = impact ] || why="$why RUN_DIR/stages does not say impact;"
    snapshots=$(h5ls "$REF/impact.h5/snapshots" 2>/dev/null | wc -l | tr -d ' ')
    [ "$snapshots" -ge 4 ] || why="$why $snapshots snapshots, expected at least 4 (0, 2.5, 5, 7.5, 10 ns);"
    if [ -z "$why" ]; then pass impact_stage_outputs; else fail impact_stage_outputs "$why"; fi
else
    fail impact_stage_outputs "spraycoat impact exited with status $?: $(tail -n 3 "$T/ref.log" | tr '\n' ' ')"
    exit 1
fi

# ---- 2. impact.xdmf names only datasets of impact.h5, one grid per snapshot, times ascending -----------------
why=""
xdmf=$REF/impact.xdmf
if [ ! -s "$xdmf" ]; then
    why="no $xdmf"
else
    sed -n 's|.*>impact\.h5:\([^<]*\)<.*|\1|p' "$xdmf" | sort -u >"$T/xdmf_paths"
    [ -s "$T/xdmf_paths" ] || why="$why no impact.h5 dataset named;"
    while read -r path; do
        h5ls "$REF/impact.h5$path" 2>/dev/null | grep -q Dataset || why="$why $path is not a dataset of impact.h5;"
    done <"$T/xdmf_paths"
    grids=$(grep -c '<Grid Name="[0-9]*" GridType="Uniform"' "$xdmf")
    [ "$grids" -eq "$snapshots" ] || why="$why $grids grids for $snapshots snapshots;"
    # each grid's point count is the size of its x dataset
    sed -n 's|.*Dimensions="\([0-9]*\) 3".*impact\.h5:\(/snapshots/[0-9]*\)/x<.*|\1 \2|p' "$xdmf" >"$T/xdmf_sizes"
    while read -r n group; do
        actual=$(h5ls "$REF/impact.h5$group/x" | sed -n 's/.*Dataset {\([0-9]*\), 3}.*/\1/p')
        [ "$actual" = "$n" ] || why="$why $group/x holds $actual points, the index says $n;"
    done <"$T/xdmf_sizes"
    sed -n 's|.*<Time Value="\([^"]*\)"/>.*|\1|p' "$xdmf" >"$T/times"
    sort -g "$T/times" | cmp -s - "$T/times" || why="$why the Time values are not ascending;"
fi
if [ -z "$why" ]; then pass impact_stage_xdmf; else fail impact_stage_xdmf "$why"; fi

# ---- 3. two threads give the same datasets --------------------------------------------------------------------
if "$BIN" impact "$CASE" -o "$T/two" --threads 2 >"$T/two.log" 2>&1 && same_results "$REF" "$T/two"; then
    pass impact_stage_threads_1_vs_2
else
    fail impact_stage_threads_1_vs_2 "${differs:-spraycoat impact --threads 2 failed: $(tail -n 2 "$T/two.log" | tr '\n' ' ')}"
fi

# ---- 4. a second run of the same case in the same folder does nothing -----------------------------------------
cp -p "$REF/impact.h5" "$T/impact.h5.before"
if "$BIN" impact "$CASE" -o "$REF" --threads 1 >"$T/again.log" 2>&1 && grep -q 'up to date' "$T/again.log" &&
    cmp -s "$REF/impact.h5" "$T/impact.h5.before"; then
    pass impact_stage_skips_when_done
else
    fail impact_stage_skips_when_done "$(tail -n 2 "$T/again.log" | tr '\n' ' ')"
fi

# ---- 5. SIGTERM after a checkpoint: exit 143, info shows the checkpoint, resume finishes identically ---------
RUN=$T/term
"$BIN" impact "$CASE" -o "$RUN" --threads 1 >"$T/term.log" 2>&1 &
bg=$!
if wait_for_checkpoints "$RUN" 2; then
    kill -TERM "$bg"
    wait "$bg" 2>/dev/null
    status=$?
    bg=""
    why=""
    [ "$status" -eq 143 ] || why="$why exit status $status, expected 143;"
    [ -f "$RUN/impact.h5" ] && why="$why impact.h5 exists after the interruption;"
    [ "$(checkpoint_count "$RUN")" -ge 1 ] || why="$why no checkpoint left;"
    "$BIN" info "$RUN" >"$T/info.log" 2>&1 || why="$why info failed;"
    grep -q 'stage impact: interrupted' "$T/info.log" || why="$why info does not say the stage was interrupted;"
    grep -q 'impact checkpoint' "$T/info.log" && grep -q '^  step ' "$T/info.log" ||
        why="$why info shows no checkpoint step;"
    if ! "$BIN" resume "$RUN" >"$T/resume.log" 2>&1; then
        why="$why resume failed: $(tail -n 2 "$T/resume.log" | tr '\n' ' ');"
    elif ! grep -q 'resuming from' "$T/resume.log"; then
        why="$why resume did not start from a checkpoint;"
    elif ! grep -Eq "^  body 1 \\(d .*\\): $(verdict_words "$RUN")" "$T/resume.log"; then
        why="$why resume's closing summary does not give the particle's stored verdict ($(verdict_words "$RUN")): $(grep -A 2 '^results in' "$T/resume.log" | tr '\n' ' ');"
    elif ! same_results "$REF" "$RUN"; then
        why="$why after resume: $differs;"
    fi
    [ "$(root_attribute "$RUN/impact.h5" case_hash)" = "$(root_attribute "$REF/impact.h5" case_hash)" ] ||
        why="$why case_hash differs;"
    [ -d "$RUN/impact_snapshots" ] && why="$why the snapshot folder was left behind;"
    if [ -z "$why" ]; then pass impact_stage_sigterm_resume; else fail impact_stage_sigterm_resume "$why"; fi
else
    wait "$bg" 2>/dev/null
    bg=""
    fail impact_stage_sigterm_resume "the run ended before its second checkpoint: $(tail -n 2 "$T/term.log" | tr '\n' ' ')"
fi

# ---- 6. info on a finished run shows the per-body summary --------------------------------------------------------
if "$BIN" info "$RUN" >"$T/info.log" 2>&1 && grep -q 'stage impact: done' "$T/info.log" &&
    grep -q 'summary (per body)' "$T/info.log" && grep -Eq "^  1 +particle .* $(verdict_words "$RUN" | sed 's/ .*//') " "$T/info.log" &&
    "$BIN" info "$RUN/impact.h5" >"$T/info2.log" 2>&1 && grep -q 'summary (per body)' "$T/info2.log"; then
    pass impact_stage_info
    # an unsettled particle's numbers are marked as the last values, not a result
    case $(verdict_words "$RUN") in
    unsettled*)
        if grep -q '^  unsettled: no verdict by the end of the run; its PBCP, v_rest and CoR are the last values' "$T/info.log"; then
            pass impact_stage_info_unsettled_marked
        else
            fail impact_stage_info_unsettled_marked "no note under the table: $(grep -A 4 'summary (per body)' "$T/info.log" | tr '\n' ' ')"
        fi
        ;;
    esac
else
    fail impact_stage_info "$(head -c 400 "$T/info.log" | tr '\n' ' ')"
fi

# ---- 6b. the summary stores its verdict thresholds; info calls a particle at rest without enough bonds "held" -----
# A tiny run whose verdict settles within its 10 ns (the settling keys of tests/test_vcrit.sh) and can never be
# bonded (PBCP must reach 100 %), judged against a v_rest threshold no motion exceeds: a settled "rebounded" at rest.
cat >"$T/held.ini" <<EOF
[run]
threads = 1
[impact]
grid = 2e-6
spacing = 1e-6
diameter = 8e-6
velocity = 200
substrate_diameter = 20e-6
substrate_height = 6e-6
t_end = 10e-9
snapshot_every = 1
settle_window = 2e-9
settle_vcom = 1e4
settle_pbcp = 1
vrest_filter = 1e4
pbcp_threshold = 1
vrest_threshold = 1e4
[material.aluminium]
EOF
summary_attribute() { h5dump -a "/summary/$2" "$1" 2>/dev/null | sed -n 's/^ *(0): *//p'; }
if "$BIN" impact "$T/held.ini" -o "$T/held" -q >"$T/held.log" 2>&1 && "$BIN" info "$T/held" >"$T/held_info.log" 2>&1; then
    why=""
    [ "$(summary_attribute "$T/held/impact.h5" pbcp_threshold)" = 1 ] || why="$why /summary pbcp_threshold is not 1;"
    [ "$(summary_attribute "$T/held/impact.h5" vrest_threshold)" = 10000 ] || why="$why /summary vrest_threshold is not 10000;"
    grep -Eq '^ +1 +particle .* held ' "$T/held_info.log" || why="$why info does not call the particle held;"
    grep -q 'held: not bonded, at rest (v_rest <= 10000 m/s) but PBCP under 100 %' "$T/held_info.log" ||
        why="$why no legend for held;"
    if [ -z "$why" ]; then pass impact_stage_info_held; else fail impact_stage_info_held "$why $(tail -n 3 "$T/held_info.log" | tr '\n' ' ')"; fi
else
    fail impact_stage_info_held "$(tail -n 3 "$T/held.log" | tr '\n' ' ')"
fi

# ---- 7. SIGKILL mid-run (after some checkpoints, at a moment that is not a checkpoint), then resume ------------
RUN=$T/kill
"$BIN" impact "$CASE" -o "$RUN" --threads 1 >"$T/kill.log" 2>&1 &
bg=$!
if wait_for_checkpoints "$RUN" 3; then
    sleep 0.1
    kill -9 "$bg" 2>/dev/null
    wait "$bg" 2>/dev/null
    bg=""
    why=""
    if [ -f "$RUN/impact.h5" ]; then
        echo "  note: the run finished before SIGKILL arrived"
    fi
    if ! "$BIN" resume "$RUN" >"$T/resume2.log" 2>&1; then
        why="resume failed: $(tail -n 2 "$T/resume2.log" | tr '\n' ' ')"
    elif ! same_results "$REF" "$RUN"; then
        why="after resume: $differs"
    fi
    if [ -z "$why" ]; then pass impact_stage_sigkill_resume; else fail impact_stage_sigkill_resume "$why"; fi
else
    wait "$bg" 2>/dev/null
    bg=""
    fail impact_stage_sigkill_resume "the run ended before its third checkpoint: $(tail -n 2 "$T/kill.log" | tr '\n' ' ')"
fi

# ---- 8. SIGKILL before the first checkpoint: resume starts over and still ends identically -----------------------
RUN=$T/early
"$BIN" impact "$CASE" -o "$RUN" --threads 1 >"$T/early.log" 2>&1 &
bg=$!
i=0
while [ ! -f "$RUN/impact_snapshots/000000.h5" ] && [ "$i" -lt 400 ] && kill -0 "$bg" 2>/dev/null; do
    sleep 0.05
    i=$((i + 1))
done
kill -9 "$bg" 2>/dev/null
wait "$bg" 2>/dev/null
bg=""
# what a kill inside a write leaves: a half-written snapshot of a later index and a half-written impact.h5
printf 'half' >"$RUN/impact_snapshots/000001.h5.tmp" 2>/dev/null
printf 'half' >"$RUN/impact.h5.tmp"
differs=""
if "$BIN" resume "$RUN" >"$T/resume3.log" 2>&1 && same_results "$REF" "$RUN"; then
    pass impact_stage_early_kill_resume
else
    fail impact_stage_early_kill_resume "${differs:-resume failed: $(tail -n 2 "$T/resume3.log" | tr '\n' ' ')}"
fi

# ---- 9. conduction = on: its exchanges are decided by the time alone, so a SIGTERM and resume end identically --
CONDUCTION=$T/conduction.ini
sed 's/^\[impact\]$/[impact]\nconduction = on/' "$CASE" >"$CONDUCTION"
problem=""
"$BIN" impact "$CONDUCTION" -o "$T/cref" --threads 1 >"$T/cref.log" 2>&1 || problem="the uninterrupted run failed;"
grep -q 'heat conduction within' "$T/cref.log" || problem="$problem the log does not say conduction is on;"
same_results "$REF" "$T/cref" && problem="$problem the results equal the adiabatic run's;"
why=$problem
RUN=$T/cterm
"$BIN" impact "$CONDUCTION" -o "$RUN" --threads 1 >"$T/cterm.log" 2>&1 &
bg=$!
if [ -z "$why" ] && wait_for_checkpoints "$RUN" 2; then
    kill -TERM "$bg"
    wait "$bg" 2>/dev/null
    bg=""
    if ! "$BIN" resume "$RUN" >"$T/cresume.log" 2>&1 || ! grep -q 'resuming from' "$T/cresume.log"; then
        why="resume did not finish from a checkpoint: $(tail -n 2 "$T/cresume.log" | tr '\n' ' ')"
    elif ! same_results "$T/cref" "$RUN"; then
        why="after resume: $differs"
    fi
else
    wait "$bg" 2>/dev/null
    bg=""
    why="${why:-the run ended before its second checkpoint}"
fi
if [ -z "$why" ]; then pass impact_stage_conduction_resume; else fail impact_stage_conduction_resume "$why"; fi
exit 0
