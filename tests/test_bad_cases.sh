#!/bin/sh
# Bad case files (tests/bad_cases/, listed in tests/bad_cases/EXPECT): `spraycoat check FILE` and
# `spraycoat COMMAND FILE -o RUN_DIR` (spray, or the impact, vcrit or calibrate command the manifest names) must end with
# exit status 2 and a message that names the key, the file (and the line, where the error is in a line); never
# a crash, and never a partial output in RUN_DIR.
# Also: a case with one empty section, a case without some sections and a CSV with a byte order mark are
# valid (every key has a default), an empty case file is not; a bad case
# run into an existing run directory leaves it as it was; a few bad cases run under valgrind without memory
# errors.  Prints "PASS name" / "FAIL name: why" (tests/run_tests.sh counts them).  Run from the repo root.
set -u
bin=${SPRAYCOAT_BIN:-build/spraycoat}
cases=tests/bad_cases
manifest=$cases/EXPECT
tab=$(printf '\t')

tmp=$(mktemp -d) || { echo "FAIL bad_cases_setup: mktemp -d failed"; exit 1; }
trap 'rm -rf "$tmp"' EXIT
trap 'exit 130' INT
trap 'exit 143' TERM
gen=$tmp/gen
mkdir "$gen"

if [ ! -x "$bin" ]; then
    echo "FAIL bad_cases_setup: no executable $bin (SPRAYCOAT_BIN)"
    exit 1
fi
if [ ! -r "$manifest" ]; then
    echo "FAIL bad_cases_setup: cannot read $manifest"
    exit 1
fi

# ---- bad cases that are not committed as text: written here, deterministically -------------------------

# binary_garbage.ini: 400 bytes from a fixed linear congruential sequence, starting with a NUL byte (so the
# error is on line 1, column 1) and holding more NULs and bytes >= 0x80 further on.
x=12345
i=0
{
    printf '\000\001\377\376'
    while [ $i -lt 396 ]; do
        x=$(( (x * 1103515245 + 12345) % 2147483648 ))
        b=$(( (x / 65536) % 256 ))
        [ $((i % 37)) -eq 0 ] && b=0
        # shellcheck disable=SC2059 # an octal escape built from the byte value
        printf "\\$(printf '%03o' "$b")"
        i=$((i + 1))
    done
} >"$gen/binary_garbage.ini"

# nul_in_value.ini: a text case with a NUL byte inside the value of line 5.
{
    printf '; BAD CASE: a NUL byte inside the value on line 5 (written by tests/test_bad_cases.sh)\n'
    printf '; the error must say: must be UTF-8 text\n'
    printf '[spray]\n'
    printf 't_end = 5e-4\n'
    printf 'dt = 1e-6\0000\n'
    printf 'nozzle_radius = 0.005\n'
} >"$gen/nul_in_value.ini"

# utf16_case.ini: "[spray]\ndt = 1e-6\n" saved as UTF-16LE with a byte-order mark.
printf '\377\376[\000s\000p\000r\000a\000y\000]\000\n\000d\000t\000 \000=\000 \0001\000e\000-\0006\000\n\000' \
    >"$gen/utf16_case.ini"

# cr_line_endings.ini: the valid base saved with old Mac line endings (CR only): one "line" to a line reader.
tr '\n' '\r' <"$cases/valid_base.ini" >"$gen/cr_line_endings.ini"

# empty_case.ini and comments_only_case.ini: no [section] at all (an empty or wrong file, not a case).
: >"$gen/empty_case.ini"
printf '; only a comment\n\n# and another\n' >"$gen/comments_only_case.ini"

# huge_file.ini: 17 MiB of ';' (one long comment line), above the 16 MiB limit for a case file.
dd if=/dev/zero bs=1048576 count=17 2>/dev/null | tr '\000' ';' >"$gen/huge_file.ini"

# ---- helpers ------------------------------------------------------------------------------------------------

case_path() { # the committed file, else the generated one, else nothing
    if [ -f "$cases/$1" ]; then
        echo "$cases/$1"
    elif [ -f "$gen/$1" ]; then
        echo "$gen/$1"
    fi
}

# describe_status STATUS: "exit status N" or "killed by signal N (a crash)"
describe_status() {
    if [ "$1" -ge 128 ]; then
        echo "exit status $1: killed by signal $(($1 - 128)) (a crash)"
    else
        echo "exit status $1"
    fi
}

# partial_output RUN_DIR: what a failed run left in RUN_DIR besides case.ini (empty if nothing)
partial_output() {
    [ -d "$1" ] || return 0
    find "$1" ! -path "$1" ! -name case.ini -print 2>/dev/null | sed "s|^$1/||" | tr '\n' ' '
}

# check_failure LABEL STATUS STDERR_FILE TEXT FILE LINE: reasons why the run is not a proper exit-2 failure
check_failure() {
    why=""
    if [ "$2" -ne 2 ]; then
        why="$why; $(describe_status "$2"), expected 2"
    fi
    if ! grep -qF -- "$4" "$3"; then
        why="$why; message does not contain '$4'"
    fi
    base=$(basename "$5")
    if ! grep -qF -- "$base" "$3"; then
        why="$why; message does not name the file $base"
    fi
    if [ "$6" != "-" ] && ! grep -qF -- "$base:$6:" "$3"; then
        why="$why; message does not give the line as '$base:$6:'"
    fi
    if ! grep -q '^spraycoat: ' "$3"; then
        why="$why; no 'spraycoat: ' error line"
    fi
    echo "$why"
}

first_error_line() { # the message, shortened, for FAIL lines
    grep '^spraycoat: ' "$1" | head -n 1 | cut -c1-400
}

# ---- every manifest entry: check and its stage command --------------------------------------------------

count=0
while IFS="$tab" read -r file text line command rest; do
    case "$file" in '' | '#'*) continue ;; esac
    [ -n "${line:-}" ] || line=-
    [ -n "${command:-}" ] || command=spray
    case "$command" in
    spray | impact | vcrit | calibrate | run) ;;
    *)
        echo "FAIL bad_case_${file%.ini}: unknown command '$command' in $manifest"
        continue
        ;;
    esac
    name=${file%.ini}
    count=$((count + 1))
    path=$(case_path "$file")
    if [ -z "$path" ]; then
        echo "FAIL bad_case_$name: case file $file is neither in $cases nor generated by this script"
        continue
    fi
    why=""
    # spraycoat check FILE
    "$bin" check "$path" >"$tmp/out" 2>"$tmp/err" </dev/null
    status=$?
    w=$(check_failure check "$status" "$tmp/err" "$text" "$path" "$line")
    [ -n "$w" ] && why="$why; check:${w#;}"
    if [ -s "$tmp/out" ]; then
        why="$why; check: printed to stdout ($(head -c 120 "$tmp/out" | tr '\n' ' ')...)"
    fi
    [ -n "$w" ] && why="$why [stderr: $(first_error_line "$tmp/err")]"
    # spraycoat spray|impact|vcrit FILE -o RUN_DIR
    run=$tmp/run_$name
    "$bin" "$command" "$path" -o "$run" >"$tmp/out" 2>"$tmp/err" </dev/null
    status=$?
    w=$(check_failure "$command" "$status" "$tmp/err" "$text" "$path" "$line")
    [ -n "$w" ] && why="$why; $command:${w#;} [stderr: $(first_error_line "$tmp/err")]"
    left=$(partial_output "$run")
    [ -n "$left" ] && why="$why; $command: partial output left in the run directory: $left"
    rm -rf "$run"
    if [ -z "$why" ]; then
        echo "PASS bad_case_$name"
    else
        echo "FAIL bad_case_$name:${why#;}"
    fi
done <"$manifest"

if [ "$count" -ge 25 ]; then
    echo "PASS bad_cases_manifest_size"
else
    echo "FAIL bad_cases_manifest_size: $manifest lists $count bad cases, expected at least 25"
fi

# Every committed .ini in tests/bad_cases/ is in the manifest (or is a valid base), so none is forgotten.
missing=""
for f in "$cases"/*.ini; do
    b=$(basename "$f")
    case "$b" in valid_*.ini) continue ;; esac
    grep -q "^$b$tab" "$manifest" || missing="$missing $b"
done
if [ -z "$missing" ]; then
    echo "PASS bad_cases_all_listed"
else
    echo "FAIL bad_cases_all_listed: not in $manifest:$missing"
fi

# ---- what is not an error ---------------------------------------------------------------------------------

# The bases that the bad cases vary are valid: each bad case fails for its one change.
if "$bin" check "$cases/valid_base.ini" >"$tmp/out" 2>"$tmp/err"; then
    echo "PASS bad_cases_base_is_valid"
else
    echo "FAIL bad_cases_base_is_valid: check $cases/valid_base.ini: $(first_error_line "$tmp/err")"
fi
if "$bin" check "$cases/valid_impact_base.ini" >"$tmp/out" 2>"$tmp/err" &&
    grep -q '^\[impact\] grid .*2e-6' "$tmp/out"; then
    echo "PASS bad_cases_impact_base_is_valid"
else
    echo "FAIL bad_cases_impact_base_is_valid: check $cases/valid_impact_base.ini: $(first_error_line "$tmp/err")"
fi

# couple_window_patch_too_wide.ini: with sample = window a lone body lands anywhere in the window, so the message
# offers what helps (a smaller patch_size, at most 7.071 um here, or a wider substrate), not bodies_per_run = 1,
# which the case has; the largest patch it names passes.
why=""
"$bin" check "$cases/couple_window_patch_too_wide.ini" >"$tmp/out" 2>"$tmp/err"
status=$?
[ "$status" -eq 2 ] || why="$why; $(describe_status $status), expected 2"
grep -q 'window .*allowed: at most 7\.071 um .*or a wider substrate' "$tmp/err" ||
    why="$why; no 'allowed: at most 7.071 um ... or a wider substrate' in: $(first_error_line "$tmp/err")"
grep -q 'bodies_per_run = 1' "$tmp/err" && why="$why; offers bodies_per_run = 1, which the case has"
sed 's/^patch_size = 40e-6$/patch_size = 7.07e-6/' "$cases/couple_window_patch_too_wide.ini" >"$tmp/window_fits.ini"
"$bin" check "$tmp/window_fits.ini" >"$tmp/out" 2>"$tmp/err" ||
    why="$why; a 7.07 um window exited $?: $(first_error_line "$tmp/err")"
if [ -z "$why" ]; then
    echo "PASS bad_cases_window_patch_remedy"
else
    echo "FAIL bad_cases_window_patch_remedy:${why#;}"
fi

# An empty case file is refused (see empty_case.ini above); one section, even an empty one, is enough, and every
# key has a default: check prints them.
printf '[run]\n' >"$tmp/one_section.ini"
"$bin" check "$tmp/one_section.ini" >"$tmp/out" 2>"$tmp/err"
status=$?
why=""
[ "$status" -eq 0 ] || why="$why; $(describe_status $status), expected 0: $(first_error_line "$tmp/err")"
grep -q '^\[spray\] dt .*2e-6.*(default)' "$tmp/out" || why="$why; no '[spray] dt = 2e-6 ... (default)' line"
grep -q '^\[target\] standoff .*0\.3.*(default)' "$tmp/out" || why="$why; no '[target] standoff = 0.3 ... (default)' line"
grep -q 'OK' "$tmp/out" || why="$why; no final OK line"
if grep '^\[' "$tmp/out" | grep -v '(default)' | grep -qv '(unset)'; then
    why="$why; a key of a case with one empty section is neither (default) nor (unset): $(grep '^\[' "$tmp/out" |
        grep -v '(default)' | grep -v '(unset)' | head -1)"
fi
if [ -z "$why" ]; then
    echo "PASS bad_cases_one_empty_section_is_valid"
else
    echo "FAIL bad_cases_one_empty_section_is_valid:${why#;}"
fi

# A CSV saved by Excel as "CSV UTF-8" starts with a byte order mark: accepted (particles and bodies CSV).
for base in particles_bad_diameter:particles impact_bodies_overlap:bodies; do
    name=${base%%:*}
    kind=${base#*:}
    sed "s/$name.csv/bom.csv/" "$cases/$name.ini" >"$tmp/bom_$kind.ini"
    if [ "$kind" = particles ]; then
        printf '\357\273\277x,y,z,vx,vy,vz,wx,wy,wz,d\r\n0,0,0.001,0,0,30,0,0,0,40e-6\r\n' >"$tmp/bom.csv"
    else
        printf '\357\273\277shape,x,y,z,vx,vy,vz,d,h,material\r\nsphere,0,0,4e-6,0,0,-810,8e-6,0,aluminium\r\n' \
            >"$tmp/bom.csv"
    fi
    if "$bin" check "$tmp/bom_$kind.ini" >"$tmp/out" 2>"$tmp/err"; then
        echo "PASS bad_cases_${kind}_csv_with_bom_is_valid"
    else
        echo "FAIL bad_cases_${kind}_csv_with_bom_is_valid: $(first_error_line "$tmp/err")"
    fi
done

# Missing sections are fine too: only [spray] and [target] given, comments and blank lines only elsewhere.
printf '; only two sections\n\n[spray]\nt_end = 5e-4\n\n[target]\nstandoff = 0.05\n\n; the end\n' >"$tmp/sparse.ini"
if "$bin" check "$tmp/sparse.ini" >"$tmp/out" 2>"$tmp/err" &&
    grep -q '^\[spray\] t_end .*5e-4' "$tmp/out" && grep -q '^\[jet\] model .*bickley.*(default)' "$tmp/out"; then
    echo "PASS bad_cases_missing_sections_are_valid"
else
    echo "FAIL bad_cases_missing_sections_are_valid: check of a case without [run], [powder], [jet] ...:" \
        "$(first_error_line "$tmp/err")"
fi

# ---- a bad case must not damage an existing run directory -------------------------------------------------

good=$tmp/good_run
if "$bin" spray "$cases/valid_base.ini" -o "$good" --threads 1 >/dev/null 2>"$tmp/err" && [ -f "$good/spray.h5" ]; then
    cp -p "$good/spray.h5" "$tmp/spray.h5.before"
    cp -p "$good/case.ini" "$tmp/case.ini.before"
    for bad in handoff_above_standoff.ini missing_particles_csv.ini unknown_key_typo.ini; do
        name=${bad%.ini}
        "$bin" spray "$cases/$bad" -o "$good" >/dev/null 2>"$tmp/err"
        status=$?
        why=""
        [ "$status" -eq 2 ] || why="$why; $(describe_status $status), expected 2"
        cmp -s "$good/spray.h5" "$tmp/spray.h5.before" || why="$why; spray.h5 of the earlier run was changed"
        cmp -s "$good/case.ini" "$tmp/case.ini.before" ||
            why="$why; case.ini of the earlier run was overwritten with the bad case (resume would now use it)"
        left=$(find "$good" \( -name '*.tmp' -o -name checkpoints \) -print | tr '\n' ' ')
        [ -n "$left" ] && why="$why; left behind: $left"
        if [ -z "$why" ]; then
            echo "PASS bad_case_keeps_run_dir_$name"
        else
            echo "FAIL bad_case_keeps_run_dir_$name:${why#;}"
            cp -p "$tmp/case.ini.before" "$good/case.ini"
        fi
    done
else
    echo "FAIL bad_case_keeps_run_dir: the valid base did not run: $(first_error_line "$tmp/err")"
fi

# ---- memory errors on the error paths -----------------------------------------------------------------------

if [ -n "${SPRAYCOAT_SANITIZED:-}" ]; then
    echo "note: SPRAYCOAT_SANITIZED is set (ASan build): valgrind checks skipped"
elif ! command -v valgrind >/dev/null 2>&1; then
    echo "note: valgrind not found: valgrind checks skipped"
else
    for spec in "check binary_garbage.ini" "spray particles_csv_nan.ini" "check unknown_key_typo.ini" \
        "spray table_not_hdf5.ini"; do
        command=${spec%% *}
        file=${spec#* }
        name=${file%.ini}
        path=$(case_path "$file")
        run=$tmp/vg_run_$name
        if [ "$command" = spray ]; then
            valgrind --error-exitcode=99 -q "$bin" spray "$path" -o "$run" >/dev/null 2>"$tmp/err"
        else
            valgrind --error-exitcode=99 -q "$bin" check "$path" >/dev/null 2>"$tmp/err"
        fi
        status=$?
        rm -rf "$run"
        if [ "$status" -eq 2 ] && ! grep -q '^==[0-9]*==' "$tmp/err"; then
            echo "PASS bad_case_valgrind_${command}_$name"
        else
            echo "FAIL bad_case_valgrind_${command}_$name: $(describe_status $status) under valgrind" \
                "(99 = memory errors), expected 2: $(grep '^==[0-9]*==' "$tmp/err" | head -n 3 | tr '\n' ' ')" \
                "$(first_error_line "$tmp/err")"
        fi
    done
fi
exit 0
