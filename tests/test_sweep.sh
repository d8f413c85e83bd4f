#!/bin/sh
# `spraycoat sweep` on a tiny case (2 x 2 spray runs of 300 steps, 200 particles each: a few seconds here):
# sweep.h5's maps of the deposition efficiency (DE by mass) and the mean impact speed hold, entry for entry, the
# values of each run's own spray.h5, and the runs differ; its axes hold the values in SI (0.7 km/s is 700); the run of one grid point equals a `spraycoat spray` of a
# case file with those values written in it (the sweep sets the keys as the file would); a second sweep runs
# nothing; after a run's spray.h5 is removed, only that run is made again and the map is the same; `resume`
# continues a sweep, also one stopped by SIGTERM in a run (from that run's checkpoint, to the same map); bad
# [sweep] keys and values are refused with exit status 2 before the run directory is made; a key that takes a
# number or a word (contact.restitution: johnson) is swept with a NaN on the axis for the word; the case file
# edited while a sweep runs changes none of its runs (they are made from the case the sweep loaded); a file the case
# names (the v_crit table) edited while it runs stops it with exit 2, and put back the sweep finishes to the same map.
# Prints "PASS name" / "FAIL name (reason)".  Run from the repository root with $SPRAYCOAT_BIN (tests/run_tests.sh
# sets it).  Needs h5dump.
set -u
. tests/wait_lib.sh

spraycoat_bin
# the energy model's v_crit(d) (lower than the shipped table's), under which the short spray's runs deposit some
# particles at every grid point, so the maps have something to show
TABLE=$(pwd)/cases/vcrit_al_energy.csv

pass() { echo "PASS $1"; }
fail() { echo "FAIL $1 ($2)"; }

if [ ! -x "$BIN" ] || [ ! -r "$TABLE" ] || ! command -v h5dump >/dev/null 2>&1; then
    echo "FAIL sweep (no $BIN, $TABLE or h5dump; run from the repository root after make)"
    exit 1
fi
scratch_dir

# write_case FILE C1 RELEASE_MAX [SWEEP_LINES]: the demo's spray, shortened
write_case() {
    cat >"$1" <<EOF
[run]
seed = 7
[spray]
dt = 1e-6
t_end = 0.3e-3
feed_count = 10
feed_every = 5
max_injected = 200
nozzle_radius = 0.003
release_speed_min = 600
release_speed_max = $3
release_cone = 1
domain_radius = 0.02
handoff_height = 0.003
metrics_every = 50
[powder]
distribution = weibull
median_diameter = 20e-6
shape = 3.5
d_min = 10e-6
d_max = 30e-6
density = 2700
[target]
standoff = 0.03
deposit_radius = 0.004
[jet]
C1 = $2
C3 = 40
virtual_origin = 0.05
core_length = 0.002
[deposition]
rule = table
table = $TABLE
$4
EOF
}

# values FILE DATASET: every value of a dataset, one a line, as %.17g
values() { h5dump -d "$2" -y -w 0 -m %.17g "$1" 2>/dev/null | awk '/^ *DATA \{/{on=1; next} on && /\}/{exit} on {gsub(/[ ,]/, ""); print}'; }

SWEEP="[sweep]
x_key = jet.C1
x_values = 250, 350
y_key = spray.release_speed_max
y_values = 0.7 km/s, 900"
write_case "$T/sweep.ini" 320 800 "$SWEEP"
R=$T/run
"$BIN" sweep "$T/sweep.ini" -o "$R" >"$T/log1" 2>&1
status=$?

# 1. the map against each run's own spray.h5 (row j = y value j, column i = x value i)
map_ok=1
reason=""
if [ $status -ne 0 ] || [ ! -r "$R/sweep.h5" ]; then
    map_ok=0
    reason="exit $status: $(tail -n 3 "$T/log1")"
else
    values "$R/sweep.h5" /de >"$T/map_de"
    values "$R/sweep.h5" /mean_impact_speed >"$T/map_speed"
    : >"$T/runs_de"
    : >"$T/runs_speed"
    for run in x0_y0 x1_y0 x0_y1 x1_y1; do
        values "$R/runs/$run/spray.h5" /deposition_efficiency/de >>"$T/runs_de"
        values "$R/runs/$run/spray.h5" /deposition_efficiency/mean_impact_speed >>"$T/runs_speed"
    done
    if [ "$(wc -l <"$T/map_de")" -ne 4 ] || ! cmp -s "$T/map_de" "$T/runs_de"; then
        map_ok=0
        reason="map DE $(tr '\n' ' ' <"$T/map_de") != runs $(tr '\n' ' ' <"$T/runs_de")"
    elif ! cmp -s "$T/map_speed" "$T/runs_speed"; then
        map_ok=0
        reason="map speed $(tr '\n' ' ' <"$T/map_speed") != runs $(tr '\n' ' ' <"$T/runs_speed")"
    elif [ "$(values "$R/sweep.h5" /x_values | tr '\n' ' ')" != "250 350 " ] ||
        [ "$(values "$R/sweep.h5" /y_values | tr '\n' ' ')" != "700 900 " ]; then
        map_ok=0
        reason="axes $(values "$R/sweep.h5" /x_values | tr '\n' ' ') and $(values "$R/sweep.h5" /y_values | tr '\n' ' '), expected 250 350 and 700 900 (0.7 km/s in SI)"
    elif [ "$(sort -u "$T/map_de" | wc -l)" -lt 4 ]; then
        map_ok=0
        reason="the four runs give DEs $(tr '\n' ' ' <"$T/map_de"): the keys did not change the runs"
    fi
    # each run's own case holds its grid point's values (run xI_yJ: x value I, y value J), so that a transposed
    # grid (run xI_yJ made with point (J, I)'s values) fails above: the map against the runs is by name only
    for run in x0_y0:250:0.7 x1_y0:350:0.7 x0_y1:250:900 x1_y1:350:900; do
        set -- $(echo "$run" | tr ':' ' ')
        grep -q "^C1 = $2\$" "$R/runs/$1/case.ini" 2>/dev/null &&
            grep -q "^release_speed_max = $3" "$R/runs/$1/case.ini" 2>/dev/null || {
            map_ok=0
            reason="$reason runs/$1/case.ini: $(grep -E '^(C1|release_speed_max) =' "$R/runs/$1/case.ini" 2>/dev/null | tr '\n' ' '), expected C1 = $2 and release_speed_max = $3;"
        }
    done
fi
[ $map_ok = 1 ] && pass sweep_map_is_the_runs || fail sweep_map_is_the_runs "$reason"

# 2. grid point (1, 1) is the spray of a case file with C1 = 350 and release_speed_max = 900
write_case "$T/point.ini" 350 900 ""
"$BIN" spray "$T/point.ini" -o "$T/point" >"$T/log_point" 2>&1
point=$(values "$T/point/spray.h5" /deposition_efficiency/de)
swept=$(sed -n 4p "$T/map_de" 2>/dev/null)
if [ -n "$point" ] && [ "$point" = "$swept" ]; then
    pass sweep_point_is_a_spray_run
else
    fail sweep_point_is_a_spray_run "spray of the case file: DE '$point'; the sweep's entry: '$swept'"
fi

# 3. nothing twice: a second sweep runs nothing; a removed run is made again, alone, with the same map
"$BIN" sweep "$T/sweep.ini" -o "$R" >"$T/log2" 2>&1
again=$?
rm -f "$R/runs/x0_y1/spray.h5" "$R/sweep.h5"
"$BIN" sweep "$T/sweep.ini" -o "$R" >"$T/log3" 2>&1
redo=$?
values "$R/sweep.h5" /de >"$T/map_de3" 2>/dev/null
made=$(grep -c "spray: wrote" "$T/log3")
if [ $again -eq 0 ] && ! grep -q "spray: wrote\|sweep: run " "$T/log2" && grep -q "up to date" "$T/log2" &&
    [ $redo -eq 0 ] && [ "$made" -eq 1 ] && grep -q "spray: wrote .*x0_y1/spray.h5" "$T/log3" &&
    cmp -s "$T/map_de" "$T/map_de3"; then
    pass sweep_restart
else
    fail sweep_restart "second sweep exit $again, $(grep -c 'spray: wrote' "$T/log2") runs made; after removing one: exit $redo, $made runs made, map $(tr '\n' ' ' <"$T/map_de3")"
fi

# 4. resume continues a sweep (stages: sweep,render), here with nothing left to do, and ends with the map as `run` does
rm -f "$R/sweep.h5"
"$BIN" resume "$R" >"$T/log4" 2>&1
resumed=$?
if [ $resumed -eq 0 ] && grep -q "stages sweep" "$T/log4" && [ -r "$R/sweep.h5" ] &&
    ! grep -q "spray: wrote" "$T/log4" && grep -q "^sweep over" "$T/log4"; then
    pass sweep_resume
else
    fail sweep_resume "exit $resumed: $(tail -n 2 "$T/log4")"
fi

# 5. bad [sweep] keys and values: exit 2 naming the key, nothing written
bad() { # bad NAME SWEEP_LINES EXPECTED_TEXT
    write_case "$T/bad.ini" 320 800 "$2"
    "$BIN" sweep "$T/bad.ini" -o "$T/bad_run" >"$T/log_bad" 2>&1
    code=$?
    if [ $code -eq 2 ] && grep -q "$3" "$T/log_bad" && [ ! -e "$T/bad_run" ]; then
        pass "sweep_refuses_$1"
    else
        fail "sweep_refuses_$1" "exit $code, run directory $([ -e "$T/bad_run" ] && echo made || echo absent): $(tail -n 1 "$T/log_bad")"
    fi
    rm -rf "$T/bad_run"
}
bad unknown_key "[sweep]
x_key = jet.C9
x_values = 1, 2" "\[sweep\] x_key.*not a case key"
bad key_without_effect "[sweep]
x_key = run.threads
x_values = 1, 2" "\[sweep\] x_key.*does not change"
bad release_speed_with_nozzle "[nozzle]
gas = n2
[sweep]
x_key = spray.release_speed_max
x_values = 700, 900" "\[sweep\] x_key.*release_speed_max does not change the spray's results with \[nozzle\]"
bad key_of_another_stage "[sweep]
x_key = impact.grid
x_values = 1e-6, 2e-6" "\[sweep\] x_key.*does not change"
bad bad_value "[sweep]
x_key = jet.C1
x_values = 250, fast" "bad.ini:[0-9][0-9]*: \[sweep\] x_values value 2.*\[jet\] C1"
bad value_out_of_range "[sweep]
x_key = spray.release_speed_max
x_values = 700, 2e5" "x_values value 2.*\[spray\] release_speed_max"
bad cross_key_check_names_the_run "[sweep]
x_key = target.standoff
x_values = 0.03, 0.001" "\[spray\] handoff_height.*not below the standoff.*(sweep run runs/x1_y0: \[target\] standoff = 0.001)"
bad values_without_key "[sweep]
x_key = jet.C1
x_values = 250
y_values = 1, 2" "\[sweep\] y_key"

# 6. a sweep stopped by SIGTERM in a run (after a checkpoint) exits 143, says to resume the sweep's directory (the
# run's own finished that run only), `info` counts its runs done and interrupted, and `resume` of it finishes the
# sweep with the same map
sed 's/^seed = 7$/seed = 7\ncheckpoint_steps = 50/' "$T/sweep.ini" >"$T/term.ini"
"$BIN" sweep "$T/term.ini" -o "$T/term" >"$T/log_term" 2>&1 &
bg=$!
wait_until "$bg" 30 exists "$T/term/runs/*/checkpoints/spray_*.h5"
kill -TERM "$bg" 2>/dev/null
wait "$bg"
term=$?
bg=""
# `info` of the stopped sweep counts its runs (it said "not done" alone: the checkpoints are the runs')
"$BIN" info "$T/term" >"$T/info_term" 2>&1
done_runs=$(ls "$T"/term/runs/*/spray.h5 2>/dev/null | wc -l)
"$BIN" resume "$T/term" >"$T/log_term_resume" 2>&1
resumed=$?
values "$T/term/sweep.h5" /de >"$T/map_de_term" 2>/dev/null
if [ $term -eq 143 ] && [ $resumed -eq 0 ] && cmp -s "$T/map_de" "$T/map_de_term" &&
    grep -q "^  $done_runs runs done, 1 interrupted (RUN_DIR/runs/" "$T/info_term" &&
    grep -q "spray: resuming from .*runs/x[01]_y[01]/checkpoints/spray_" "$T/log_term_resume" &&
    grep -q "continue with \`spraycoat resume $T/term\`" "$T/log_term"; then
    pass sweep_interrupted_and_resumed
else
    fail sweep_interrupted_and_resumed "sweep exit $term (143 expected), resume exit $resumed, map $(tr '\n' ' ' <"$T/map_de_term"); $(grep -o 'continue with .*' "$T/log_term"); info: $(grep 'runs done\|stage sweep' "$T/info_term" | tr '\n' ' ')"
fi

# 7. a key that takes a number or a word other than auto ([contact] restitution: a number or johnson): every run
# finishes and the map is written, the word's axis value NaN (case_is(..., "auto") aborted on it after the runs)
write_case "$T/rest.ini" 320 800 "[sweep]
x_key = contact.restitution
x_values = 0.3, 0.5, johnson"
"$BIN" sweep "$T/rest.ini" -o "$T/rest" >"$T/log_rest" 2>&1
rest=$?
axis=$(values "$T/rest/sweep.h5" /x_values | tr '\n' ' ')
if [ $rest -eq 0 ] && [ -r "$T/rest/sweep.h5" ] && [ "$axis" = "0.29999999999999999 0.5 nan " ]; then
    pass sweep_over_a_number_or_word_key
else
    fail sweep_over_a_number_or_word_key "exit $rest, x_values '$axis': $(tail -n 2 "$T/log_rest")"
fi

# edit_while_stopped NAME EDIT...: the sweep of $T/NAME.ini into $T/NAME (log $T/log_NAME) in the background, stopped
# (SIGSTOP) once its first run wrote a checkpoint, EDIT run, then continued to its end; started: the runs begun when
# EDIT ran, finished: the sweep's exit status.
edit_while_stopped() {
    name=$1
    shift
    "$BIN" sweep "$T/$name.ini" -o "$T/$name" >"$T/log_$name" 2>&1 &
    bg=$!
    wait_until "$bg" 30 exists "$T/$name/runs/x0_y0/checkpoints/spray_*.h5"
    kill -STOP "$bg"
    started=$(ls "$T/$name/runs" 2>/dev/null | tr '\n' ' ')
    "$@"
    kill -CONT "$bg"
    wait "$bg"
    finished=$?
    bg=""
}

# 8. the runs are made from the case the sweep loaded: the case file edited while the first run goes (here [jet] C3)
# reaches no run, and the map is the unedited sweep's (each run read the file again: the later runs were another
# case's, under the first case's hash, and a later sweep found them up to date).  The sweep is stopped (SIGSTOP)
# while the file is edited, so that the edit always lands before the later runs start (the runs go one after the
# other); the test fails rather than passes when it did not.
sed 's/^seed = 7$/seed = 7\ncheckpoint_steps = 50/' "$T/sweep.ini" >"$T/edit.ini"
edit_while_stopped edit sed -i 's/^C3 = 40$/C3 = 41/' "$T/edit.ini"
edited=$finished
values "$T/edit/sweep.h5" /de >"$T/map_de_edit" 2>/dev/null
mixed=$(grep -l '^C3 = 41' "$T"/edit/runs/*/case.ini 2>/dev/null | tr '\n' ' ')
if [ "$started" != "x0_y0 " ]; then
    fail sweep_runs_ignore_an_edited_case_file "the runs '$started' had started when the case file was edited (only x0_y0 should have)"
elif [ $edited -eq 0 ] && [ -z "$mixed" ] && cmp -s "$T/map_de" "$T/map_de_edit"; then
    pass sweep_runs_ignore_an_edited_case_file
else
    fail sweep_runs_ignore_an_edited_case_file "exit $edited; runs of the edited file: '$mixed'; map $(tr '\n' ' ' <"$T/map_de_edit")"
fi

# 9. a file the case names (here the v_crit table) edited while the sweep runs stops it with exit 2 before the next
# run rather than mixing two tables in one map (each run's hash holds the contents it read, the map's the first:
# with the file put back, the map was up to date with a run of the edited table in it); put back, the sweep
# finishes with the unedited sweep's map.  Stopped (SIGSTOP) while the file is edited, as in 8.
cp "$TABLE" "$T/table.csv"
sed -e 's/^seed = 7$/seed = 7\ncheckpoint_steps = 50/' -e "s|^table = .*|table = $T/table.csv|" "$T/sweep.ini" >"$T/table.ini"
edit_while_stopped table sed -i 's/^1e-05,803.125,/1e-05,603.125,/' "$T/table.csv"
stopped=$finished
cmp -s "$TABLE" "$T/table.csv" && stopped="the table was not edited"
cp "$TABLE" "$T/table.csv"
"$BIN" sweep "$T/table.ini" -o "$T/table" >"$T/log_table_again" 2>&1
again=$?
values "$T/table/sweep.h5" /de >"$T/map_de_table" 2>/dev/null
if [ "$started" != "x0_y0 " ]; then
    fail sweep_stops_when_a_named_file_changes "the runs '$started' had started when the table was edited (only x0_y0 should have)"
elif [ "$stopped" = 2 ] && grep -q 'changed while the sweep ran' "$T/log_table" && [ ! -e "$T/table/sweep.h5.tmp" ] &&
    [ $again -eq 0 ] && cmp -s "$T/map_de" "$T/map_de_table"; then
    pass sweep_stops_when_a_named_file_changes
else
    fail sweep_stops_when_a_named_file_changes "exit $stopped with the table edited ($(grep -i error "$T/log_table" | head -n 1)); put back: exit $again, map $(tr '\n' ' ' <"$T/map_de_table")"
fi

# 10. the figures follow sweep.h5: a pipeline of sweep,render run again with other x values draws the map again
# (render's fingerprint left sweep.h5 out: "up to date", the old map's figure kept), and `render` of the first case
# over the second's sweep.h5 is refused, exit 3, as for its other inputs (it drew the other case's map under this
# case's keys), and `info` marks an output of another case
cp -r "$R" "$T/figs"
why=""
"$BIN" run "$T/sweep.ini" --stages sweep,render -o "$T/figs" >"$T/log10a" 2>&1 || why="$why first pipeline exit $?;"
first=$(md5sum <"$T/figs/figures/sweep_de.png" 2>/dev/null)
sed 's/^x_values = 250, 350$/x_values = 250, 300/' "$T/sweep.ini" >"$T/sweep_b.ini"
"$BIN" run "$T/sweep_b.ini" --stages sweep,render -o "$T/figs" >"$T/log10b" 2>&1 || why="$why second pipeline exit $?;"
grep -q 'render: the figures .* are up to date' "$T/log10b" && why="$why render found the figures up to date;"
[ -n "$first" ] && [ "$first" != "$(md5sum <"$T/figs/figures/sweep_de.png" 2>/dev/null)" ] ||
    why="$why sweep_de.png unchanged (or missing);"
"$BIN" render "$T/sweep.ini" -o "$T/figs" >"$T/log10c" 2>&1
code=$?
[ $code -eq 3 ] && grep -q 'sweep.h5 was made by another case' "$T/log10c" ||
    why="$why render of the first case over the second's sweep.h5: exit $code, $(tail -n 1 "$T/log10c");"
# refused, it leaves the run directory as it was: case.ini still the second case's (it was written over first)
grep -q '^x_values = 250, 300$' "$T/figs/case.ini" || why="$why the refused render wrote its case.ini: $(grep '^x_values' "$T/figs/case.ini");"
# and `info` of a run directory whose case.ini is the first case's (a run of it stopped before its sweep.h5) says
# that the second's sweep.h5 is another case's, not "done" alone
cp -r "$T/figs" "$T/figs_a" && cp "$R/case.ini" "$T/figs_a/case.ini"
"$BIN" info "$T/figs_a" >"$T/info10" 2>&1
grep -q '^stage sweep: done (of another case than' "$T/info10" || why="$why info: $(grep '^stage sweep' "$T/info10");"
"$BIN" info "$T/figs" >"$T/info10b" 2>&1
grep -q '^stage sweep: done$' "$T/info10b" || why="$why info of the second case's own directory: $(grep '^stage sweep' "$T/info10b");"
if [ -z "$why" ]; then pass sweep_figures_follow_the_map; else fail sweep_figures_follow_the_map "$why"; fi

# 10b. the report of the sweep shows its map (figure sweep_de: it was drawn and never linked) and a table of every
# run's DE and mean impact speed, as sweep.h5 holds them (the page had an empty result and no figure)
why=""
grep -q '<img src="figures/sweep_de.png"' "$T/figs/report.html" || why="no sweep_de figure in the report;"
rows=$(grep -c '<tr><td>runs/x[0-9]*_y[0-9]*</td>' "$T/figs/report.html")
[ "$rows" -eq 4 ] || why="$why $rows run rows in the sweep table, not 4;"
# A run whose particles are still in flight at its end (over 5 % of those sprayed: the spray's warning) has a DE
# that is a lower bound: sweep.h5 /in_flight_share holds each run's share, recomputed here from its spray.h5
# (/metrics/in_flight's last over /deposition_efficiency sprayed_count), and the report marks those DE with ">="
# (a review: the map did not say so; these short runs leave 22-50 % in flight)
attr() { h5dump -a "$2" "$1" 2>/dev/null | sed -n 's/^ *(0): *//p'; }
shares=$(values "$T/figs/sweep.h5" /in_flight_share | tr ' ' '\n' | awk 'NF' | tr '\n' ' ')
k=0
for de in $(values "$T/figs/sweep.h5" /de | tr ' ' '\n' | awk 'NF'); do
    row=$(sed -n "s|.*<tr><td>runs/x$((k % 2))_y$((k / 2))</td><td>[^<]*</td><td>[^<]*</td><td>\([^<]*\)</td>.*|\1|p" "$T/figs/report.html")
    shown=${row#≥ }
    awk -v a="$shown" -v b="$de" 'BEGIN { exit !(a != "" && (b == 0 ? a == 0 : a / (100 * b) > 0.995 && a / (100 * b) < 1.005)) }' ||
        why="$why run $k: DE '$shown' % in the report, $de in sweep.h5;"
    spray=$T/figs/runs/x$((k % 2))_y$((k / 2))/spray.h5
    in_flight=$(values "$spray" /metrics/in_flight | tr ' ' '\n' | awk 'NF' | tail -n 1)
    sprayed=$(attr "$spray" /deposition_efficiency/sprayed_count)
    share=$(echo "$shares" | awk -v k=$((k + 1)) '{ print $k }')
    awk -v s="$share" -v f="${in_flight:-x}" -v n="${sprayed:-0}" 'BEGIN { exit !(n > 0 && s == f / n) }' ||
        why="$why run $k: in_flight_share '$share', its spray.h5 $in_flight in flight of $sprayed;"
    marked=no
    [ "$row" != "$shown" ] && marked=yes
    expected=$(awk -v s="$share" 'BEGIN { print (s > 0.05 ? "yes" : "no") }')
    [ "$marked" = "$expected" ] || why="$why run $k: share $share, marked a lower bound: $marked;"
    k=$((k + 1))
done
[ $k -eq 4 ] || why="$why $k DE values in sweep.h5;"
grep -q '<b>Sweep: deposition efficiency.* 4 of them lower bounds, with particles still in flight' "$T/figs/report.html" ||
    why="$why the headline does not say the DE are lower bounds;"
grep -q 'warning: sweep: the DE of 4 of the 4 runs is a lower bound' "$T/log10b" ||
    why="$why the sweep's log does not warn of the lower bounds;"
grep -q '<b>Sweep: deposition efficiency' "$T/figs/report.html" || why="$why no sweep headline;"
if [ -z "$why" ]; then pass sweep_report; else fail sweep_report "$why"; fi

# 10c. the lower bound marked only where particles are still in flight: the same spray to 0.3 ms (31.5 % in flight)
# and to 3 ms (none): the first run's DE marked ">=" in the report, the second's not, and the log counts 1 of 2 (the
# runs above all leave over 22 % in flight, where marking every cell would pass)
write_case "$T/bound.ini" 320 800 "[sweep]
x_key = spray.t_end
x_values = 0.3e-3, 3e-3"
why=""
"$BIN" run "$T/bound.ini" --stages sweep,render -o "$T/bound" >"$T/log10c" 2>&1 || why="exit $?;"
shares=$(values "$T/bound/sweep.h5" /in_flight_share | tr '\n' ' ')
echo "$shares" | awk '{ exit !(NF == 2 && $1 > 0.05 && $2 <= 0.05) }' || why="$why in_flight_share '$shares', expected one above 5 % and one not;"
text=$(sed 's/<[^>]*>//g' "$T/bound/report.html" | tr '\n' ' ')
printf '%s' "$text" | grep -q 'runs/x0_y00.3e-3≥ ' || why="$why the 0.3 ms run's DE is not marked;"
printf '%s' "$text" | grep -q 'runs/x1_y03e-3≥' && why="$why the 3 ms run's DE is marked;"
grep -q 'warning: sweep: the DE of 1 of the 2 runs is a lower bound' "$T/log10c" || why="$why the log does not count 1 of 2;"
if [ -z "$why" ]; then pass sweep_lower_bound_marked_where_in_flight; else fail sweep_lower_bound_marked_where_in_flight "$why"; fi

# 11. a file key swept ([deposition] table over two files): the files' contents are part of the map's hash, so a
# table edited after the sweep makes the map out of date and its run is made again, to the map of a fresh sweep
# (the hash held only the [sweep] text: "up to date" with the old table's DE); a relative file name is refused,
# exit 2 (a resumed sweep reads its values from RUN_DIR/case.ini, where it named another file)
cp "$TABLE" "$T/t1.csv"
cp "$TABLE" "$T/t2.csv"
write_case "$T/tables.ini" 320 800 "[sweep]
x_key = deposition.table
x_values = $T/t1.csv, $T/t2.csv"
why=""
"$BIN" sweep "$T/tables.ini" -o "$T/tables" >"$T/log11a" 2>&1 || why="$why first sweep exit $?;"
before=$(values "$T/tables/sweep.h5" /de | tr '\n' ' ')
awk -F, -v OFS=, 'NR > 1 && !/^#/ { $2 = $2 - 200 } { print }' "$TABLE" >"$T/t2.csv"
"$BIN" sweep "$T/tables.ini" -o "$T/tables" >"$T/log11b" 2>&1 || why="$why second sweep exit $?;"
grep -q 'sweep.h5 is up to date' "$T/log11b" && why="$why the map was found up to date after t2.csv changed;"
after=$(values "$T/tables/sweep.h5" /de | tr '\n' ' ')
"$BIN" sweep "$T/tables.ini" -o "$T/tables_fresh" >"$T/log11c" 2>&1 || why="$why fresh sweep exit $?;"
fresh=$(values "$T/tables_fresh/sweep.h5" /de | tr '\n' ' ')
[ -n "$after" ] && [ "$after" = "$fresh" ] && [ "$after" != "$before" ] ||
    why="$why DE before '$before', after the edit '$after', a fresh sweep '$fresh';"
(cd "$T" && write_case relative.ini 320 800 "[sweep]
x_key = deposition.table
x_values = t1.csv, t2.csv" && "$BIN" sweep relative.ini -o relative >log11d 2>&1)
code=$?
[ $code -eq 2 ] && grep -q "relative file name of \[deposition\] table" "$T/log11d" && [ ! -e "$T/relative" ] ||
    why="$why a relative file value: exit $code, $(tail -n 1 "$T/log11d");"
if [ -z "$why" ]; then pass sweep_file_values_hashed; else fail sweep_file_values_hashed "$why"; fi
