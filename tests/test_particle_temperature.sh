#!/bin/sh
# The particle temperature from the spray to the impact, and v_crit over temperature (issue 26 item 3; docs/physics.md
# "Particle temperature at impact"):
#   - the spray writes the particles' temperature to spray.h5 /impacts/temperature and the couple stage carries each
#     impact's own into couple.h5 /seeds/temperature (the small pipeline with cases/al6061_n2.ini's [nozzle]: the
#     particles leave the nozzle at temperatures that differ by diameter, so that a seed given another impact's
#     temperature, or one temperature for all, is seen);
#   - the impact stage starts every point of a seeded particle at its seed's temperature and the substrate at its
#     T_initial (impact.h5 /run_NNNN/snapshots/000000/T at t = 0);
#   - `spraycoat vcrit` with [vcrit] temperatures over two temperatures (one 8 um diameter, 10 ns runs): vcrit.csv with
#     a temperature column and a row per pair, vcrit.h5 /temperature and the 1 x 2 /grid/v_crit, both read back by
#     the spray stage's table rule (`spraycoat check`), the 600 K v_crit below the 300 K one (at this coarse grid it
#     is above with bonding_preheat = none), and its figures rendered (vcrit.png, vcrit_cor.png);
#   - an [impact] bodies CSV with a temperature column: each body's points start at its row's temperature.
# Prints "PASS name" / "FAIL name (reason)".  Run from the repository root with $SPRAYCOAT_BIN.  Needs h5dump.  About 10 s on one core.
set -u

BIN=${SPRAYCOAT_BIN:-build/spraycoat}
case $BIN in
/*) ;;
*/*) BIN=$(pwd)/$BIN ;;
esac
CASE=tests/fixtures/pipeline_small.ini
BASE=tests/bad_cases/valid_base.ini

pass() { echo "PASS $1"; }
fail() { echo "FAIL $1 ($2)"; }

for tool in h5dump; do
    if ! command -v "$tool" >/dev/null 2>&1; then
        echo "FAIL particle_temperature ($tool not found: install hdf5-tools)"
        exit 1
    fi
done
if [ ! -x "$BIN" ] || [ ! -r "$CASE" ] || [ ! -r "$BASE" ]; then
    echo "FAIL particle_temperature (no $BIN, $CASE or $BASE; run from the repository root after make)"
    exit 1
fi
T=$(mktemp -d) || exit 1
trap 'rm -rf "$T"' EXIT
trap 'exit 1' HUP INT TERM
. tests/pipeline_lib.sh

# the small pipeline's particles heated in cases/al6061_n2.ini's nozzle (N2 at 698 K): their temperatures differ by
# diameter (tests/pipeline_lib.sh nozzle_case)
nozzle_case "$T/case.ini"
if ! "$BIN" run "$T/case.ini" --stages spray,couple,impact -o "$T/run" >"$T/run.log" 2>&1; then
    echo "FAIL particle_temperature (spray, couple and impact failed: $(tail -n 3 "$T/run.log" | tr '\n' ' '))"
    exit 1
fi

# ---- 1. spray.h5 /impacts/temperature -> couple.h5 /seeds/temperature, each seed its own impact row's ------------
values "$T/run/spray.h5" /impacts/temperature >"$T/impact_t"
values "$T/run/couple.h5" /seeds/temperature >"$T/seed_t"
values "$T/run/couple.h5" /seeds/impact_row >"$T/seed_row"
why=$(awk 'FILENAME == ARGV[1] { t[FNR - 1] = $1; next } FILENAME == ARGV[2] { row[FNR] = $1; next }
    { n++; if (!(row[FNR] in t) || $1 != t[row[FNR]]) printf " seed %d: %s K, its impact row %s has %s K;", FNR - 1, $1,
        row[FNR], t[row[FNR]]; if (!(($1 "") in seen)) distinct++; seen[$1 ""] = 1 }
    END { if (n != 4) printf " %d seeds, 4 runs;", n; if (distinct < 3) printf " %d distinct temperatures: the check cannot tell seeds apart;", distinct }' \
    "$T/impact_t" "$T/seed_row" "$T/seed_t")
if [ -z "$why" ] && [ -s "$T/impact_t" ]; then
    pass couple_carries_temperature
else
    fail couple_carries_temperature "${why:- no /impacts/temperature}"
fi

# ---- 2. the impact stage starts the particle's points at its seed's temperature ---------------------------------
why=""
for r in 0 1 2 3; do
    expected=$(sed -n "$((r + 1))p" "$T/seed_t")
    values "$T/run/impact.h5" "/run_000$r/snapshots/000000/body" >"$T/body"
    values "$T/run/impact.h5" "/run_000$r/snapshots/000000/T" >"$T/points_t"
    [ -s "$T/points_t" ] || why="$why run $r: no snapshot 000000/T;"
    why="$why$(paste "$T/body" "$T/points_t" | awk -v p="$expected" -v r="$r" '
        $1 == 0 && $2 != 298 { bad++ } $1 == 1 && $2 != p { bad++ } $1 == 1 { n++ }
        END { if (bad || !n) printf " run %d: %d of the points not at 298 K (substrate) or %s K (particle, %d points);", r, bad, p, n }')"
done
if [ -z "$why" ]; then pass impact_starts_at_seed_temperature; else fail impact_starts_at_seed_temperature "$why"; fi

# ---- 2b. ...and its bonding model's critical strain scaled by the melt-heat factor (bonding_preheat = melt_heat,
# the default): q / (2 - q) for the particle, q = sqrt((933 - T) / (933 - 298)) at its seed's temperature T (0.92731
# at 345 K; its mean with the substrate's is q), exactly 1 for the substrate at 298 K
why=""
for r in 0 1 2 3; do
    seed_t=$(sed -n "$((r + 1))p" "$T/seed_t")
    values "$T/run/impact.h5" "/run_000$r/summary/bonding_scale" >"$T/scale"
    why="$why$(awk -v r="$r" -v t="$seed_t" 'NR == 1 && $1 != 1 { printf " run %d: substrate %s;", r, $1 }
        NR == 2 { q = sqrt((933 - t) / 635); d = $1 - q / (2 - q); if (d > 1e-12 || d < -1e-12) printf " run %d: particle %s;", r, $1 }
        END { if (NR != 2) printf " run %d: %d bodies;", r, NR }' "$T/scale")"
done
if [ -z "$why" ]; then pass impact_bonding_scale; else fail impact_bonding_scale "$why"; fi

# ---- 4. vcrit over two temperatures ----------------------------------------------------------------------------
cat >"$T/vcrit.ini" <<EOF
; tiny vcrit search over temperature: far too coarse for physics, quick (as tests/test_vcrit.sh)
[run]
threads = 1

[impact]
grid = 2e-6
spacing = 1e-6
substrate_diameter = 20e-6
substrate_height = 6e-6
t_end = 10e-9
settle_window = 2e-9
settle_vcom = 1e4
settle_pbcp = 1
vrest_filter = 1e4
; below the 10-cell calibration's 2.468, so that 300 K also bonds below v_high at this coarse grid (at 2.468 it
; rebounds still at 2000 m/s) and both rows are bracketed
eps_c = 1.5

[material.aluminium]

[vcrit]
diameters = 8e-6
temperatures = 600,300
v_low = 200
v_high = 1200
tolerance = 400
EOF
RUN=$T/vcrit
why=""
if "$BIN" vcrit "$T/vcrit.ini" -o "$RUN" >"$T/vcrit.log" 2>&1; then
    [ "$(head -n 1 "$RUN/vcrit.csv")" = "diameter,temperature,v_crit,pbcp,v_rest,runs" ] ||
        why="$why vcrit.csv header '$(head -n 1 "$RUN/vcrit.csv")';"
    # one row per temperature, ascending, at 8 um: a v_crit in the bracket or a '#' line with the reason
    rows=$(sed 1d "$RUN/vcrit.csv" | awk -F, '
        /^#/ { sub(/^# /, ""); if ($3 != "nan") print "bad"; else print $1 "," $2; next }
        { if (!($3 + 0 >= 200 && $3 + 0 <= 1200)) print "bad"; else print $1 "," $2 }' | tr '\n' ' ')
    [ "$rows" = "8e-06,300 8e-06,600 " ] || why="$why rows '$rows', expected 8e-06,300 and 8e-06,600;"
    grid=$(h5dump -H -d /grid/v_crit "$RUN/vcrit.h5" 2>/dev/null | grep -c 'SIMPLE { ( 1, 2 )')
    [ "$grid" -eq 1 ] || why="$why no 1 x 2 /grid/v_crit in vcrit.h5;"
    [ "$(values "$RUN/vcrit.h5" /grid/temperature | tr '\n' ' ')" = "300 600 " ] || why="$why /grid/temperature;"
    # the particle started at its temperature: the runs at 300 K and 600 K are not the same bits (a search that
    # ignored the temperature would repeat the same runs).  Compared as text: h5diff calls datasets of different
    # lengths (searches of different run counts) "not comparable" and exits 0, as for equal ones.
    same=1
    for field in v_rest pbcp; do
        [ "$(values "$RUN/vcrit.h5" /search/000/$field)" = "$(values "$RUN/vcrit.h5" /search/001/$field)" ] || same=0
    done
    for search in 000 001; do
        [ -n "$(values "$RUN/vcrit.h5" /search/$search/v_rest)" ] || why="$why no /search/$search/v_rest in vcrit.h5;"
    done
    [ "$same" -eq 0 ] || why="$why the runs at 300 K and 600 K are identical;"
    # both pairs bracketed (eps_c above), the hot particle bonding at a lower speed than the cold one
    vhot=$(awk -F, '$2 == 600 && /^[0-9]/ { print $3 }' "$RUN/vcrit.csv")
    vcold=$(awk -F, '$2 == 300 && /^[0-9]/ { print $3 }' "$RUN/vcrit.csv")
    if [ -z "$vhot" ] || [ -z "$vcold" ]; then
        why="$why a pair was not bracketed, so the 2-D table is incomplete;"
    elif ! awk -v h="$vhot" -v c="$vcold" 'BEGIN { exit !(h < c) }'; then
        why="$why v_crit at 600 K ($vhot m/s) not below v_crit at 300 K ($vcold m/s);"
    fi
    for file in vcrit.csv vcrit.h5; do
        sed -e 's/^rule = adhesion$/rule = table/' -e "s|^alpha_adh = .*|table = $RUN/$file|" "$BASE" >"$T/spray.ini"
        "$BIN" check "$T/spray.ini" >"$T/check.log" 2>&1 ||
            why="$why the spray cannot read $file: $(grep '^spraycoat:' "$T/check.log" | head -n 1);"
    done
    # the figures of a table over (d, T): a v_crit curve per temperature, CoR in two panels (render/vcrit_figures.c)
    if ! "$BIN" render "$T/vcrit.ini" -o "$RUN" >"$T/render.log" 2>&1; then
        why="$why spraycoat render of the 2-D table failed: $(tail -n 1 "$T/render.log");"
    elif [ ! -s "$RUN/figures/vcrit.png" ] || [ ! -s "$RUN/figures/vcrit_cor.png" ]; then
        why="$why no vcrit.png or vcrit_cor.png;"
    fi
else
    why="spraycoat vcrit exited with status $?: $(tail -n 3 "$T/vcrit.log" | tr '\n' ' ')"
fi
sed 's/^/  /' "$RUN/vcrit.csv" 2>/dev/null
if [ -z "$why" ]; then pass vcrit_over_temperature; else fail vcrit_over_temperature "$why"; fi

# ---- 5. an [impact] bodies CSV with a temperature column: each body starts at its own -----------------------------
mkdir -p "$T/bodies"
printf 'shape,x,y,z,vx,vy,vz,d,h,material,temperature\nsphere,0,0,4e-6,0,0,-600,8e-6,0,aluminium,520\nsphere,6e-6,0,14e-6,0,0,-600,8e-6,0,aluminium,410.5\n' \
    >"$T/bodies/bodies.csv"
printf '[run]\nthreads = 1\n[impact]\ngrid = 2e-6\nspacing = 1e-6\nsubstrate = cylinder\nsubstrate_diameter = 24e-6\nsubstrate_height = 6e-6\nbodies = bodies.csv\nt_end = 1e-9\nsnapshot_every = 1e-9\n[material.aluminium]\n' \
    >"$T/bodies/case.ini"
if "$BIN" impact "$T/bodies/case.ini" -o "$T/bodies/run" >"$T/bodies.log" 2>&1; then
    values "$T/bodies/run/impact.h5" /snapshots/000000/body >"$T/body"
    values "$T/bodies/run/impact.h5" /snapshots/000000/T >"$T/points_t"
    got=$(paste "$T/body" "$T/points_t" | LC_ALL=C sort -u | tr '\t\n' ': ')
    if [ "$got" = "0:298 1:520 2:410.5 " ]; then
        pass bodies_csv_temperature
    else
        fail bodies_csv_temperature "body:T at t = 0 '$got', expected 0:298 1:520 2:410.5"
    fi
else
    fail bodies_csv_temperature "spraycoat impact failed: $(tail -n 2 "$T/bodies.log" | tr '\n' ' ')"
fi
exit 0
