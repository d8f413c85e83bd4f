#!/bin/sh
# The shipped v_crit(d) table of `make validate` (VALIDATE_ONLY=vcrit_al): cases/vcrit_al.csv has the header of
# vcrit.csv (method = logistic: with the fit's columns), a bracketed row (no '#' line) for each of 14, 22, 30 and
# 45 um at least, v_crit within [v_low, v_high] of cases/vcrit_al.ini and falling with d as the thesis's does
# (Tang Table 5.4: 824, 791, 761 m/s at 14, 22, 30 um); cases/vcrit_al_cor.csv has one row per run with a verdict
# word that agrees with the row's PBCP and v_rest and the case's thresholds and a finite CoR, every diameter of the
# table among its rows; and cases/vcrit_al.ini uses the shipped calibration: the defaults of bonding, eps_c and
# eps_rate_c (docs/keys.md, which test_keys_doc keeps current).  Prints SKIP while the table does not exist.
# The same checks for the energy model's table, cases/vcrit_al_energy.csv and _cor.csv (bisection), and for the
# 15-cell calibration's, cases/vcrit_al_15cells.csv (with the case's grid and eps_c checked against its fit).
# And v_crit(d, T), cases/vcrit_al_temperature.csv: every pair bracketed (whether it falls with T: scripts/validate.sh).
# Also checks the checkers: a table that rises with d, or with T, is refused; a row's note line ("# d = D m: ...",
# beneath a separable row) is not taken for an unbracketed row.
set -u
cd "$(dirname "$0")/.." || exit 1
table=cases/vcrit_al.csv
cor=cases/vcrit_al_cor.csv

# The search range of the case, [v_low, v_high]: a v_crit outside it was not found by the search.
ini_value() { sed -n "s/^$1 *= *//p" "${2:-cases/vcrit_al.ini}"; }
v_low=$(ini_value v_low)
v_high=$(ini_value v_high)
header=diameter,v_crit,pbcp,v_rest,runs

# check_table FILE: empty output when FILE is a valid table falling with d; else the reason.
check_table() {
    awk -F, -v v_low="$v_low" -v v_high="$v_high" -v header="$header" '
        NR == 1 { if ($0 != header) { print "header \"" $0 "\""; bad = 1 }; next }
        /^# d = / { next }
        /^#/ { print "unbracketed: " $0; bad = 1; next }
        NF != split(header, names, ",") { print "line " NR ": " NF " fields"; bad = 1; next }
        {
            if ($2 < v_low || $2 > v_high) { print "v_crit " $2 " outside [" v_low ", " v_high "] at d = " $1; bad = 1 }
            if (n && !($1 > last_d)) { print "diameters not ascending at " $1; bad = 1 }
            if (n && !($2 < last_v)) { print "v_crit does not fall with d: " last_v " at " last_d ", " $2 " at " $1; bad = 1 }
            for (k in want) if ($1 + 0 == want[k] + 0) found[k] = 1
            last_d = $1; last_v = $2; n++
        }
        BEGIN { split("14e-6 22e-6 30e-6 45e-6", want, " ") }
        END { for (k in want) if (!found[k]) print "no row for d = " want[k] }' "$1"
}

rising=$(mktemp) || exit 1
trap 'rm -f "$rising"' EXIT
printf 'diameter,v_crit,pbcp,v_rest,runs\n1.4e-05,800,0.1,0,8\n2.2e-05,790,0.1,0,8\n3e-05,795,0.1,0,8\n4.5e-05,780,0.1,0,8\n' >"$rising"
if check_table "$rising" | grep -q 'does not fall'; then
    echo "PASS vcrit_al_checker_refuses_rising"
else
    echo "FAIL vcrit_al_checker_refuses_rising (a table rising from 22 to 30 um passed)"
fi
# a row's note beneath it (method = logistic, outcomes separable: "# d = D m: ...") is no unbracketed row
printf 'diameter,v_crit,pbcp,v_rest,runs\n1.4e-05,800,0.1,0,8\n# d = 1.4e-05 m: outcomes separable: v_crit is the middle of the gap 797.5-802.5 m/s (no fit, no standard error)\n2.2e-05,790,0.1,0,8\n3e-05,780,0.1,0,8\n4.5e-05,770,0.1,0,8\n' >"$rising"
why=$(check_table "$rising" | tr '\n' ';')
if [ -z "$why" ]; then
    echo "PASS vcrit_al_checker_accepts_row_notes"
else
    echo "FAIL vcrit_al_checker_accepts_row_notes ($why)"
fi


# check_cor TABLE COR INI: empty output when COR holds the runs of every diameter of TABLE, each with a verdict word
# that agrees with its PBCP and v_rest and the thresholds of INI; else the reason.
check_cor() {
    [ -r "$2" ] || { echo "no $2"; return; }
    awk -F, -v table="$1" -v pbcp_min="$(ini_value pbcp_threshold "$3")" -v vrest_max="$(ini_value vrest_threshold "$3")" '
    BEGIN { while ((getline line < table) > 0) if (line !~ /^(#|diameter)/) { split(line, f, ","); d[f[1] + 0] = 1 } }
    NR == 1 { if ($0 != "diameter,velocity,verdict,cor,pbcp,v_rest") print "header \"" $0 "\""; next }
    $3 !~ /^(bonded|rebounded|held|unsettled)$/ || $4 == "" || $4 ~ /nan/ { print "line " NR ": " $0 }
    # the verdict word agrees with the PBCP and v_rest of its row and the thresholds of the case (mpm/verdict.c)
    $3 == "bonded" && !($5 >= pbcp_min && $6 <= vrest_max) { print "bonded with these numbers, line " NR ": " $0 }
    $3 == "held" && !($5 < pbcp_min && $6 <= vrest_max) { print "held with these numbers, line " NR ": " $0 }
    $3 == "rebounded" && !($6 > vrest_max) { print "rebounded at rest, line " NR ": " $0 }
    { seen[$1 + 0] = 1 }
    END { for (x in d) if (!seen[x]) print "no runs of d = " x }' "$2"
}

# check_case NAME HEADER: the table and CoR checks of cases/NAME.csv and NAME_cor.csv against cases/NAME.ini.
check_case() {
    ini=cases/$1.ini
    v_low=$(ini_value v_low "$ini")
    v_high=$(ini_value v_high "$ini")
    header=$2
    if [ ! -e "cases/$1.csv" ]; then
        echo "SKIP $1_table: cases/$1.csv does not exist yet (make validate writes it)"
        return
    fi
    why=$(check_table "cases/$1.csv" | head -n 5 | tr '\n' ';')
    if [ -z "$why" ]; then echo "PASS $1_table"; else echo "FAIL $1_table ($why)"; fi
    why=$(check_cor "cases/$1.csv" "cases/$1_cor.csv" "$ini" | head -n 5 | tr '\n' ';')
    if [ -z "$why" ]; then echo "PASS $1_cor"; else echo "FAIL $1_cor ($why)"; fi
}

# key_default KEY: the default of [impact] KEY in docs/keys.md
key_default() { awk -F'|' -v key="\`$1\`" '$2 ~ "^ *" key " *$" { gsub(/ /, "", $5); print $5; exit }' docs/keys.md; }

check_case vcrit_al diameter,v_crit,pbcp,v_rest,runs,v_crit_se,width,v_bisection
why=""
[ "$(ini_value method cases/vcrit_al.ini)" = logistic ] || why="cases/vcrit_al.ini is not method = logistic;"
# best_eps_c SEARCHES: the eps_c of the calibration record's search with the smallest mean residual
best_eps_c() {
    awk -F, 'NR > 1 && $7 ~ /^[-+]?[0-9]/ { r = $7 < 0 ? -$7 : $7; if (best == "" || r < best) { best = r; eps = $2 } }
        END { print eps }' "$1"
}
for key in bonding eps_c eps_rate_c; do
    want=$(key_default $key)
    # eps_c = auto: the adiabatic calibration (conduction = off) of cases/calibrate_vcrit_al.ini, its record's value
    [ "$key" = eps_c ] && [ "$want" = auto ] && want=$(best_eps_c cases/calibrate_vcrit_al.csv)
    have=$(ini_value $key cases/vcrit_al.ini)
    [ -n "$want" ] || why="$why no default of $key in docs/keys.md;"
    # the same value to the 3 digits of the default
    if [ "$key" = bonding ]; then
        [ "$have" = "$want" ] || why="$why bonding = $have, default $want;"
    elif ! awk -v a="$have" -v b="$want" 'BEGIN { exit !(a != "" && (a - b) ^ 2 <= (1e-3 * b) ^ 2) }'; then
        why="$why $key = $have, default $want;"
    fi
done
if [ -z "$why" ]; then echo "PASS vcrit_al_shipped_calibration"; else echo "FAIL vcrit_al_shipped_calibration ($why)"; fi
check_case vcrit_al_energy diameter,v_crit,pbcp,v_rest,runs

# The finest grid's calibration (cases/vcrit_al_15cells.ini): the table and CoR checks, and the case is what its
# name and comments say: the strain model, 15 grid cells per reference_diameter, and the eps_c and eps_rate_c of
# the search of cases/calibrate_vcrit_al_15cells.csv (`make validate VALIDATE_ONLY=calibrate_vcrit_fine`)
# whose mean residual is the smallest, within fit_tolerance of cases/calibrate_vcrit_al.ini.
check_case vcrit_al_15cells diameter,v_crit,pbcp,v_rest,runs,v_crit_se,width,v_bisection
# check_fine_case INI SEARCHES: empty output when INI is the 15-cell calibration of SEARCHES; else the reason.
check_fine_case() {
    [ -r "$2" ] || { echo "no $2;"; return; }
    [ "$(ini_value bonding "$1")" = strain ] || echo "bonding is not strain;"
    [ "$(ini_value method "$1")" = logistic ] || echo "method is not logistic;"
    awk -v g="$(ini_value grid "$1")" -v d="$(ini_value reference_diameter "$1")" \
        'BEGIN { exit !(g > 0 && (d / g - 15) ^ 2 <= 0.01 ^ 2) }' || echo "grid is not 15 cells per reference_diameter;"
    awk -F, -v eps="$(ini_value eps_c "$1")" -v rate="$(ini_value eps_rate_c "$1")" \
        -v tol="$(ini_value fit_tolerance cases/calibrate_vcrit_al.ini)" '
        NR == 1 || $7 !~ /^[-+]?[0-9]/ { next }
        { r = $7 < 0 ? -$7 : $7; if (best == "" || r < best) { best = r; best_eps = $2; best_rate = $3 } }
        END { if (best == "" || best > tol) print "no search within " tol " m/s;"
              else if ((eps - best_eps) ^ 2 > (1e-9 * best_eps) ^ 2) print "eps_c " eps ", best search " best_eps ";"
              if (best != "" && (rate == "" || (rate - best_rate) ^ 2 > (1e-9 * best_rate) ^ 2))
                  print "eps_rate_c " rate ", best search " best_rate ";" }' "$2"
}
why=$(check_fine_case cases/vcrit_al_15cells.ini cases/calibrate_vcrit_al_15cells.csv | tr '\n' ' ')
if [ -z "$why" ]; then echo "PASS vcrit_al_15cells_calibration"; else echo "FAIL vcrit_al_15cells_calibration ($why)"; fi
# ...and the check itself: the 10-cell case is not the 15-cell calibration
if check_fine_case cases/vcrit_al.ini cases/calibrate_vcrit_al_15cells.csv | tr '\n' ' ' | grep -q 'grid is not 15.*eps_c 2.4680778017283251'; then
    echo "PASS vcrit_al_15cells_checker_refuses_10cells"
else
    echo "FAIL vcrit_al_15cells_checker_refuses_10cells (cases/vcrit_al.ini passed as the 15-cell calibration)"
fi

# v_crit(d, T) (cases/vcrit_al_temperature.ini, `make validate VALIDATE_ONLY=vcrit_al_temperature`): the case is
# cases/vcrit_al.ini's set-up and shipped calibration ([impact] the same line for line) over [vcrit] temperatures;
# its table has a bracketed row for every diameter and temperature of the case, ascending, v_crit within
# [v_low, v_high].  Whether v_crit falls as the particle's temperature rises (thermal softening: Assadi et al. 2003,
# Schmidt et al. 2006), and by how much, is the physics the validate part checks, and fails: v_crit is flat from 400
# to 500 K at 10 um and falls less than Schmidt et al.'s ratio for fine or hot particles (docs/physics.md "The
# model's v_crit(d, T)"); `temperature_falls` and `schmidt_gaps` are those checks, run here on the checker's own
# cases only.
# check_temperature_table FILE INI: empty output when FILE is such a table of INI; else the reason.
check_temperature_table() {
    awk -F, -v v_low="$(ini_value v_low "$2")" -v v_high="$(ini_value v_high "$2")" \
        -v ds="$(ini_value diameters "$2")" -v ts="$(ini_value temperatures "$2")" '
        BEGIN { nd = split(ds, want_d, ","); nt = split(ts, want_t, ",") }
        NR == 1 { for (i = 1; i <= NF; i++) col[$i] = i
                  if (!col["diameter"] || !col["temperature"] || !col["v_crit"]) { print "header \"" $0 "\""; exit } ; next }
        /^# d = / { next }
        /^#/ { print "unbracketed: " $0; next }
        {
            d = $col["diameter"] + 0; t = $col["temperature"] + 0; v = $col["v_crit"] + 0
            if (v < v_low || v > v_high) print "v_crit " v " outside [" v_low ", " v_high "] at d = " d ", T = " t
            if (d == last_d && !(t > last_t)) print "temperatures not ascending at d = " d
            seen[d, t] = 1; last_d = d; last_t = t
        }
        END { for (i = 1; i <= nd; i++) for (j = 1; j <= nt; j++)
                  if (!((want_d[i] + 0, want_t[j] + 0) in seen)) print "no row for d = " want_d[i] ", T = " want_t[j] }' "$1"
}
# temperature_falls FILE: empty output when v_crit falls with T at every diameter of the table FILE; else where not.
temperature_falls() {
    awk -F, 'NR == 1 { for (i = 1; i <= NF; i++) col[$i] = i; next }
        /^#/ { next }
        { d = $col["diameter"] + 0; t = $col["temperature"] + 0; v = $col["v_crit"] + 0
          if (d == last_d && !(v < last_v)) print "d = " d ": " last_v " m/s at " last_t " K, " v " at " t " K"
          last_d = d; last_t = t; last_v = v }' "$1"
}
# schmidt_gaps FILE: for every row above a diameter's first (coldest) temperature T0, the model's v_crit(T) /
# v_crit(T0) against Schmidt et al. 2006's sqrt((Tm - T) / (Tm - T0)), Tm = 933 K (pure Al: the material's melt_T0).
# Both terms of their critical velocity fall in proportion to Tm - T, so the ratio has no fitted constant in it.
# One line per row, "d = D, T = T: model R, Schmidt S, gap G", with " OUTSIDE" where |G| > SCHMIDT_TOLERANCE.
SCHMIDT_TOLERANCE=0.05
schmidt_gaps() {
    awk -F, -v tol="$SCHMIDT_TOLERANCE" 'NR == 1 { for (i = 1; i <= NF; i++) col[$i] = i; next }
        /^#/ { next }
        { d = $col["diameter"] + 0; t = $col["temperature"] + 0; v = $col["v_crit"] + 0
          if (d != last_d) { t0 = t; v0 = v; last_d = d; next }
          model = v / v0; schmidt = sqrt((933 - t) / (933 - t0)); gap = model - schmidt
          printf "d = %g, T = %g: model %.3f, Schmidt %.3f, gap %+.3f%s\n", d, t, model, schmidt, gap,
                 (gap > tol || gap < -tol) ? " OUTSIDE" : "" }' "$1"
}
# impact_section INI: the [impact] section's key lines, comments and blank lines left out
impact_section() { awk '/^\[/ { on = ($0 == "[impact]") } on && !/^[;[]/ && NF' "$1"; }
hot=cases/vcrit_al_temperature
if [ ! -e "$hot.csv" ]; then
    echo "SKIP vcrit_al_temperature_table: $hot.csv does not exist yet (make validate writes it)"
else
    why=$(check_temperature_table "$hot.csv" "$hot.ini" | head -n 5 | tr '\n' ';')
    [ "$(impact_section "$hot.ini")" = "$(impact_section cases/vcrit_al.ini)" ] ||
        why="$why [impact] of $hot.ini is not that of cases/vcrit_al.ini;"
    if [ -z "$why" ]; then echo "PASS vcrit_al_temperature_table"; else echo "FAIL vcrit_al_temperature_table ($why)"; fi
    # its CoR file: check_cor's checks on the rows with the temperature column (the second) left out
    without_t=$(mktemp) || exit 1
    cut -d, -f1,3- "${hot}_cor.csv" >"$without_t" 2>/dev/null
    [ "$(head -n 1 "${hot}_cor.csv" | cut -d, -f2)" = temperature ] || echo "no temperature column" >>"$without_t.why"
    cut -d, -f1,3- "$hot.csv" | sed '1s/.*/diameter,v_crit/' >"$without_t.table"
    why=$(cat "$without_t.why" 2>/dev/null; check_cor "$without_t.table" "$without_t" "$hot.ini" | head -n 5 | tr '\n' ';')
    rm -f "$without_t" "$without_t.why" "$without_t.table"
    if [ -z "$why" ]; then echo "PASS vcrit_al_temperature_cor"; else echo "FAIL vcrit_al_temperature_cor ($why)"; fi
fi
# ...and the checkers: a table with a pair missing is refused; one rising from 400 to 500 K at 14 um does not fall
# with T, one falling at every step does
hotter=$(mktemp) || exit 1
trap 'rm -f "$rising" "$hotter"' EXIT
printf 'diameter,temperature,v_crit,pbcp,v_rest,runs\n1.4e-05,298,800,0.1,0,8\n1.4e-05,400,780,0.1,0,8\n1.4e-05,500,790,0.1,0,8\n' >"$hotter"
if check_temperature_table "$hotter" "$hot.ini" | grep -q 'no row for d = 10e-6, T = 298' &&
    [ -n "$(temperature_falls "$hotter")" ]; then
    echo "PASS vcrit_al_temperature_checker_refuses"
else
    echo "FAIL vcrit_al_temperature_checker_refuses (a table with missing pairs, or rising from 400 to 500 K, passed)"
fi
printf 'diameter,temperature,v_crit,pbcp,v_rest,runs\n1.4e-05,298,800,0.1,0,8\n1.4e-05,400,780,0.1,0,8\n3e-05,298,770,0.1,0,8\n3e-05,400,760,0.1,0,8\n' >"$hotter"
if [ -z "$(temperature_falls "$hotter")" ]; then
    echo "PASS vcrit_al_temperature_checker_accepts_falling"
else
    echo "FAIL vcrit_al_temperature_checker_accepts_falling ($(temperature_falls "$hotter" | tr '\n' ';'))"
fi
# a table falling as Schmidt's ratio (800 x 0.9162 at 400 K) is inside; one falling by 10 % more is outside
printf 'diameter,temperature,v_crit,pbcp,v_rest,runs\n1.4e-05,298,800,0.1,0,8\n1.4e-05,400,733,0.1,0,8\n3e-05,298,770,0.1,0,8\n3e-05,400,628,0.1,0,8\n' >"$hotter"
gaps=$(schmidt_gaps "$hotter")
if [ "$(printf '%s\n' "$gaps" | grep -c OUTSIDE)" = 1 ] && printf '%s\n' "$gaps" | grep -q 'd = 3e-05, T = 400.*OUTSIDE' &&
    printf '%s\n' "$gaps" | grep -q 'd = 1.4e-05, T = 400: model 0.916, Schmidt 0.916'; then
    echo "PASS vcrit_al_temperature_schmidt_checker"
else
    echo "FAIL vcrit_al_temperature_schmidt_checker ($(printf '%s' "$gaps" | tr '\n' ';'))"
fi
if [ "${1:-}" = --temperature-falls ]; then # scripts/validate.sh: the physics checks of the shipped table
    temperature_falls "$hot.csv"
    schmidt_gaps "$hot.csv" | sed 's/^/schmidt: /'
fi
exit 0
