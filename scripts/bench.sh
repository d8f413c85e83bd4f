#!/bin/sh
# `make bench`: the performance tables of BENCHMARKS.md, in Markdown (docs/performance.md says what they mean).
#   free flight with drag: N particles on a sparse lattice in the jet, no contacts
#   colliding: a dense cloud in vacuum, many particle-particle contacts per step
#   Table 1: wall time of the paper's full 50,050-particle case (skip with BENCH_TABLE1=0)
# Particle-steps are the flying particles advanced, summed over steps (spray.h5:/stats particle_steps).
# First the machine's own 1 -> 2 thread scaling (tests/bench/machine_ceiling.c), measured in the same minutes.
set -eu
# One OpenMP wait policy for every figure: spraycoat picks passive when the machine is busy at the start of a
# command (docs/performance.md), so without this the figures would depend on the load a moment before each run.
# Active is the idle machine's choice (within the noise of libgomp's default there); a value you set is kept.
export OMP_WAIT_POLICY="${OMP_WAIT_POLICY:-active}"
build=${1:-build}
bin="$build/spraycoat"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# N particles, deterministic: a lattice (free flight) or a random cloud (colliding).
lattice() { # n spacing speed
    awk -v n="$1" -v h="$2" -v u="$3" 'BEGIN { print "x,y,z,vx,vy,vz,wx,wy,wz,d"; side = int(exp(log(n) / 3)) + 1;
        for (i = 0; i < n; i++) { a = i % side; b = int(i / side) % side; c = int(i / side / side);
            printf "%.6e,%.6e,%.6e,0,0,%.4f,0,0,0,4e-05\n", (a - side / 2) * h, (b - side / 2) * h, 0.01 + c * h, u + (i % 7) } }'
}
cloud() { # n box speed  (Park-Miller LCG: exact in awk doubles)
    awk -v n="$1" -v box="$2" -v u="$3" 'BEGIN { print "x,y,z,vx,vy,vz,wx,wy,wz,d"; s = 12345;
        for (i = 0; i < n; i++) { for (k = 0; k < 6; k++) { s = (s * 16807) % 2147483647; r[k] = s / 2147483647 }
            printf "%.6e,%.6e,%.6e,%.4f,%.4f,%.4f,0,0,0,4e-05\n", box * (r[0] - 0.5), box * (r[1] - 0.5), 0.1 + box * r[2],
                u * (2 * r[3] - 1), u * (2 * r[4] - 1), u * (2 * r[5] - 1) } }'
}

# The machine is shared: each case runs BENCH_REPEAT times (default 3) and the fastest run is reported, with
# the least CPU (user) time of the runs, which a loaded machine disturbs far less than the wall time.
# Two rates: the whole command (reading the particles, set-up, output included) and the time loop alone, from the
# stage's closing log line, as LAMMPS's "Performance" line counts its loop time (and as the impact rows' PUPS).
run_case() { # name case threads -> prints a table row
    best=
    cpu=
    loop=
    for rep in $(seq "${BENCH_REPEAT:-3}"); do
        rm -rf "$work/run"
        start=$(date +%s.%N)
        /usr/bin/time -f %U -o "$work/cpu" "$bin" spray "$2" -o "$work/run" --threads "$3" 2> "$work/log"
        end=$(date +%s.%N)
        best=$(awk -v s="$start" -v e="$end" -v b="$best" 'BEGIN { w = e - s; print (b == "" || w < b) ? w : b }')
        cpu=$(awk -v u="$(tail -n 1 "$work/cpu")" -v b="$cpu" 'BEGIN { print (b == "" || u < b) ? u : b }')
        seconds=$(sed -n 's/.*time loop \([0-9.]*\) s wall.*/\1/p' "$work/log")
        loop=$(awk -v l="$seconds" -v b="$loop" 'BEGIN { print (b == "" || l < b) ? l : b }')
    done
    steps=$(h5dump -a /stats/particle_steps "$work/run/spray.h5" | sed -n 's/^ *(0): *//p')
    contacts=$(h5dump -a /stats/contacts_pair "$work/run/spray.h5" | sed -n 's/^ *(0): *//p')
    awk -v name="$1" -v t="$3" -v w="$best" -v u="$cpu" -v l="$loop" -v ps="$steps" -v c="$contacts" 'BEGIN {
        printf "| %-28s | %7d | %12d | %9d | %8.2f | %10.2f | %10.2f | %8.2f | %10.2f | %6.3f | %10.2f |\n", name, t,
            ps, c, w, ps / w / 1e6, ps / w / 1e6 / t, u, ps / u / 1e6, l, ps / l / 1e6 / t }'
}

lattice 20000 1e-3 50 > "$work/lattice.csv"
cat > "$work/free.ini" <<INI
[spray]
dt = 1e-6
t_end = 1e-3
injection = file
particles = lattice.csv
domain_radius = 0.2
[target]
standoff = 0.3
[deposition]
rule = none
INI
cloud 20000 0.006 30 > "$work/cloud.csv"
cat > "$work/colliding.ini" <<INI
[spray]
dt = 1e-6
t_end = 5e-4
injection = file
particles = cloud.csv
domain_radius = 0.2
[jet]
model = none
[contact]
restitution = 0.9
[deposition]
rule = none
INI

# The header row of BENCHMARKS.md: the machine, the commit, the command (the output is Markdown throughout, so
# `make bench > FILE` or a paste gives BENCHMARKS.md's tables; docs/performance.md says what the columns mean).
machine="$(lscpu | sed -n 's/^Model name: *//p'), $(nproc) cores, $(awk '/^MemTotal/ { printf "%.0f GiB", $2 / 1048576 }' /proc/meminfo)"
machine="$machine, $(. /etc/os-release 2>/dev/null && echo "$PRETTY_NAME"), $("$bin" --version | sed -n 's/^ *compiler *:* *//p' | head -n 1)"
# The instruction-set level the kernels ran with (core/isa.h: the best this CPU runs, or SPRAYCOAT_ISA's).
isa=$("$bin" --version | sed -n 's/^ *isa *//p')
echo "| machine | commit | command | kernels' instruction set | load average at the start |"
echo "| --- | --- | --- | --- | --- |"
echo "| $machine | $("$bin" --version | sed -n 's/^ *git *//p') | \`${BENCH_COMMAND:-scripts/bench.sh $build}\` (BENCH_REPEAT=${BENCH_REPEAT:-3}) | ${isa:-unknown} | $(cut -d' ' -f1-3 /proc/loadavg) |"
echo
echo "What 2 threads can gain over 1 on this machine, now (tests/bench/machine_ceiling.c): arithmetic in registers,"
echo "and the STREAM triad through memory, which bounds the scaling of a step that streams its arrays:"
echo
gcc -std=c17 -O2 -fopenmp -Wall -Wextra -o "$work/machine_ceiling" tests/bench/machine_ceiling.c
"$work/machine_ceiling" "$(nproc)"
echo
echo "| case                         | threads | particle-steps | contacts | wall s | M p-steps/s | per thread | CPU s | M p-steps per CPU s | loop s | loop M p-steps/s per thread |"
echo "| ---------------------------- | ------- | -------------- | -------- | ------ | ----------- | ---------- | ----- | ------------------- | ------ | --------------------------- |"
for t in 1 2; do run_case "free flight + drag, 20k" "$work/free.ini" "$t"; done
for t in 1 2; do run_case "colliding cloud, 20k, vacuum" "$work/colliding.ini" "$t"; done
if [ "${BENCH_TABLE1:-1}" != 0 ]; then
    BENCH_REPEAT=1 run_case "Table 1 full (50,050)" cases/mz2015_table1.ini 2
fi
echo
"$(dirname "$0")/bench_impact.sh" "$build" "${BENCH_REPEAT:-3}"

echo
"$(dirname "$0")/bench_render.sh" "$build"
