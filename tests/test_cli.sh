#!/bin/sh
# The command line as a user meets it (issue 23, CLI items): per-command help, `resume` ending with the summary
# of `run`, `info` telling a running job (its run directory locked) from a stopped one, one numbering of bodies,
# `check` warning of a nozzle path longer than the run, the spray warning of particles in flight at its end.
# Prints "PASS name" / "FAIL name: why".  Run from the repository root.
set -u
bin=${SPRAYCOAT_BIN:-build/spraycoat}
base=tests/bad_cases/valid_base.ini
T=$(mktemp -d) || { echo "FAIL cli_setup: mktemp -d failed"; exit 1; }
trap 'rm -rf "$T"' EXIT

report() { if [ -z "$why" ]; then echo "PASS $1"; else echo "FAIL $1: $why"; fi; }

# per-command help: `spraycoat COMMAND --help` and `spraycoat help COMMAND` give the command's own page
why=""
for command in check run resume spray couple impact vcrit calibrate render info keys; do
    "$bin" "$command" --help >"$T/a" 2>&1 || why="${why:+$why; }$command --help exited $?"
    "$bin" help "$command" >"$T/b" 2>&1 || why="${why:+$why; }help $command exited $?"
    grep -q "^usage: spraycoat $command" "$T/a" || why="${why:+$why; }$command --help is not the command's page"
    cmp -s "$T/a" "$T/b" || why="${why:+$why; }help $command differs from $command --help"
done
"$bin" help nosuchcommand >/dev/null 2>&1
[ $? -eq 2 ] || why="${why:+$why; }help of an unknown command does not exit 2"
"$bin" help | grep -q 'spraycoat help' || why="${why:+$why; }the general help does not list help"
report per_command_help

# resume ends with the same summary as run
R=$T/run
"$bin" run "$base" -o "$R" >"$T/run.out" 2>/dev/null
"$bin" resume "$R" >"$T/resume.out" 2>/dev/null
why=""
grep -q "^results in $R:" "$T/run.out" || why="run prints no summary"
sed -n '/^results in/,$p' "$T/run.out" >"$T/run.summary"
sed -n '/^results in/,$p' "$T/resume.out" >"$T/resume.summary"
[ -s "$T/resume.summary" ] || why="${why:+$why; }resume prints no summary"
cmp -s "$T/run.summary" "$T/resume.summary" || why="${why:+$why; }resume's summary differs from run's"
report resume_prints_summary

# info: a run directory whose lock another process holds is running, not interrupted
why=""
"$bin" info "$R" | grep -q '^status: not running' || why="a finished run is not 'not running'"
if command -v flock >/dev/null 2>&1; then
    flock -n "$R" "$bin" info "$R" >"$T/info.out" 2>&1
    grep -q '^status: running' "$T/info.out" || why="${why:+$why; }a locked run directory is not 'running'"
else
    why="flock(1) is not installed (util-linux)"
fi
report info_running_or_not

# one numbering of bodies everywhere: the index of impact.h5 (/summary rows, the snapshots' `body` field; the
# substrate is body 0), in the log, in `info` and in the figures
R=$T/impact
"$bin" impact tests/bad_cases/valid_impact_base.ini -o "$R" >/dev/null 2>"$T/impact.log"
why=""
grep -q 'impact: body 1 (d = 8 um' "$T/impact.log" || why="the log does not call the particle body 1: $(grep -m 1 'body' "$T/impact.log")"
"$bin" info "$R" >"$T/impact.info" 2>&1
grep -Eq '^ +1 +particle' "$T/impact.info" || why="${why:+$why; }info does not call the particle body 1"
substrate=$(h5dump -d /summary/substrate -y -w 0 "$R/impact.h5" 2>/dev/null | awk '/DATA/{on=1; next} on && /[0-9]/{split($0, v, ","); gsub(/ /, "", v[1]); print v[1]; exit}')
[ "$substrate" = "1" ] || why="${why:+$why; }/summary row 0 is not the substrate ($substrate)"
report bodies_numbered_as_in_hdf5

# a nozzle path longer than the run: `check` warns that the thickness and profile are those of the part sprayed (the
# run's numbers alone do not show it); the shipped case, whose run outlasts its path, gets no such warning
why=""
sed 's/^t_end = .*/t_end = 1e-3/' cases/traverse_demo.ini >"$T/short_path.ini"
grep -q '^t_end = 1e-3$' "$T/short_path.ini" || why="cases/traverse_demo.ini has no t_end line to shorten"
"$bin" check "$T/short_path.ini" >/dev/null 2>"$T/short_path.err" || why="${why:+$why; }check of the shortened case exited $?"
grep -q 'warning: \[path\]: the nozzle takes 0.0026 s over its path, longer than \[spray\] t_end = 0.001 s' "$T/short_path.err" ||
    why="${why:+$why; }no warning that the path outlasts the run: $(head -n 2 "$T/short_path.err")"
"$bin" check cases/traverse_demo.ini >/dev/null 2>"$T/path.err"
grep -q 'longer than \[spray\] t_end' "$T/path.err" && why="${why:+$why; }the shipped case, whose run outlasts its path, is warned about"
report path_longer_than_the_run_warns

# particles still in flight at t_end: the spray warns that its DE counts them as not deposited (a lower bound), with
# their number; a run long enough for every particle to land or leave does not
why=""
sed 's/^t_end = .*/t_end = 4e-3/' "$base" >"$T/in_flight.ini"
sed 's/^t_end = .*/t_end = 2e-2/' "$base" >"$T/landed.ini"
"$bin" spray "$T/in_flight.ini" -o "$T/in_flight" >/dev/null 2>"$T/in_flight.err" || why="the short spray exited $?"
"$bin" spray "$T/landed.ini" -o "$T/landed" >/dev/null 2>"$T/landed.err" || why="${why:+$why; }the long spray exited $?"
flying=$(sed -n 's/.*in flight \([0-9]*\)$/\1/p' "$T/in_flight.err")
grep -q "warning: spray: $flying of the 200 particles sprayed .* were still in flight at t_end: the DE counts them" "$T/in_flight.err" &&
    [ "${flying:-0}" -gt 10 ] || why="${why:+$why; }no warning of the ${flying:-?} particles in flight: $(grep -i 'warning' "$T/in_flight.err" | head -n 1)"
grep -q 'in flight 0$' "$T/landed.err" || why="${why:+$why; }the long spray still has particles in flight"
grep -q 'still in flight at t_end' "$T/landed.err" && why="${why:+$why; }the spray whose particles all landed or left is warned about"
report in_flight_at_the_end_warns

# particles of a particles CSV that overlap at t = 0 never collide (a contact starts when surfaces meet): warned,
# naming the first pair's rows and counting the pairs (rows 1-2, 2-3, 1-7 and 2-7 overlap, 4 is apart, rows 5 and 6
# overlap though far apart in the file, and 1-2 are not next to each other along x: the search sorts by x); none for
# a file without overlap
why=""
printf 'x,y,z,vx,vy,vz,wx,wy,wz,d\n0,0,0,0,0,100,0,0,0,40e-6\n20e-6,0,0,0,0,100,0,0,0,40e-6\n55e-6,0,0,0,0,100,0,0,0,40e-6\n1e-3,0,0,0,0,100,0,0,0,40e-6\n-1e-3,5e-4,0,0,0,100,0,0,0,40e-6\n-1e-3,5.3e-4,0,0,0,100,0,0,0,40e-6\n5e-6,30e-6,0,0,0,100,0,0,0,40e-6\n' >"$T/overlap.csv"
printf 'x,y,z,vx,vy,vz,wx,wy,wz,d\n0,0,0,0,0,100,0,0,0,40e-6\n41e-6,0,0,0,0,100,0,0,0,40e-6\n' >"$T/apart.csv"
for f in overlap apart; do
    printf '[spray]\ninjection = file\nparticles = %s.csv\nt_end = 1e-5\ndt = 1e-6\n[jet]\nmodel = none\n' "$f" >"$T/$f.ini"
    "$bin" check "$T/$f.ini" >/dev/null 2>"$T/$f.err" || why="${why:+$why; }check of $f exited $?"
done
grep -q 'warning: spray: 5 pairs of the particles in .*overlap.csv overlap at t = 0 (first: data rows 1 and 2)' "$T/overlap.err" ||
    why="${why:+$why; }no warning of the 5 overlapping pairs: $(grep -i 'overlap' "$T/overlap.err" | head -n 1)"
grep -qi 'overlap' "$T/apart.err" && why="${why:+$why; }a file without overlap is warned about"
report overlapping_particles_warn

# a [material.NAME] section no body uses (a misspelt name: the bodies stay on the default material) is warned of,
# naming it and the materials in use; the fixture's own sections are not
why=""
sed 's/^\[material.aluminium\]$/[material.aluminium]\n[material.aluminum]\ndensity = 2800/' tests/fixtures/pipeline_small.ini >"$T/misspelt.ini"
grep -q '^\[material.aluminum\]$' "$T/misspelt.ini" || why="tests/fixtures/pipeline_small.ini has no [material.aluminium] line"
"$bin" check "$T/misspelt.ini" >/dev/null 2>"$T/misspelt.err" || why="${why:+$why; }check exited $?"
grep -q "warning: impact: \[material.aluminum\] is used by no body (the bodies' materials: aluminium)" "$T/misspelt.err" ||
    why="${why:+$why; }no warning of the unused section: $(grep -i 'material' "$T/misspelt.err" | head -n 1)"
"$bin" check tests/fixtures/pipeline_small.ini >/dev/null 2>"$T/fixture.err"
grep -q 'used by no body' "$T/fixture.err" && why="${why:+$why; }the fixture's own material section is warned about"
report unused_material_section_warns

# a CSV whose lines end with CR alone (classic Mac OS) is read as one line: refused saying so (it said "no data
# rows (only a header)")
why=""
"$bin" check tests/bad_cases/particles_csv_cr.ini >/dev/null 2>"$T/cr.err"
status=$?
[ $status -eq 2 ] || why="exit $status"
grep -q 'particles_cr.csv:1:26: a carriage return inside a line (lines ended by CR alone?)' "$T/cr.err" ||
    why="${why:+$why; }the message: $(tail -n 1 "$T/cr.err")"
report csv_cr_line_ends_named

# `check` of a [nozzle] case lists the jet's keys with their defaults, which the run does not use: it then gives the
# values the nozzle's exit state sets (C1 = u_e (x_core)^(1/3): 1046 m/s over the 166 mm of core and virtual
# origin of the Al6061 case's nozzle, docs/nozzle.md, is 575 m^(4/3)/s; the gas's Sutherland constant N2's 107 K)
why=""
"$bin" check cases/al6061_n2.ini >"$T/nozzle_check.out" 2>/dev/null || why="check exited $?"
grep -q '^with \[nozzle\], from its exit state' "$T/nozzle_check.out" || why="${why:+$why; }no values from the nozzle listed"
c1=$(sed -n 's/^  \[jet\] C1 *= \([0-9.e+-]*\) .*/\1/p' "$T/nozzle_check.out")
awk -v c="${c1:-0}" 'BEGIN { exit !(c > 569 && c < 581) }' || why="${why:+$why; }C1 from the nozzle '$c1', not about 575"
# the run takes N2's Sutherland constant, 107 K (dem/params.c map_jet), not the listed default of 111 K (air's)
grep -q '^  \[jet\] gas_sutherland *= 107 K$' "$T/nozzle_check.out" ||
    why="${why:+$why; }no '[jet] gas_sutherland = 107 K' from the nozzle's N2"
"$bin" check tests/bad_cases/valid_base.ini 2>/dev/null | grep -q '^with \[nozzle\], from' && why="${why:+$why; }a case without [nozzle] lists them"
report check_lists_the_nozzle_jet

# a feed that outlasts the nozzle's path releases particles from the nozzle parked at its end, and one that stops first
# leaves the end of the path bare: both warned of with the times (a review: cases/al6061_n2.ini fed 72 of its 400
# particles after its 20 ms pass; it now feeds 320 over the pass).  traverse_demo.ini: 4 particles a step of 2 us,
# path 2.6 ms (3 passes of 8 mm and 2 step-overs of 1 mm at 10 m/s), t_end 2.8 ms: max_injected 8000 feeds all
# 1400 steps, 5600 particles, 5204 of them by the path's end (steps 0-1300): 396 parked; 2000 run out at step 499.
why=""
sed 's/^max_injected = 5200$/max_injected = 8000/' cases/traverse_demo.ini >"$T/feed_long.ini"
sed 's/^max_injected = 5200$/max_injected = 2000/' cases/traverse_demo.ini >"$T/feed_short.ini"
"$bin" check "$T/feed_long.ini" >"$T/feed_long.out" 2>&1 || why="check of feed_long.ini exited $?"
grep -q 'the powder is fed until t = 0.002798 s .* after the nozzle.s path ends at 0.0026 s: 396 particles leave the nozzle parked' \
    "$T/feed_long.out" || why="${why:+$why; }no warning of 396 particles fed after the path: $(grep warning "$T/feed_long.out")"
"$bin" check "$T/feed_short.ini" >"$T/feed_short.out" 2>&1 || why="${why:+$why; }check of feed_short.ini exited $?"
grep -q 'the powder runs out at t = 0.000998 s (max_injected = 2000), before the nozzle.s path ends at 0.0026 s' \
    "$T/feed_short.out" || why="${why:+$why; }no warning of the feed running out: $(grep warning "$T/feed_short.out")"
for f in cases/traverse_demo.ini cases/al6061_n2.ini; do
    "$bin" check "$f" 2>&1 | grep -q 'the powder is fed until\|the powder runs out' && why="${why:+$why; }$f warned of"
done
report feed_against_path_warned

# a v_crit(d, T) table's temperature column is in kelvin: one whose lowest value is 25 (degrees Celsius written as
# kelvin, read as cryogenic powder) is warned of, naming the file and the value; one in kelvin is not
why=""
printf 'diameter,temperature,v_crit\n1e-5,25,800\n1e-5,300,700\n3e-5,25,750\n3e-5,300,650\n' >"$T/degc.csv"
awk -F, 'NR > 1 { $2 = $2 + 273.15 } 1' OFS=, "$T/degc.csv" >"$T/kelvin.csv"
for table in degc kelvin; do
    sed -e 's/^rule = adhesion$/rule = table/' -e "s|^alpha_adh = .*|table = $T/$table.csv|" "$base" >"$T/$table.ini"
    grep -q "^table = $T/$table.csv" "$T/$table.ini" || why="${why:+$why; }no table line in $T/$table.ini"
    "$bin" check "$T/$table.ini" >/dev/null 2>"$T/$table.err" || why="${why:+$why; }check of $table.csv exited $?"
done
grep -q "warning: \[deposition\] table = $T/degc.csv: its lowest temperature is 25 K (the column is in kelvin; degrees Celsius?)" "$T/degc.err" ||
    why="${why:+$why; }no warning of the table in degC: $(tail -n 1 "$T/degc.err")"
grep -q 'degrees Celsius' "$T/kelvin.err" && why="${why:+$why; }the table in kelvin is warned of"
report vcrit_table_in_celsius_warns

# a pipeline whose runs hold one particle each, on the substrate's axis: a substrate narrower than the powder is
# refused up front, naming [impact] substrate_diameter (`run cases/impact_demo.ini` sprayed 160 um default powder
# for a minute, then blamed [couple] patch_size and offered bodies_per_run = 1, which it had); a seeded particle
# wider than the substrate (an untruncated powder: known only once seeded) is refused naming the particle's size
why=""
"$bin" run cases/impact_demo.ini -o "$T/impact_demo_run" >/dev/null 2>"$T/impact_demo.err"
status=$?
[ $status -eq 2 ] || why="run of impact_demo.ini exited $status"
grep -q "impact_demo.ini:19: \[impact\] substrate_diameter = 24e-6: 24 um is narrower than the powder's median diameter" "$T/impact_demo.err" &&
    grep -q '`spraycoat impact` runs \[impact\]'"'"'s own particle' "$T/impact_demo.err" ||
    why="${why:+$why; }the message: $(tail -n 1 "$T/impact_demo.err")"
[ -e "$T/impact_demo_run" ] && why="${why:+$why; }the refused run made its run directory"
sed -e 's/^substrate_diameter = 20e-6$/substrate_diameter = 8.5e-6/' -e 's/^d_max = 10e-6$/d_max = 0/' \
    -e 's/^d_min = 6e-6$/d_min = 0/' tests/fixtures/pipeline_small.ini >"$T/wide.ini"
[ "$(grep -c '^substrate_diameter = 8.5e-6$\|^d_max = 0$\|^d_min = 0$' "$T/wide.ini")" -eq 3 ] || why="${why:+$why; }wide.ini not made"
"$bin" run "$T/wide.ini" -o "$T/wide" >/dev/null 2>"$T/wide.err"
status=$?
[ $status -eq 2 ] || why="${why:+$why; }run of wide.ini exited $status"
grep -q 'is wider than the substrate (a cylinder 8.5 um across in this run' "$T/wide.err" ||
    why="${why:+$why; }the seeded particle's message: $(tail -n 1 "$T/wide.err")"
grep -q 'bodies_per_run = 1\|patch_size' "$T/wide.err" && why="${why:+$why; }it blames the patch or offers bodies_per_run = 1"
# two bodies a run on a patch of 0.1 um: the first lands on the axis, and a particle wider than the substrate is
# named as such there too (it blamed the patch and offered bodies_per_run = 1)
sed -e 's/^bodies_per_run = 1$/bodies_per_run = 2/' -e 's/^\[couple\]$/[couple]\npatch_size = 1e-7/' "$T/wide.ini" >"$T/wide2.ini"
grep -q '^bodies_per_run = 2$' "$T/wide2.ini" || why="${why:+$why; }wide2.ini not made"
"$bin" run "$T/wide2.ini" -o "$T/wide2" >/dev/null 2>"$T/wide2.err"
grep -q 'is wider than the substrate (a cylinder 8.5 um across in this run' "$T/wide2.err" ||
    why="${why:+$why; }two bodies a run: $(tail -n 1 "$T/wide2.err")"
report lone_particle_wider_than_substrate

# ---- an empty [material.NAME] section is Tang's aluminium whatever its name: `check` says so for another name (a
# review: [material.copper] left empty ran as aluminium without a word, and the refusal of a missing section said an
# empty one was enough); an empty [material.aluminium] (impact_demo.ini) is not warned of
why=""
sed -e 's/^\[material.aluminium\]$/[material.copper]/' -e 's/^\[impact\]$/[impact]\nmaterial = copper\nsubstrate_material = copper/' \
    cases/impact_demo.ini >"$T/copper.ini"
[ "$(grep -c '^\[material.copper\]$\|^material = copper$' "$T/copper.ini")" -eq 2 ] || why="copper.ini not made"
"$bin" check "$T/copper.ini" >"$T/copper.out" 2>&1 || why="${why:+$why; }check of copper.ini failed"
grep -q "\[material.copper\] gives no key, so every property is Tang's aluminium default" "$T/copper.out" ||
    why="${why:+$why; }no warning for the empty [material.copper]"
"$bin" check cases/impact_demo.ini >"$T/alu.out" 2>&1 || why="${why:+$why; }check of impact_demo.ini failed"
grep -q 'gives no key' "$T/alu.out" && why="${why:+$why; }an empty [material.aluminium] warned of"
report empty_material_section_is_aluminium

# ---- a case made for `spraycoat impact` passes `check` but `spraycoat run` refuses it (its substrate cannot hold the
# powder's particles): check says so, with run's own message (a review: check said OK and nothing else)
why=""
"$bin" check cases/impact_demo.ini >"$T/impact_check.out" 2>&1 || why="check of impact_demo.ini exited $?"
"$bin" run cases/impact_demo.ini -o "$T/impact_run" >"$T/impact_run.out" 2>&1 && why="${why:+$why; }run of impact_demo.ini was not refused"
refusal=$(sed -n 's/^spraycoat: //p' "$T/impact_run.out" | head -n 1)
[ -n "$refusal" ] || why="${why:+$why; }run printed no refusal"
grep -qF "note: \`spraycoat run\` (the pipeline, whose impact runs take the spray's particles) refuses this case: $refusal" \
    "$T/impact_check.out" || why="${why:+$why; }check does not give run's refusal ($refusal)"
"$bin" check cases/demo.ini >"$T/demo_check.out" 2>&1 || why="${why:+$why; }check of demo.ini exited $?"
grep -q 'refuses this case' "$T/demo_check.out" && why="${why:+$why; }check of the pipeline case demo.ini notes a refusal"
report check_notes_pipeline_refusal
