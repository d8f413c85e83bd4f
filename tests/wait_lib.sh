# Shell helpers of the tests that stop a run on purpose (sourced): wait until the run in the background has written
# what the test needs (a checkpoint, recorded runs), then signal it.

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
