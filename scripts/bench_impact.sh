#!/bin/sh
# `make bench`, impact stage: material-point updates per second (PUPS) of a single 14 um Al particle impact
# on an Al cylinder at 810 m/s with PTW, Mie-Grueneisen, contact and bonding on, about 1e5 and 1e6 points,
# threads 1 and 2, and the peak memory per material point.  PUPS are the stage's own count over its steps
# (set-up, the snapshots written in the loop and the final output excluded), from its closing log line, which
# also gives the whole time loop's wall time (steps and snapshots): the row shows both.
#   usage: scripts/bench_impact.sh [BUILD] [REPEATS]
# Each case runs REPEATS times (default 1) and the row shows the best run: on a shared machine the other jobs
# only ever slow a run down.  The load average before the first run is printed under the table.
set -eu
build=${1:-build}
repeats=${2:-1}
bin="$build/spraycoat"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

case_file() { # name grid spacing t_end
    cat > "$work/$1.ini" <<INI
[impact]
grid = $2
spacing = $3
t_end = $4
snapshot_every = 1
[material.aluminium]
INI
}
# 68,096 points, 10 ns: contact, jetting onset and plastic flow included
case_file small 1.5e-6 0.5e-6 10e-9
# 1.06 million points (grid 0.7 um, spacing 0.2 um), first 0.3 ns of contact
case_file large 0.7e-6 0.2e-6 0.3e-9

run_once() { # name threads: appends "PUPS points steps rss_kib loop_s" to $work/runs
    rm -rf "$work/run"
    /usr/bin/time -f "%M" -o "$work/rss" "$bin" impact "$work/$1.ini" -o "$work/run" --threads "$2" \
        > "$work/log" 2>&1
    line=$(grep "point updates/s" "$work/log" | tail -1)
    pups=$(echo "$line" | sed -n 's/.* s, \([0-9.e+]*\) point updates\/s.*/\1/p')
    loop=$(echo "$line" | sed -n 's/.*time loop \([0-9.]*\) s wall.*/\1/p')
    line=$(grep "points removed" "$work/log" | tail -1)
    points=$(echo "$line" | sed -n 's/.* of \([0-9]*\) points removed.*/\1/p')
    steps=$(echo "$line" | sed -n 's/.* after \([0-9]*\) steps.*/\1/p')
    echo "$pups $points $steps $(cat "$work/rss") $loop" >> "$work/runs"
}

run_case() { # name label threads
    : > "$work/runs"
    i=0
    while [ "$i" -lt "$repeats" ]; do
        run_once "$1" "$3"
        i=$((i + 1))
    done
    sort -g -r "$work/runs" | head -1 | awk -v name="$2" -v t="$3" '{
        printf "| %-34s | %7d | %9d | %5d | %10.3g | %10.3g | %8.2f | %10.3g | %8.0f |\n", name, t, $2, $3, $1, $1 / t,
            $5, $2 * $3 / $5 / t, $4 * 1024 / $2 }'
}

load_before=$(cut -d ' ' -f 1-3 /proc/loadavg)
echo "| impact case                        | threads | points    | steps | PUPS       | per thread | loop s   | loop PUPS per thread | B/point |"
echo "| ---------------------------------- | ------- | --------- | ----- | ---------- | ---------- | -------- | -------------------- | ------- |"
for t in 1 2; do run_case small "14 um, 810 m/s, 1.5/0.5, 10 ns" "$t"; done
for t in 1 2; do run_case large "14 um, 810 m/s, 0.7/0.2, 0.3 ns" "$t"; done
echo
echo "best of $repeats run(s); kernels: $("$bin" --version | sed -n 's/^ *isa *//p'); load average before the first run: $load_before"
