#!/bin/sh
# Every output records how the program was built: the group /code of spray.h5 and impact.h5 (a short spray and
# a short impact) holds the build record of core/version.h as text attributes, none of them empty; the semantic
# version is that of the file VERSION (MAJOR.MINOR.PATCH); the flags state -ffp-contract=off (bit-identical
# results must not rest on a compiler default); isa names the instruction-set level the kernels ran with
# (core/isa.h), and SPRAYCOAT_ISA=v2 changes it in /code and in --version alike; and `spraycoat --version` prints
# the same record, the semantic version on its first line and the git description as "git".
# Run from the repository root with $SPRAYCOAT_BIN (tests/run_tests.sh sets it).  Needs h5dump.
set -u
BIN=${SPRAYCOAT_BIN:-build/spraycoat}
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
pass() { echo "PASS $1"; }
fail() { echo "FAIL $1: $2"; }

if ! command -v h5dump >/dev/null 2>&1; then
    fail code_group "h5dump is missing (hdf5-tools)"
    exit 1
fi

# attr FILE NAME: the text attribute /code/NAME of FILE ("" when absent)
attr() { h5dump -a "/code/$2" "$1" 2>/dev/null | sed -n 's/^ *(0): "\(.*\)"$/\1/p'; }

# check NAME FILE [LEVEL]: every entry of the record present and not empty, the flags with -ffp-contract=off
check() {
    why=""
    [ -f "$2" ] || { fail "$1" "$2 was not written"; return; }
    for name in version program_version sources_id compiler flags file_flags target isa openmp hdf5 sundials cairo osmesa inih mpi; do
        [ -n "$(attr "$2" "$name")" ] || why="$why /code/$name missing or empty;"
    done
    case "$(attr "$2" flags)" in
    *-ffp-contract=off*) ;;
    *) why="$why /code/flags \"$(attr "$2" flags)\" lacks -ffp-contract=off;" ;;
    esac
    semver=$(cat VERSION)
    echo "$semver" | grep -Eqx '[0-9]+\.[0-9]+\.[0-9]+' || why="$why VERSION \"$semver\" is not MAJOR.MINOR.PATCH;"
    [ "$(attr "$2" version)" = "$semver" ] || why="$why /code/version \"$(attr "$2" version)\" is not VERSION's;"
    version=$("$BIN" --version | head -n 1)
    [ "spraycoat $(attr "$2" version)" = "$version" ] ||
        why="$why /code/version \"$(attr "$2" version)\" is not that of --version (\"$version\");"
    SPRAYCOAT_ISA=${3:-} "$BIN" --version >"$T/version.txt"
    grep -qxF "  $(printf '%-12s' git) $(attr "$2" program_version)" "$T/version.txt" ||
        why="$why --version does not print the git description /code/program_version;"
    for name in compiler flags isa hdf5 sundials; do
        grep -qxF "  $(printf '%-12s' "$name") $(attr "$2" "$name")" "$T/version.txt" ||
            why="$why --version does not print /code/$name \"$(attr "$2" "$name")\";"
    done
    if [ -z "$why" ]; then pass "$1"; else fail "$1" "$why"; fi
}

awk '/^\[/ { section = $0 } section == "[spray]" && /^t_end = / { $0 = "t_end = 2e-4" } { print }' \
    cases/demo.ini >"$T/spray.ini"
cp cases/vcrit_al.csv "$T/" # the demo's v_crit(d) table, a path relative to the case
"$BIN" spray "$T/spray.ini" -o "$T/spray" >"$T/spray.log" 2>&1 ||
    fail code_group_spray "the spray failed: $(tail -n 2 "$T/spray.log" | tr '\n' ' ')"
check code_group_spray "$T/spray/spray.h5"

sed 's/^t_end = .*/t_end = 2e-9/' cases/impact_demo.ini >"$T/impact.ini"
"$BIN" impact "$T/impact.ini" -o "$T/impact" >"$T/impact.log" 2>&1 ||
    fail code_group_impact "the impact failed: $(tail -n 2 "$T/impact.log" | tr '\n' ' ')"
check code_group_impact "$T/impact/impact.h5"

# a forced level is the one /code records (on x86-64 builds with the per-level kernels; every such CPU runs v2)
case "$("$BIN" --version | sed -n 's/^ *isa *//p')" in
x86-64-v*)
    SPRAYCOAT_ISA=v2 "$BIN" impact "$T/impact.ini" -o "$T/impact_v2" >"$T/impact_v2.log" 2>&1 ||
        fail code_group_isa "the impact with SPRAYCOAT_ISA=v2 failed: $(tail -n 2 "$T/impact_v2.log" | tr '\n' ' ')"
    check code_group_isa "$T/impact_v2/impact.h5" v2
    case "$(attr "$T/impact_v2/impact.h5" isa)" in
    "x86-64-v2 (SPRAYCOAT_ISA=v2;"*) pass code_group_isa_forced ;;
    *) fail code_group_isa_forced "/code/isa is \"$(attr "$T/impact_v2/impact.h5" isa)\" with SPRAYCOAT_ISA=v2" ;;
    esac ;;
esac
