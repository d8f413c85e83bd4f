#!/bin/sh
# OpenMP's wait policy (app/main.c, docs/performance.md): a command that computes runs with a passive wait when
# the user has not set OMP_WAIT_POLICY and the machine is busy (libgomp reads it at load, so spraycoat runs itself
# again with it set), else with libgomp's default: libgomp's own report (OMP_DISPLAY_ENV=verbose) of the process
# that runs agrees with what the debug line says was chosen, and the choice follows the load average; a value the user sets is kept (libgomp reports it, and no second start happens); commands
# that do not compute start once; --version names the policy.
# Prints "PASS name" / "FAIL name: why".  Run from the repository root with $SPRAYCOAT_BIN.
set -u
bin=${SPRAYCOAT_BIN:-build/spraycoat}
tmp=$(mktemp -d) || { echo "FAIL omp_wait_setup: mktemp -d failed"; exit 1; }
trap 'rm -rf "$tmp"' EXIT
pass() { echo "PASS $1"; }
fail() { echo "FAIL $1: $2"; }

# a spray of 2e-4 s (a fraction of a second)
awk '/^\[/ { section = $0 } section == "[spray]" && /^t_end = / { $0 = "t_end = 2e-4" } { print }' \
    cases/demo.ini >"$tmp/short.ini"
cp cases/vcrit_al.csv "$tmp/"

# spray NAME [VAR=VALUE...]: a short spray with 2 threads under `env VAR=VALUE`, libgomp's report on stderr
spray() {
    name=$1
    shift
    env -u OMP_WAIT_POLICY -u SPRAYCOAT_PASSIVE_WAIT OMP_DISPLAY_ENV=verbose "$@" "$bin" spray "$tmp/short.ini" \
        -o "$tmp/$name" --threads 2 -v >"$tmp/$name.out" 2>"$tmp/$name.err"
}
last_report() { grep "^  $1 = " "$2" | tail -n 1; }

# the policy spraycoat chose with OMP_WAIT_POLICY unset: passive when the machine is busy (1-minute load average
# >= online cores - 0.5), else libgomp's default; what the debug line claims must be what libgomp uses, and the
# choice must follow the load (unless the load is within 0.3 of the threshold while the test reads it)
load=$(cut -d' ' -f1 /proc/loadavg)
cores=$(getconf _NPROCESSORS_ONLN)
spray passive
why=""
spins=$(last_report GOMP_SPINCOUNT "$tmp/passive.err")
libgomp=$(last_report OMP_WAIT_POLICY "$tmp/passive.err")
if grep -q "debug: OpenMP wait policy: passive (set by spraycoat" "$tmp/passive.err"; then
    chosen=busy
    [ "$spins" = "  GOMP_SPINCOUNT = '0'" ] || why="claims passive, libgomp spins: $spins;"
    [ "$libgomp" = "  OMP_WAIT_POLICY = 'PASSIVE'" ] || why="$why claims passive, libgomp reports $libgomp;"
elif grep -q "debug: OpenMP wait policy: libgomp's default, spin then sleep (the machine was idle" "$tmp/passive.err"; then
    chosen=idle
    [ "$spins" != "  GOMP_SPINCOUNT = '0'" ] || why="claims libgomp's default, libgomp does not spin;"
    [ "$(grep -c "^  OMP_WAIT_POLICY = " "$tmp/passive.err")" -eq 1 ] || why="$why libgomp started twice;"
else
    chosen=none
    why="no debug line naming the policy;"
fi
expected=$(awk -v l="$load" -v c="$cores" 'BEGIN { t = c - 0.5; d = l - t; if (d < 0) d = -d
    print d < 0.3 ? "either" : (l >= t ? "busy" : "idle") }')
[ "$expected" = either ] || [ "$expected" = "$chosen" ] ||
    why="$why load $load on $cores cores: expected the $expected choice, spraycoat made the $chosen one;"
[ -f "$tmp/passive/spray.h5" ] || why="$why the spray wrote no spray.h5;"
if [ -z "$why" ]; then pass omp_wait_default_follows_load; else fail omp_wait_default_follows_load "$why"; fi

spray active OMP_WAIT_POLICY=active
why=""
[ "$(grep -c "^  OMP_WAIT_POLICY = " "$tmp/active.err")" -eq 1 ] || why="libgomp started more than once;"
[ "$(last_report OMP_WAIT_POLICY "$tmp/active.err")" = "  OMP_WAIT_POLICY = 'ACTIVE'" ] ||
    why="$why libgomp reports $(last_report OMP_WAIT_POLICY "$tmp/active.err");"
grep -q "debug: OpenMP wait policy: active (OMP_WAIT_POLICY of the environment)" "$tmp/active.err" ||
    why="$why no debug line naming the user's policy;"
if [ -z "$why" ]; then pass omp_wait_user_policy_kept; else fail omp_wait_user_policy_kept "$why"; fi

env -u OMP_WAIT_POLICY OMP_DISPLAY_ENV=true "$bin" check "$tmp/short.ini" >/dev/null 2>"$tmp/check.err"
n=$(grep -c "^  OMP_WAIT_POLICY = " "$tmp/check.err")
if [ "$n" -eq 1 ]; then pass omp_wait_check_starts_once; else fail omp_wait_check_starts_once "$n starts"; fi

policy=$(env -u OMP_WAIT_POLICY "$bin" --version | sed -n 's/^  omp_wait *//p')
user=$(OMP_WAIT_POLICY=active "$bin" --version | sed -n 's/^  omp_wait *//p')
case "$policy|$user" in
"passive for the commands that compute when the machine is busy"*"|active (OMP_WAIT_POLICY of the environment)")
    pass omp_wait_version ;;
*) fail omp_wait_version "--version says \"$policy\", with OMP_WAIT_POLICY=active \"$user\"" ;;
esac
