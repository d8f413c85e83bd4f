# Shell helpers of the tests (sourced): a scratch folder, a write made to fail, and for the tests that stop a run on
# purpose, waiting until the run in the background has written what the test needs (a checkpoint, recorded runs).

# wait_until PID SECONDS COMMAND...: runs COMMAND every 0.02 s until it succeeds (status 0), or the process PID has
# ended or SECONDS have passed (status 1).
wait_until() {
    wait_pid=$1 wait_tries=$(($2 * 50))
    shift 2
    while [ "$wait_tries" -gt 0 ]; do
        "$@" && return 0
        kill -0 "$wait_pid" 2>/dev/null || return 1
        sleep 0.02
        wait_tries=$((wait_tries - 1))
    done
    return 1
}

# exists PATTERN: some file matches the glob PATTERN (a path without spaces).
exists() {
    # shellcheck disable=SC2086 # the pattern is expanded here
    ls $1 >/dev/null 2>&1
}

# rows_at_least FILE N: FILE has at least N lines that start with a digit (the records of a CSV file).
rows_at_least() {
    [ "$(grep -c '^[0-9]' "$1" 2>/dev/null)" -ge "$2" ] 2>/dev/null
}

# scratch_dir: T, a new temporary folder, removed when the test exits, and bg, the PID of the run the test puts in the
# background (empty until then), killed then; a signal ends the test with status 1.
scratch_dir() {
    T=$(mktemp -d) || exit 1
    bg=""
    trap scratch_cleanup EXIT
    trap 'exit 1' HUP INT TERM
}

scratch_cleanup() {
    if [ -n "$bg" ]; then
        kill -9 "$bg" 2>/dev/null
        wait "$bg" 2>/dev/null
    fi
    rm -rf "$T"
}

# blocked_write DIR FILE LOG COMMAND...: runs COMMAND (output into LOG) with the temporary DIR/FILE.tmp that the
# atomic write of DIR/FILE takes blocked by a folder, so that writing FILE fails (an I/O fault: exit status 3);
# blocked is COMMAND's exit status.
blocked_write() {
    block_dir=$1 block_file=$2 block_log=$3
    shift 3
    mkdir "$block_dir/$block_file.tmp"
    "$@" >"$block_log" 2>&1
    blocked=$?
    rmdir "$block_dir/$block_file.tmp"
}

# spraycoat_bin: BIN, the program under test ($SPRAYCOAT_BIN, default build/spraycoat), made absolute when it names a
# path relative to the repository root (a test that changes folder still finds it; a bare name stays a PATH lookup).
spraycoat_bin() {
    BIN=${SPRAYCOAT_BIN:-build/spraycoat}
    case $BIN in
    /*) ;;
    */*) BIN=$(pwd)/$BIN ;;
    esac
}
