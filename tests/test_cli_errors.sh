#!/bin/sh
# Command-line errors and I/O errors (docs/architecture.md: exit status 2 for a bad command line or case
# file, 3 for an I/O error).  A bad command line exits 2 with a message; --help and --version exit 0; an I/O
# error exits 3 with the path in the message, never with a crash, and damages nothing that was there before:
# a run directory under a regular file, a file-size limit (ulimit -f) while writing spray.h5 or a checkpoint,
# `info` of a missing or non-HDF5 file.  Prints "PASS name" / "FAIL name: why".  Run from the repo root.
set -u
bin=${SPRAYCOAT_BIN:-build/spraycoat}
base=tests/bad_cases/valid_base.ini

tmp=$(mktemp -d) || { echo "FAIL cli_setup: mktemp -d failed"; exit 1; }
trap 'rm -rf "$tmp"' EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

if [ ! -x "$bin" ]; then
    echo "FAIL cli_setup: no executable $bin (SPRAYCOAT_BIN)"
    exit 1
fi
if [ ! -r cases/mz2015_demo.ini ] || [ ! -r "$base" ]; then
    echo "FAIL cli_setup: cases/mz2015_demo.ini or $base missing (run from the repository root)"
    exit 1
fi

describe_status() {
    if [ "$1" -ge 128 ]; then
        echo "exit status $1: killed by signal $(($1 - 128)) (a crash)"
    else
        echo "exit status $1"
    fi
}

first_error_line() { grep '^spraycoat: ' "$1" | head -n 1 | cut -c1-300; }

# expect NAME STATUS TEXT COMMAND...: run COMMAND; it must exit with STATUS; for STATUS 0 stdout must contain
# TEXT and stderr be empty, otherwise stderr must hold a "spraycoat: " line containing TEXT and stdout be empty.
# Sets $why (empty when all is well) and prints nothing: the caller adds its own checks and calls report.
expect() {
    _status_wanted=$2
    _text=$3
    shift 3
    "$@" >"$tmp/out" 2>"$tmp/err"
    _status=$?
    why=""
    if [ "$_status" -ne "$_status_wanted" ]; then
        why="$why; $(describe_status "$_status"), expected $_status_wanted"
    fi
    if [ "$_status_wanted" -eq 0 ]; then
        grep -qF -- "$_text" "$tmp/out" || why="$why; stdout does not contain '$_text'"
        [ -s "$tmp/err" ] && why="$why; unexpected stderr: $(head -c 200 "$tmp/err")"
    else
        grep -q '^spraycoat: ' "$tmp/err" || why="$why; no 'spraycoat: ' error line on stderr"
        grep -qF -- "$_text" "$tmp/err" || why="$why; message does not contain '$_text'"
        [ -s "$tmp/out" ] && why="$why; printed to stdout: $(head -c 120 "$tmp/out" | tr '\n' ' ')"
    fi
    if [ -n "$why" ] && [ -s "$tmp/err" ]; then
        why="$why [stderr: $(first_error_line "$tmp/err")]"
    fi
}

report() { # report NAME: PASS or FAIL with $why
    if [ -z "$why" ]; then
        echo "PASS $1"
    else
        echo "FAIL $1:${why#;}"
    fi
}

run1() { expect "$@"; report "$1"; } # a test with no further checks

# ---- the command line: exit 2 with a message, --help and --version exit 0 ---------------------------------

run1 cli_no_command 2 "no command" "$bin"
run1 cli_unknown_command 2 "frobnicate" "$bin" frobnicate cases/mz2015_demo.ini
run1 cli_unknown_option 2 "--bogus" "$bin" check --bogus cases/mz2015_demo.ini
run1 cli_o_without_value 2 "-o" "$bin" spray "$base" -o
run1 cli_threads_without_value 2 "--threads" "$bin" check "$base" --threads
run1 cli_threads_not_integer 2 "threads" "$bin" check "$base" --threads abc
run1 cli_threads_out_of_range 2 "threads" "$bin" check "$base" --threads -1
run1 cli_extra_argument 2 "extra_arg" "$bin" check "$base" extra_arg
run1 cli_check_without_case 2 "case file" "$bin" check
run1 cli_spray_without_case 2 "case file" "$bin" spray
run1 cli_impact_without_case 2 "case file" "$bin" impact
run1 cli_vcrit_without_case 2 "case file" "$bin" vcrit
# a stage whose input is missing: exit 3 naming the missing file and the stage to run first
run1 cli_couple_without_spray 3 "spray.h5 is missing" "$bin" couple "$base" -o "$tmp/run_couple"
run1 cli_impact_of_run_without_couple 3 "couple.h5 is missing" "$bin" run cases/demo.ini --stages impact -o "$tmp/run_impact"
run1 cli_info_without_target 2 "info" "$bin" info
run1 cli_resume_without_dir 2 "run directory" "$bin" resume
# resume continues the run directory where it is: an -o would be ignored (the results went on into RUN_DIR)
mkdir -p "$tmp/resume_o" && cp "$base" "$tmp/resume_o/case.ini"
run1 cli_resume_with_o 2 "resume continues $tmp/resume_o where it is; -o goes with run" "$bin" resume "$tmp/resume_o" -o "$tmp/elsewhere"
run1 cli_version_extra 2 "--version takes no other argument" "$bin" --version extra
expect cli_empty_run_dir 2 "run directory" "$bin" spray "$base" -o ""
report cli_empty_run_dir
run1 cli_help 0 "usage" "$bin" --help
run1 cli_help_short 0 "usage" "$bin" -h
run1 cli_help_after_command 0 "usage" "$bin" check --help
expect cli_version 0 "spraycoat " "$bin" --version
# the semantic version first (MAJOR.MINOR.PATCH), then the build record of /code (git description, compiler,
# flags, libraries)
head -n 1 "$tmp/out" | grep -Eqx 'spraycoat [0-9]+\.[0-9]+\.[0-9]+' ||
    why="$why; --version's first line is \"$(head -n 1 "$tmp/out")\""
for item in git compiler flags hdf5 sundials mpi omp_wait; do
    grep -q "^  $item  *[^ ]" "$tmp/out" || why="$why; --version has no $item line"
done
report cli_version

# ---- I/O errors: exit 3, the path in the message -----------------------------------------------------------

# A case file that does not exist, or is a folder: an I/O error (3), not a bad case (2); no run directory made.
expect io_missing_case_file 3 "$tmp/no_such_case.ini" "$bin" check "$tmp/no_such_case.ini"
report io_missing_case_file
expect io_missing_case_file_spray 3 "$tmp/no_such_case.ini" "$bin" spray "$tmp/no_such_case.ini" -o "$tmp/run_nocase"
[ -e "$tmp/run_nocase" ] && why="$why; the run directory was created for a case that could not be read"
report io_missing_case_file_spray
mkdir "$tmp/a_folder"
run1 io_case_file_is_folder 3 "$tmp/a_folder" "$bin" check "$tmp/a_folder"

# (a) The run directory cannot be made: a path under a regular file (permissions do not stop root).
printf 'not a folder\n' >"$tmp/afile"
expect io_run_dir_under_file 3 "$tmp/afile" "$bin" spray "$base" -o "$tmp/afile/run"
[ "$(cat "$tmp/afile")" = "not a folder" ] || why="$why; $tmp/afile was changed"
report io_run_dir_under_file
expect io_run_dir_is_file 3 "$tmp/afile: the run directory exists but is not a directory" "$bin" spray "$base" -o "$tmp/afile"
[ "$(cat "$tmp/afile")" = "not a folder" ] || why="$why; $tmp/afile was changed"
report io_run_dir_is_file
mkdir "$tmp/empty_dir"
run1 io_resume_not_a_run_dir 3 "$tmp/empty_dir" "$bin" resume "$tmp/empty_dir"

# (b) A file-size limit while writing (one thread: quick also on a busy machine).  ulimit -f counts 512-byte blocks in a POSIX shell: 50 blocks = 25 KiB,
# enough for case.ini, far too little for spray.h5 or a checkpoint of the short demo.  The program must report
# EFBIG as an I/O error (it ignores SIGXFSZ); being killed by SIGXFSZ (status 153) or crashing is a failure.
sed 's/^t_end *=.*/t_end = 5e-4/' cases/mz2015_demo.ini >"$tmp/short.ini"
sed 's/^checkpoint_steps *=.*/checkpoint_steps = 100/' "$tmp/short.ini" >"$tmp/short_ckpt.ini"
sed 's/^seed *=.*/seed = 8/' "$tmp/short.ini" >"$tmp/short_seed8.ini"
grep -q '^t_end = 5e-4' "$tmp/short.ini" && grep -q '^checkpoint_steps = 100' "$tmp/short_ckpt.ini" &&
    grep -q '^seed = 8' "$tmp/short_seed8.ini" || echo "FAIL io_setup: cannot make short copies of cases/mz2015_demo.ini"

# shellcheck disable=SC2317 # called through expect "$@"
limited() { # limited RUN_DIR CASE: spray CASE into RUN_DIR under ulimit -f 50
    (
        # shellcheck disable=SC3045 # ulimit -c: dash, bash and busybox sh have it; a failure is harmless
        ulimit -c 0 2>/dev/null # no core dump of a crash
        ulimit -f 50 || exit 97
        exec "$bin" spray "$2" -o "$1" --threads 1
    )
}

leftovers() { # temporary files in a run directory after a failed write
    find "$1" -name '*.tmp' -print 2>/dev/null | tr '\n' ' '
}

expect io_file_size_limit_output 3 "$tmp/limited" limited "$tmp/limited" "$tmp/short.ini"
[ -e "$tmp/limited/spray.h5" ] && why="$why; a spray.h5 was left in the run directory"
[ -n "$(leftovers "$tmp/limited")" ] && why="$why; temporary files left: $(leftovers "$tmp/limited")"
report io_file_size_limit_output

expect io_file_size_limit_checkpoint 3 "$tmp/limited_ckpt" limited "$tmp/limited_ckpt" "$tmp/short_ckpt.ini"
[ -e "$tmp/limited_ckpt/spray.h5" ] && why="$why; a spray.h5 was left in the run directory"
[ -n "$(find "$tmp/limited_ckpt" -name 'spray_*.h5' -print 2>/dev/null)" ] &&
    why="$why; a checkpoint was left: $(find "$tmp/limited_ckpt" -name 'spray_*.h5' -print | tr '\n' ' ')"
[ -n "$(leftovers "$tmp/limited_ckpt")" ] && why="$why; temporary files left: $(leftovers "$tmp/limited_ckpt")"
report io_file_size_limit_checkpoint

# A good run, then a run of another case (seed 8) into the same directory that fails under the limit: the good
# spray.h5 (and spray.xdmf, if the program writes one) must stay byte-identical and readable.
good=$tmp/good
if "$bin" spray "$tmp/short.ini" -o "$good" --threads 1 >/dev/null 2>"$tmp/err" && [ -f "$good/spray.h5" ]; then
    cp -p "$good/spray.h5" "$tmp/spray.h5.before"
    [ -f "$good/spray.xdmf" ] && cp -p "$good/spray.xdmf" "$tmp/spray.xdmf.before"
    expect io_file_size_limit_keeps_output 3 "$good" limited "$good" "$tmp/short_seed8.ini"
    cmp -s "$good/spray.h5" "$tmp/spray.h5.before" || why="$why; spray.h5 of the earlier good run was changed"
    if [ -f "$tmp/spray.xdmf.before" ]; then
        cmp -s "$good/spray.xdmf" "$tmp/spray.xdmf.before" || why="$why; spray.xdmf of the earlier run was changed"
    fi
    [ -n "$(leftovers "$good")" ] && why="$why; temporary files left: $(leftovers "$good")"
    "$bin" info "$good/spray.h5" >/dev/null 2>"$tmp/err2" ||
        why="$why; info of the kept spray.h5 fails: $(first_error_line "$tmp/err2")"
    report io_file_size_limit_keeps_output
else
    echo "FAIL io_file_size_limit_keeps_output: the short demo did not run: $(first_error_line "$tmp/err")"
fi

# (d) one process per run directory: a second run into a directory in use exits 3 and the first finishes.
busy=$tmp/busy
"$bin" spray cases/mz2015_demo.ini -o "$busy" --threads 1 >/dev/null 2>"$tmp/busy_first.err" &
first=$!
i=0
while [ ! -f "$busy/case.ini" ] && [ "$i" -lt 100 ]; do sleep 0.1; i=$((i + 1)); done
"$bin" spray cases/mz2015_demo.ini -o "$busy" --threads 1 >/dev/null 2>"$tmp/busy_second.err"
second=$?
wait "$first"
first_status=$?
if [ "$second" -eq 3 ] && grep -q 'in use' "$tmp/busy_second.err" && [ "$first_status" -eq 0 ] &&
    [ -f "$busy/spray.h5" ]; then
    echo "PASS io_run_dir_in_use"
else
    echo "FAIL io_run_dir_in_use: second run exit $second ($(first_error_line "$tmp/busy_second.err")), first run exit $first_status"
fi

# ---- inputs that are not regular files: refused at once, never read (a FIFO blocks, /dev/zero never ends) --
# Under `timeout 10`, so that a regression fails here instead of hanging the suite (124: timed out).
mkfifo "$tmp/fifo.ini" "$tmp/fifo.csv" 2>/dev/null || echo "FAIL nonregular_setup: mkfifo failed"
run1 input_case_file_fifo 2 "must be a regular file" timeout 10 "$bin" check "$tmp/fifo.ini"
run1 input_case_file_dev_zero 2 "must be a regular file" timeout 10 "$bin" check /dev/zero
particle_case=tests/bad_cases/particles_bad_diameter.ini
sed "s|^particles = .*|particles = /dev/zero|" "$particle_case" >"$tmp/particles_dev_zero.ini"
expect input_particles_dev_zero 2 "[spray] particles = /dev/zero: " timeout 10 "$bin" check "$tmp/particles_dev_zero.ini"
grep -q 'must be a regular file' "$tmp/err" || why="$why; message does not say 'must be a regular file'"
report input_particles_dev_zero
sed "s|^particles = .*|particles = $tmp/fifo.csv|" "$particle_case" >"$tmp/particles_fifo.ini"
run1 input_particles_fifo 2 "must be a regular file" timeout 10 "$bin" spray "$tmp/particles_fifo.ini" -o "$tmp/run_fifo"
sed "s|^rule = adhesion|rule = table\ntable = /dev/zero|" "$base" >"$tmp/table_dev_zero.ini"
grep -q '^table = /dev/zero' "$tmp/table_dev_zero.ini" || echo "FAIL nonregular_setup: no table line in $tmp/table_dev_zero.ini"
run1 input_table_dev_zero 2 "[deposition] table = /dev/zero: " timeout 10 "$bin" check "$tmp/table_dev_zero.ini"
sed "s|^rule = adhesion|rule = table\ntable = $tmp/fifo.h5|" "$base" >"$tmp/table_fifo_h5.ini"
mkfifo "$tmp/fifo.h5"
run1 input_table_h5_fifo 2 "[deposition] table" timeout 10 "$bin" check "$tmp/table_fifo_h5.ini"
sed "s|^bodies = .*|bodies = /dev/zero|" tests/bad_cases/impact_bodies_overlap.ini >"$tmp/bodies_dev_zero.ini"
run1 input_bodies_dev_zero 2 "[impact] bodies = /dev/zero: " timeout 10 "$bin" check "$tmp/bodies_dev_zero.ini"
# spray.h5 read by a later stage, and info: an I/O error (3)
mkdir -p "$tmp/run_h5_fifo"
mkfifo "$tmp/run_h5_fifo/spray.h5"
# (couple refuses it as an input that is not this case's spray.h5, without opening it as HDF5)
run1 input_spray_h5_fifo 3 "spray.h5" timeout 10 "$bin" couple "$base" -o "$tmp/run_h5_fifo"
run1 input_info_fifo 3 "not a regular file" timeout 10 "$bin" info "$tmp/run_h5_fifo/spray.h5"

# A run directory path longer than the system allows is a bad command line (2), naming the option and the limit.
long_dir=$tmp/$(printf '%05000d' 0)
expect cli_o_path_too_long 2 "-o" "$bin" spray "$base" -o "$long_dir"
grep -q 'at most' "$tmp/err" || why="$why; the message does not give the limit ('at most')"
report cli_o_path_too_long

# (c) info of a missing path, of a file that is not HDF5, of an empty and of a truncated HDF5 file.
run1 io_info_missing_path 3 "$tmp/no_such_run" "$bin" info "$tmp/no_such_run"
run1 io_info_missing_h5 3 "$tmp/no_such_file.h5" "$bin" info "$tmp/no_such_file.h5"
cp cases/mz2015_demo.ini "$tmp/not_hdf5.h5"
run1 io_info_not_hdf5 3 "$tmp/not_hdf5.h5" "$bin" info "$tmp/not_hdf5.h5"
: >"$tmp/empty.h5"
run1 io_info_empty_file 3 "$tmp/empty.h5" "$bin" info "$tmp/empty.h5"
if [ -f "$tmp/spray.h5.before" ]; then
    dd if="$tmp/spray.h5.before" of="$tmp/truncated.h5" bs=1024 count=20 2>/dev/null
    run1 io_info_truncated_h5 3 "$tmp/truncated.h5" "$bin" info "$tmp/truncated.h5"
fi
exit 0
