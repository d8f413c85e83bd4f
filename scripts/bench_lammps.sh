#!/bin/sh
# shellcheck disable=SC2154  # the particle-set variables come from the generated particles.env
# bench_lammps.sh BUILD_DIR: spraycoat side by side with LAMMPS on the same particles, box and simulated time.
#
# One particle set (tests/bench/make_particles.c: N Cu-like spheres, d = 20-60 um, in a 5 mm wide
# cylinder, flying at 50 +- 5 m/s towards a target plane; no gas) is run to the same simulated time by
#   spraycoat  impulse-based collisions, swept-sphere detection, dt = 1e-6 s (set by the flow), threads 1 and 2
#   LAMMPS     soft-sphere Hertz/Mindlin (pair_style granular, fix wall/gran), dt = tc/20 of the shortest
#              Hertz contact (tests/bench/in.spray_compare), 1 MPI rank and, if mpirun exists, 2 ranks
# and one table gives per-step cost and time to solution, then a table of physics so the reader can see
# both solved the same problem.  Installs the Debian package lammps if `lmp` is missing (as root).
#
# Environment (optional):
#   BENCH_N=20000        particles
#   BENCH_T_END=1e-4     simulated time, s (all particles reach the target after 78 us)
#   BENCH_DT=1e-6        spraycoat time step, s
#   BENCH_DIR=BUILD_DIR/bench_lammps   work folder (generated files, run folders, logs)
#   BENCH_MPI=1          0: skip the 2-rank LAMMPS run
# Benchmarks are not tests: nothing here asserts on time.  Exit status 0 unless something failed to run.
set -eu

usage() {
    echo "usage: $0 BUILD_DIR   (BUILD_DIR holds the spraycoat binary, e.g. build)" >&2
    exit 2
}
[ $# -eq 1 ] || usage
case $1 in -h|--help) usage ;; esac

ROOT=$(cd "$(dirname "$0")/.." && pwd)
BUILD=$(cd "$1" && pwd) || usage
SPRAYCOAT=$BUILD/spraycoat
[ -x "$SPRAYCOAT" ] || { echo "bench_lammps: $SPRAYCOAT not found: build it first (make -j2 all)" >&2; exit 2; }
N=${BENCH_N:-20000}
T_END=${BENCH_T_END:-1e-4}
DT_SPRAY=${BENCH_DT:-1e-6}
WORK=${BENCH_DIR:-$BUILD/bench_lammps}
MPI=${BENCH_MPI:-1}
INPUT=$ROOT/tests/bench/in.spray_compare
FRICTION=0.3
SKIN=20e-6   # m: at 125 m/s (the fastest after collisions) and dt ~1.5 ns, ~50 steps to cross half of it

say() { printf '%s\n' "bench_lammps: $*" >&2; }
die() { say "$*"; exit 1; }
now() { date +%s.%N; }
elapsed() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.3f", b - a }'; }

# ---------------------------------------------------------------- LAMMPS
if ! command -v lmp >/dev/null 2>&1; then
    say "lmp not found: installing the Debian package lammps (apt-get, --no-install-recommends)"
    [ "$(id -u)" -eq 0 ] || die "not root: install it yourself (sudo apt-get install lammps) and run again"
    command -v apt-get >/dev/null 2>&1 || die "no apt-get: install LAMMPS (with the GRANULAR package) so that lmp is on PATH"
    # lammps depends on liblammps0, lammps-data, libopenmpi3 and mpi-default-bin (mpirun); the only
    # recommendation is lammps-doc, so --no-install-recommends still gives a working lmp and mpirun.
    DEBIAN_FRONTEND=noninteractive apt-get update -q >&2 || die "apt-get update failed"
    DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends lammps >&2 \
        || die "apt-get install lammps failed"
    command -v lmp >/dev/null 2>&1 || die "lammps installed but no lmp on PATH"
fi
lmp -h 2>/dev/null | grep -qw GRANULAR || die "this lmp has no GRANULAR package"
LMP_VERSION=$(lmp -h 2>/dev/null | sed -n 's/^Large-scale Atomic\/Molecular Massively Parallel Simulator - //p' | head -1)
export OMP_NUM_THREADS=1
if [ "$(id -u)" -eq 0 ]; then
    export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
fi
HAVE_MPIRUN=0
if [ "$MPI" != 0 ] && command -v mpirun >/dev/null 2>&1; then HAVE_MPIRUN=1; fi
command -v h5dump >/dev/null 2>&1 || die "h5dump not found (Debian: hdf5-tools)"
command -v gcc >/dev/null 2>&1 || die "gcc not found"

# ---------------------------------------------------------------- particles
mkdir -p "$WORK"
gcc -std=c17 -O2 -Wall -Wextra -o "$WORK/make_particles" "$ROOT/tests/bench/make_particles.c" -lm \
    || die "cannot compile tests/bench/make_particles.c"
"$WORK/make_particles" "$WORK" "$N" > "$WORK/particles.env" || die "make_particles failed"
# key=value lines: n d_min d_max v_max solid_fraction cloud_radius z_lo z_hi z_wall v_mean v_spread v_lateral
#                  rho young poisson restitution tc_pp tc_pw tc t_last_arrival
# shellcheck source=/dev/null
. "$WORK/particles.env"

DT_LMP=$(awk -v tc="$tc" 'BEGIN { printf "%.4g", tc / 20 }')
BINSIZE=$(awk -v d="$d_max" -v s="$SKIN" 'BEGIN { printf "%.4g", d + s }')
STEPS_LMP=$(awk -v t="$T_END" -v dt="$DT_LMP" 'BEGIN { s = t / dt; s = int((s + 9.999) / 10) * 10; print s }')
say "$n particles, d = $d_min..$d_max m, v_max = $v_max m/s, solid fraction $solid_fraction of the cloud"
say "Hertz contact time, smallest sphere at the largest relative speed: particle-particle $tc_pp s," \
    "particle-wall $tc_pw s -> LAMMPS dt = tc/20 = $DT_LMP s, $STEPS_LMP steps"
awk -v t="$T_END" -v a="$t_last_arrival" 'BEGIN { if (t < a) exit 1 }' \
    || say "warning: t_end = $T_END s is shorter than the last arrival at the target ($t_last_arrival s)"

# ---------------------------------------------------------------- LAMMPS damping calibration
# damping tsuji takes a restitution coefficient, but in this LAMMPS version a Hertz impact rebounds
# with more than it (input 0.8 gives about 0.85).  The map is independent of speed and size for Hertz,
# so find the input that gives e = $restitution with one particle hitting the wall head-on (secant).
cat > "$WORK/calib.data" <<EOF
spraycoat/LAMMPS benchmark: damping calibration, one particle

1 atoms
1 atom types

-1e-4 1e-4 xlo xhi
-1e-4 1e-4 ylo yhi
$(awk -v z="$z_wall" 'BEGIN { printf "%.10g %.10g", z - 2e-4, z + 1e-5 }') zlo zhi

Atoms # sphere

1 1 40e-6 $rho 0 0 $(awk -v z="$z_wall" 'BEGIN { printf "%.10g", z - 3e-5 }')

Velocities

1 0 0 50 0 0 0
EOF
lmp_rebound() { # e_input -> measured e
    lmp -in "$INPUT" -log none -screen none -var data "$WORK/calib.data" -var dt "$DT_LMP" -var steps 400 \
        -var zwall "$z_wall" -var E "$young" -var nu "$poisson" -var e "$1" -var mu "$FRICTION" \
        -var skin "$SKIN" -var binsize "$BINSIZE" -var dump "$WORK/calib.dump" || die "LAMMPS calibration run failed"
    awk 'END { printf "%.6f", -$8 / 50 }' "$WORK/calib.dump"
}
E0=$restitution
R0=$(lmp_rebound "$E0")
E_LMP=$(awk -v e="$E0" 'BEGIN { printf "%.6f", e - 0.1 }')
R_LMP=$(lmp_rebound "$E_LMP")
i=0
while awk -v r="$R_LMP" -v t="$restitution" 'BEGIN { exit !((r - t) ^ 2 > 1e-8) }' && [ $i -lt 8 ]; do
    E2=$(awk -v e0="$E0" -v r0="$R0" -v e1="$E_LMP" -v r1="$R_LMP" -v t="$restitution" \
        'BEGIN { printf "%.6f", e1 + (t - r1) * (e1 - e0) / (r1 - r0) }')
    E0=$E_LMP R0=$R_LMP E_LMP=$E2
    R_LMP=$(lmp_rebound "$E_LMP")
    i=$((i + 1))
done
say "LAMMPS damping tsuji: input $restitution gives e = $(lmp_rebound "$restitution"); input $E_LMP gives e = $R_LMP (used)"

# ---------------------------------------------------------------- spraycoat case
G=$(awk -v E="$young" -v nu="$poisson" 'BEGIN { printf "%.6g", E / (2 * (1 + nu)) }')
K=$(awk -v E="$young" -v nu="$poisson" 'BEGIN { printf "%.6g", E / (3 * (1 - 2 * nu)) }')
CASE=$WORK/spray_compare.ini
cat > "$CASE" <<EOF
; Written by scripts/bench_lammps.sh: the spraycoat side of the LAMMPS comparison.
; $n Cu-like spheres from particles.csv (tests/bench/make_particles.c) fly towards the target at
; z = $z_wall m; no gas; constant restitution $restitution, friction $FRICTION; every particle rebounds.
; Material: E = $young Pa, nu = $poisson -> G = $G Pa, K = $K Pa; Y = 70 MPa (unused: constant e).

[run]
seed = 1
checkpoint_wall = 0
checkpoint_steps = 0

[spray]
dt = $DT_SPRAY
t_end = $T_END
injection = file
particles = particles.csv
domain_radius = 0.05
handoff_height = 0.001
metrics_every = 10

[powder]
distribution = mono
median_diameter = 40e-6
density = $rho
shear_modulus = $G
bulk_modulus = $K
yield_stress = 70e6
friction = $FRICTION

[target]
standoff = $z_wall
shear_modulus = $G
bulk_modulus = $K
yield_stress = 70e6
friction = $FRICTION
deposit_radius = $cloud_radius

[contact]
restitution = $restitution

[jet]
model = none

[deposition]
rule = none
EOF
"$SPRAYCOAT" check "$CASE" > "$WORK/spray_compare.check" 2>&1 || { cat "$WORK/spray_compare.check" >&2; die "spraycoat check failed"; }

# ---------------------------------------------------------------- runs
ROWS=$WORK/rows.txt      # code|ranks x threads|dt|steps|wall s|loop s
: > "$ROWS"
LOAD_BEFORE=$(cut -d' ' -f1-3 /proc/loadavg 2>/dev/null || echo "?")

run_spraycoat() { # threads
    dir=$WORK/spray_t$1
    rm -rf "$dir"
    say "spraycoat, $1 thread(s) ..."
    t0=$(now)
    "$SPRAYCOAT" spray "$CASE" -o "$dir" -q --threads "$1" || die "spraycoat failed (threads $1)"
    t1=$(now)
    steps=$(h5dump -a /stats/steps "$dir/spray.h5" | awk '/\(0\)/ { print $2 }')
    echo "spraycoat|1 x $1|$DT_SPRAY|$steps|$(elapsed "$t0" "$t1")|-" >> "$ROWS"
}

run_lammps() { # ranks
    log=$WORK/log.lammps.np$1
    say "LAMMPS, $1 MPI rank(s), $STEPS_LMP steps ..."
    set -- "$1" lmp -in "$INPUT" -log "$log" -screen none -var data "$WORK/particles.data" -var dt "$DT_LMP" \
        -var steps "$STEPS_LMP" -var zwall "$z_wall" -var E "$young" -var nu "$poisson" -var e "$E_LMP" \
        -var mu "$FRICTION" -var skin "$SKIN" -var binsize "$BINSIZE" -var dump "$WORK/final.np$1.dump"
    ranks=$1
    shift
    t0=$(now)
    if [ "$ranks" -eq 1 ]; then
        "$@" || die "LAMMPS failed (see $log)"
    else
        mpirun -np "$ranks" --oversubscribe "$@" > "$WORK/mpirun.np$ranks.out" 2>&1 \
            || { tail -20 "$WORK/mpirun.np$ranks.out" >&2; die "mpirun LAMMPS failed (see $log)"; }
    fi
    t1=$(now)
    loop=$(awk '/^Loop time of/ { print $4 }' "$log")
    echo "LAMMPS|$ranks x 1|$DT_LMP|$STEPS_LMP|$(elapsed "$t0" "$t1")|$loop" >> "$ROWS"
}

run_spraycoat 1
run_spraycoat 2
run_lammps 1
if [ "$HAVE_MPIRUN" -eq 1 ]; then run_lammps 2; else say "no mpirun (or BENCH_MPI=0): 2-rank LAMMPS run skipped"; fi
LOAD_AFTER=$(cut -d' ' -f1-3 /proc/loadavg 2>/dev/null || echo "?")

# ---------------------------------------------------------------- physics
# One line per particle, "id d vz0 v0sq vz vsq hit" (id from 0 = the CSV row), for the common metrics.
h5col() { # file dataset -> one number per line
    h5dump -y -w 0 -m %.17g -d "$2" -o "$WORK/h5col.tmp" "$1" > /dev/null || die "h5dump $2 of $1 failed"
    tr -s ', \t\r' '\n' < "$WORK/h5col.tmp" | sed '/^$/d'
}
h5attr() { h5dump -a "$2" "$1" | awk '/\(0\)/ { print $2 }'; }

spraycoat_state() { # run dir -> particle lines on stdout
    dir=$1
    h5col "$dir/spray.h5" /particles/id > "$WORK/s_id"
    h5col "$dir/spray.h5" /particles/v | paste -d' ' - - - > "$WORK/s_v"
    h5col "$dir/spray.h5" /impacts/particle_id > "$WORK/s_ipid"
    h5col "$dir/spray.h5" /impacts/partner > "$WORK/s_ipartner"
    paste -d' ' "$WORK/s_ipid" "$WORK/s_ipartner" > "$WORK/s_imp"
    paste -d' ' "$WORK/s_id" "$WORK/s_v" > "$WORK/s_final"
    awk -F, 'FILENAME == ARGV[1] { if (FNR > 1) { d[FNR - 2] = $10; vz0[FNR - 2] = $6;
                                       v0sq[FNR - 2] = $4 * $4 + $5 * $5 + $6 * $6 }; next }
             FILENAME == ARGV[2] { split($0, f, " "); if (f[2] == -1) hit[f[1]] = 1; next }
             { split($0, f, " "); id = f[1];
               printf "%d %.10g %.10g %.10g %.10g %.10g %d\n", id, d[id], vz0[id], v0sq[id], f[4],
                      f[2] * f[2] + f[3] * f[3] + f[4] * f[4], (id in hit) }' \
        "$WORK/particles.csv" "$WORK/s_imp" "$WORK/s_final"
}

lammps_state() { # dump -> particle lines (last snapshot of the dump)
    awk -F, 'FILENAME == ARGV[1] { if (FNR > 1) { vz0[FNR - 2] = $6; v0sq[FNR - 2] = $4 * $4 + $5 * $5 + $6 * $6 }; next }
             /^ITEM: ATOMS/ { n = 0; inatoms = 1; next }
             /^ITEM:/ { inatoms = 0; next }
             inatoms { split($0, f, " "); id = f[1] - 1; line[n++] = sprintf("%d %s %.10g %.10g %s %.10g %d", id, f[2],
                       vz0[id], v0sq[id], f[8], f[6] * f[6] + f[7] * f[7] + f[8] * f[8], f[9] > 0) }
             END { for (i = 0; i < n; i++) print line[i] }' "$WORK/particles.csv" "$1"
}

# metrics over particle lines: present, hit, mean incoming vz of the hit ones, mean final vz of the hit
# ones, ratio, fraction of the hit ones moving away from the target, kinetic energy final/initial (all N)
metrics() { # label escaped < particle lines
    awk -v label="$1" -v escaped="$2" -v n="$n" '
        { m = $2 * $2 * $2; present++; if ($7) { hits++; in_sum += $3; out_sum += $5; if ($5 < 0) away++ }
          ke += m * $6; ke0p += m * $4 }
        END { printf "%-22s %8d %8d %7.1f%% %10.2f %10.2f %8.3f %8.1f%% %9s %8d\n", label, present, hits,
                     100 * hits / n, hits ? in_sum / hits : 0, hits ? -out_sum / hits : 0,
                     hits && in_sum ? -out_sum / in_sum : 0, hits ? 100 * away / hits : 0,
                     ke0p ? sprintf("%.3f", ke / ke0p) : "-", escaped }'
}

PHYS=$WORK/physics.txt
{
    printf "%-22s %8s %8s %8s %10s %10s %8s %9s %9s %8s\n" "run" "final N" "hit" "hit" "<vz> in" "<-vz> end" \
        "end/in" "away" "KE/KE0" "escaped"
    for t in 1 2; do
        dir=$WORK/spray_t$t
        spraycoat_state "$dir" | metrics "spraycoat, $t thread(s)" "$(h5attr "$dir/spray.h5" /stats/escaped)"
    done
    for r in 1 2; do
        [ -f "$WORK/final.np$r.dump" ] || continue
        [ "$r" -eq 1 ] || [ "$HAVE_MPIRUN" -eq 1 ] || continue
        lammps_state "$WORK/final.np$r.dump" | metrics "LAMMPS, $r rank(s)" 0
    done
} > "$PHYS"

# per-impact restitution in spraycoat (first target impact of each particle), contact counts
SPRAY_H5=$WORK/spray_t1/spray.h5
h5col "$SPRAY_H5" /impacts/v_in | paste -d' ' - - - > "$WORK/s_vin"
h5col "$SPRAY_H5" /impacts/v_out | paste -d' ' - - - > "$WORK/s_vout"
h5col "$SPRAY_H5" /impacts/particle_id > "$WORK/s_ipid"
h5col "$SPRAY_H5" /impacts/partner > "$WORK/s_ipartner"
SPRAY_E=$(paste -d' ' "$WORK/s_ipid" "$WORK/s_ipartner" "$WORK/s_vin" "$WORK/s_vout" |
    awk '$2 == -1 && !($1 in seen) { seen[$1] = 1; s += -$8 / $5; k++ } END { printf "%.4f over %d first impacts", k ? s / k : 0, k }')
PAIR_CONTACTS=$(h5attr "$SPRAY_H5" /stats/contacts_pair)
TARGET_CONTACTS=$(h5attr "$SPRAY_H5" /stats/contacts_target)
SAME_THREADS=different
spraycoat_state "$WORK/spray_t2" > "$WORK/s_t2.tmp"
if spraycoat_state "$WORK/spray_t1" | cmp -s - "$WORK/s_t2.tmp"; then SAME_THREADS=identical; fi

# ---------------------------------------------------------------- report
CPU=$(lscpu 2>/dev/null | sed -n 's/^Model name: *//p' | head -1)
CORES=$(getconf _NPROCESSORS_ONLN 2>/dev/null || echo "?")  # not nproc: it honours OMP_NUM_THREADS
T_LMP=$(awk -v s="$STEPS_LMP" -v dt="$DT_LMP" 'BEGIN { printf "%.4g", s * dt }')
echo
UM=$(awk -v a="$d_min" -v b="$d_max" 'BEGIN { printf "%.1f-%.1f um", a * 1e6, b * 1e6 }')
echo "spraycoat vs LAMMPS: $n Cu-like spheres (d $UM, rho $rho, E $young, nu $poisson), 5 mm wide cloud"
echo "z = $z_lo-$z_hi m flying at $v_mean +- $v_spread m/s (lateral +-$v_lateral) to the target at z = $z_wall m;"
echo "no gas; e = $restitution, mu = $FRICTION; simulated time $T_END s (LAMMPS $T_LMP s)."
echo "machine: $CPU, $CORES cores; load average before $LOAD_BEFORE, after $LOAD_AFTER"
echo "spraycoat $("$SPRAYCOAT" --version 2>/dev/null | head -1); LAMMPS $LMP_VERSION (lmp, Debian package)"
echo
printf "%-10s %-9s %9s %7s %13s %9s %9s %14s %10s %11s\n" "code" "ranks x" "dt" "steps" "particle-" "wall s" \
    "loop s" "particle-" "us/step" "time to"
printf "%-10s %-9s %9s %7s %13s %9s %9s %14s %10s %11s\n" "" "threads" "s" "" "steps" "(command)" "(stepping)" \
    "steps/s" "" "solution s"
awk -F'|' -v n="$n" '{
    ps = n * $4; wall = $5; loop = ($6 == "-") ? wall : $6
    printf "%-10s %-9s %9s %7d %13.4g %9.2f %9s %14.4g %10.1f %11.2f\n", $1, $2, $3, $4, ps, wall,
           ($6 == "-") ? "-" : sprintf("%.2f", $6), ps / loop, 1e6 * loop / $4, wall }' "$ROWS"
echo
echo "particle-steps = N x steps; particle-steps/s and us/step use the stepping time (LAMMPS \"Loop time\"; for"
echo "spraycoat, which prints no timing with -q, the whole command, so its rate includes reading the CSV and"
echo "writing spray.h5); time to solution = wall time of the whole command to reach the simulated time."
echo "LAMMPS dt = tc/20, tc = $tc s = Hertz contact time of two $d_min m spheres at 2 x $v_max m/s; the LAMMPS"
echo "loop includes fix ave/atom every 10 steps to record which particles touch the target. Neighbour skin"
echo "$SKIN m, bin size $BINSIZE m."
for log in "$WORK"/log.lammps.np*; do
    [ -f "$log" ] || continue
    awk -v name="${log##*/}" '/% CPU use/ { cpu = $1 }
        /^(Pair|Neigh|Comm|Output|Modify|Other) *\|/ { part = part sprintf(" %s %s%%,", $1, $NF) }
        /^Neighbor list builds/ { builds = $NF }
        END { sub(/,$/, "", part); printf "%s: loop time split%s; %s neighbour builds; %s CPU use\n", name, part, builds, cpu }' "$log"
done
echo
echo "physics (same definitions for both codes; 'hit' = touched the target at least once; <vz> in = initial"
echo "vz of the hit particles, <-vz> end = their final velocity away from the target; KE/KE0 over all particles):"
cat "$PHYS"
echo
echo "spraycoat: per-impact normal restitution -v_out,z/v_in,z = $SPRAY_E (set: $restitution);"
echo "  contacts: particle-particle $PAIR_CONTACTS, target $TARGET_CONTACTS; 1 and 2 threads give $SAME_THREADS particle states."
echo "LAMMPS: damping tsuji input $E_LMP (calibrated: a head-on wall impact then rebounds with e = $R_LMP)."
echo "files: $WORK (case spray_compare.ini, particles.csv/.data, logs log.lammps.np*, dumps final.np*.dump)"
