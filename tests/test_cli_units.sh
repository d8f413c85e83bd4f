#!/bin/sh
# Units in case files through `spraycoat check` (docs/keys.md's header): values with units are converted to SI
# (the check lists "30 mm = 0.03 m"), give the same case hash as the bare SI numbers, and a unit of another
# dimension or an unknown unit exits 2 naming file, line, key, the unit given and the unit expected (an angle counts
# as a dimension: "10 %" is no angle, "1 rad" no friction coefficient); a case file
# with three errors has all three reported, each with its line, before exit status 2.
# Prints "PASS name" / "FAIL name: why".  Run from the repository root with $SPRAYCOAT_BIN.
set -u
bin=${SPRAYCOAT_BIN:-build/spraycoat}
tmp=$(mktemp -d) || { echo "FAIL cli_units_setup: mktemp -d failed"; exit 1; }
trap 'rm -rf "$tmp"' EXIT
pass() { echo "PASS $1"; }
fail() { echo "FAIL $1: $2"; }

cp cases/demo.ini cases/*.csv "$tmp/"
# with_value KEY VALUE OUT: the demo with KEY = VALUE in place of its own line
with_value() { sed "s/^$1 = .*/$1 = $2/" "$tmp/demo.ini" >"$3"; }
hash_of() { sed -n 's/^case hash \([0-9a-f]*\): OK$/\1/p' "$1"; }

with_value standoff "30 mm" "$tmp/a.ini"
sed -i 's/^median_diameter = .*/median_diameter = 20 um/' "$tmp/a.ini"
printf 'T_initial = 25 degC\n' >>"$tmp/a.ini" # the last section is [material.aluminium]
"$bin" check "$tmp/a.ini" >"$tmp/a.out" 2>"$tmp/a.err"
status=$?
why=""
[ "$status" -eq 0 ] || why="exit status $status: $(head -c 300 "$tmp/a.err");"
for shown in "standoff *= 30 mm = 0.03 m " "median_diameter *= 20 um = 2e-05 m " "T_initial *= 25 degC = 298.15 K "; do
    grep -q "$shown" "$tmp/a.out" || why="$why check does not list \"$shown\";"
done
if [ -z "$why" ]; then pass cli_units_listed; else fail cli_units_listed "$why"; fi

# the same case as the bare SI numbers (without the T_initial line, whose degC sum is rounded)
sed '$d' "$tmp/a.ini" >"$tmp/b.ini"
"$bin" check "$tmp/b.ini" >"$tmp/b.out" 2>&1
"$bin" check "$tmp/demo.ini" >"$tmp/demo.out" 2>&1
if [ -n "$(hash_of "$tmp/b.out")" ] && [ "$(hash_of "$tmp/b.out")" = "$(hash_of "$tmp/demo.out")" ]; then
    pass cli_units_same_hash
else
    fail cli_units_same_hash "hash with units \"$(hash_of "$tmp/b.out")\", bare \"$(hash_of "$tmp/demo.out")\""
fi

# check_refused NAME SECTION KEY TEXT...: `check` of $tmp/NAME.ini exits 2 and stderr holds FILE:LINE of KEY's line,
# [SECTION] KEY and every TEXT
check_refused() {
    name=$1 section=$2 key=$3
    shift 3
    line=$(grep -n "^$key = " "$tmp/$name.ini" | cut -d: -f1)
    "$bin" check "$tmp/$name.ini" >"$tmp/$name.out" 2>"$tmp/$name.err"
    status=$?
    why=""
    [ "$status" -eq 2 ] || why="exit status $status, expected 2;"
    for text in "$tmp/$name.ini:$line: [$section] $key" "$@"; do
        grep -qF -- "$text" "$tmp/$name.err" || why="$why stderr lacks \"$text\";"
    done
    if [ -z "$why" ]; then pass "$name"; else fail "$name" "$why $(head -c 300 "$tmp/$name.err")"; fi
}

# refused NAME VALUE TEXT...: standoff = VALUE exits 2 and stderr holds FILE:LINE, the key and every TEXT
refused() {
    name=$1
    with_value standoff "$2" "$tmp/$name.ini"
    shift 2
    check_refused "$name" target standoff "$@"
}
refused cli_units_wrong_dimension "30 s" 'unit "s"' 'unit "m"'
refused cli_units_unknown "30 furlongz" 'unknown unit "furlongz"' 'unit is "m"'
refused cli_units_out_of_range "3 km" "out of range (3000 m)" "allowed: > 0 and <= 100 m"

# angles: UDUNITS-2 counts rad, degree and sr as dimensionless, so that "10 %" converted to 5.73 degree and
# "2 degree" to 0.0349; an angle key takes angle units only, a dimensionless key none.
# unit_refused NAME SECTION KEY VALUE TEXT...: the demo with KEY = VALUE as the first line of [SECTION] exits 2 and
# stderr holds FILE:LINE, the key and every TEXT
unit_refused() {
    name=$1 section=$2 key=$3
    sed "s/^\[$section\]\$/[$section]\n$key = $4/" "$tmp/demo.ini" >"$tmp/$name.ini"
    shift 4
    check_refused "$name" "$section" "$key" "$@"
}
unit_refused cli_units_angle_percent impact angle "10 %" 'unit "%" is not an angle' 'rad, degree'
unit_refused cli_units_angle_steradian impact angle "0.5 sr" 'unit "sr"' 'unit "degree"'
unit_refused cli_units_fraction_degree impact pbcp_threshold "2 degree" 'unit "degree" is an angle' 'dimensionless'
unit_refused cli_units_friction_radian powder friction "1 rad" 'unit "rad" is an angle' 'dimensionless'
sed 's/^\[impact\]$/[impact]\nangle = 0.5 rad\npbcp_threshold = 5 %/' "$tmp/demo.ini" >"$tmp/angles.ini"
"$bin" check "$tmp/angles.ini" >"$tmp/angles.out" 2>&1
why=""
for shown in "angle *= 0.5 rad = 28.647889756541" "pbcp_threshold *= 5 % = 0.05 "; do
    grep -q "$shown" "$tmp/angles.out" || why="$why check does not list \"$shown\";"
done
if [ -z "$why" ]; then pass cli_units_angles_kept; else fail cli_units_angles_kept "$why $(head -c 300 "$tmp/angles.out")"; fi

# a number in the unit is refused, not multiplied in: UDUNITS-2 reads "800 m/s 2" as 1600 m/s and "30 mm (2)" as
# 0.06 m, which check listed as accepted
factor_refused() { # NAME SECTION KEY VALUE: the demo's KEY = VALUE refused, naming the unit and what is allowed
    sed "s|^$3 = .*|$3 = $4|" "$tmp/demo.ini" >"$tmp/$1.ini"
    check_refused "$1" "$2" "$3" "= $4: the unit \"" "numeric factor" \
        "allowed: a value and a unit without a numeric factor"
}
factor_refused cli_units_factor_after_quotient spray release_speed_max "800 m/s 2"
factor_refused cli_units_factor_after_prefix target standoff "30 mm 2"
factor_refused cli_units_factor_parenthesised target standoff "30 mm (2)"
# the documented forms stay: prefixes, degC, powers attached to their unit (m2, m3, s-1, m^2, m**2)
sed -e 's/^\[powder\]$/[powder]\nsurface_energy = 46 mJ\/m2/' -e 's/^density = 2700$/density = 2.7 g\/cm3/' \
    -e 's/^\[jet\]$/[jet]\ngas_viscosity = 25 mm2\/s/' -e 's/^median_diameter = .*/median_diameter = 20 um/' \
    -e 's/^release_speed_max = .*/release_speed_max = 800 m.s-1/' -e 's/^release_speed_min = .*/release_speed_min = 600 m s^-1/' \
    -e 's/^\[impact\]$/[impact]\nGc_rate = 2e11 J m**-2 s-1\neps_rate_c = 1e5 Hz/' \
    -e 's/^\[material.aluminium\]$/[material.aluminium]\nT_initial = 25 degC\ndensity = 2700 kg\/m^3/' \
    "$tmp/demo.ini" >"$tmp/forms.ini"
"$bin" check "$tmp/forms.ini" >"$tmp/forms.out" 2>"$tmp/forms.err"
status=$?
why=""
[ "$status" -eq 0 ] || why="exit status $status: $(head -c 300 "$tmp/forms.err");"
for shown in "surface_energy *= 46 mJ/m2 = 0.046 J/m2" "density *= 2.7 g/cm3 = 2700 kg/m3" \
    "gas_viscosity *= 25 mm2/s = 2.5e-05 m2/s" "release_speed_max *= 800 m.s-1 = 800 m/s" \
    "release_speed_min *= 600 m s^-1 = 600 m/s" "Gc_rate *= 2e11 J m\*\*-2 s-1 = 2e+11 J/m2/s" \
    "eps_rate_c *= 1e5 Hz = 100000 1/s" "density *= 2700 kg/m^3 = 2700 kg/m3"; do
    grep -q "$shown" "$tmp/forms.out" || why="$why check does not list \"$shown\";"
done
if [ -z "$why" ]; then pass cli_units_documented_forms_kept; else fail cli_units_documented_forms_kept "$why"; fi

# three errors: a value out of range, an unknown key, a unit of another dimension; all three, with their lines
with_value dt 0 "$tmp/three.ini"
sed -i -e 's/^standoff = .*/standoff = 30 s/' -e 's/^median_diameter = .*/median_diamter = 20e-6/' "$tmp/three.ini"
"$bin" check "$tmp/three.ini" >"$tmp/three.out" 2>"$tmp/three.err"
status=$?
why=""
[ "$status" -eq 2 ] || why="exit status $status, expected 2;"
for key in dt median_diamter standoff; do
    line=$(grep -n "^$key = " "$tmp/three.ini" | cut -d: -f1)
    grep -q "^spraycoat: $tmp/three.ini:$line: \[[a-z]*\] $key = " "$tmp/three.err" ||
        why="$why no error for line $line ($key);"
done
grep -q "3 errors in the case file" "$tmp/three.err" || why="$why no count of 3 errors;"
[ ! -s "$tmp/three.out" ] || why="$why stdout not empty;"
if [ -z "$why" ]; then pass cli_check_every_error; else fail cli_check_every_error "$why $(cat "$tmp/three.err")"; fi

# without the units database: values with a unit are refused with a message that says where it was looked for
# and how to fix it; a case of bare numbers needs no database (it is read only for a value with a unit)
UDUNITS2_XML_PATH=$tmp/none/udunits2.xml "$bin" check "$tmp/a.ini" >/dev/null 2>"$tmp/nodb.err"
status=$?
UDUNITS2_XML_PATH=$tmp/none/udunits2.xml "$bin" check "$tmp/demo.ini" >/dev/null 2>&1
bare=$?
why=""
[ "$status" -eq 2 ] || why="exit status $status with units, expected 2;"
grep -qF "$tmp/none/udunits2.xml" "$tmp/nodb.err" && grep -q "UDUNITS2_XML_PATH" "$tmp/nodb.err" ||
    why="$why the message does not name the database and UDUNITS2_XML_PATH;"
[ "$bare" -eq 0 ] || why="$why a case of bare numbers fails without the database (status $bare);"
if [ -z "$why" ]; then pass cli_units_no_database; else fail cli_units_no_database "$why $(head -c 300 "$tmp/nodb.err")"; fi
