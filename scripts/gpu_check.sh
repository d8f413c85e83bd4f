#!/bin/sh
# The GPU step checked in one call on a machine with an NVIDIA GPU (sm_90: H100/H200; docs/gpu.md): builds with
# make CUDA=1 (unless BUILD already holds a spraycoat built so), runs a small impact with --device cpu and --device
# gpu and compares the last snapshot's fields and the verdicts, then times the GPU step at about 1e6 and 1e7 points
# and on a fraction of the thesis-grade 14 um impact, and prints one table.  Written to finish in under 8 minutes
# on an H200 (the CPU reference run, 2 threads of 16 cores, is the longest part: about a minute).
#   usage: scripts/gpu_check.sh [BUILD]           (default build-cuda)
# Tolerances of the comparison (FP64 on both; the sums of particle-to-grid and the reductions run in another
# order on the GPU, and libm's exp/log/pow differ from CUDA's by an ulp, so the runs separate from round-off and
# the gap grows with plastic flow; docs/gpu.md, "Bits"): over the points of the last snapshot,
#   x:        max |dx| <= 1e-3 grid cell            v:        max |dv| <= 1e-3 impact speed
#   T:        max |dT| <= 1 K                       pressure, von_mises: max |d| <= 1e-3 of the largest |value|
#   eps_p:    max |d| <= 1e-3                       D_bond:   max |d| <= 1e-3 (and the same points bonded, D >= 1)
# and the same verdict for every body.  Exit 0 when all hold.  Needs h5dump and h5diff (hdf5-tools) and awk.
# GPU_CHECK_DEVICE=cpu runs the "gpu" side on the CPU and GPU_CHECK_PARTS=1 only the comparison: a dry run of the
# script itself on a machine without a GPU (every comparison then holds exactly).
set -u
gpu=${GPU_CHECK_DEVICE:-gpu}
parts=${GPU_CHECK_PARTS:-1 2}
build=${1:-build-cuda}
bin="$build/spraycoat"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
jobs=$(nproc 2>/dev/null || echo 4)
start=$(date +%s)
failed=0

note() { printf '%s\n' "$*" >&2; }

if [ "$gpu" = gpu ] && ! "$bin" --version 2>/dev/null | grep -q -- "-DSPRAYCOAT_CUDA"; then
    note "building $bin with make CUDA=1 ($jobs jobs)"
    make -j"$jobs" CUDA=1 BUILD="$build" "$bin" > "$work/build.log" 2>&1 || {
        tail -30 "$work/build.log"
        echo "FAIL gpu_check: make CUDA=1 failed"
        exit 1
    }
fi
command -v nvidia-smi > /dev/null 2>&1 && nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader >&2

# case NAME GRID SPACING T_END [extra lines]
impact_case() {
    name=$1 grid=$2 spacing=$3 t_end=$4
    shift 4
    {
        printf '[run]\ncheckpoint_wall = 0\n[impact]\ngrid = %s\nspacing = %s\nt_end = %s\n' "$grid" "$spacing" "$t_end"
        printf 'snapshot_every = %s\nseries_every = %s\n' "$t_end" "$(awk -v t="$t_end" 'BEGIN { print t / 8 }')"
        for line in "$@"; do printf '%s\n' "$line"; done
        printf '[material.aluminium]\n'
    } > "$work/$name.ini"
}

# run NAME DEVICE THREADS: the log's PUPS and loop time into $work/NAME.DEVICE.{log,pups}
run() {
    rm -rf "$work/$1.$2"
    device=$2
    [ "$device" = gpu ] && device=$gpu
    if ! "$bin" impact "$work/$1.ini" -o "$work/$1.$2" --device "$device" --threads "$3" > "$work/$1.$2.log" 2>&1; then
        tail -5 "$work/$1.$2.log" >&2
        return 1
    fi
    line=$(grep "point updates/s" "$work/$1.$2.log" | tail -1)
    pups=$(echo "$line" | sed -n 's/.* s, \([0-9.e+]*\) point updates\/s.*/\1/p')
    loop=$(echo "$line" | sed -n 's/.*time loop \([0-9.]*\) s wall.*/\1/p')
    line=$(grep "points removed" "$work/$1.$2.log" | tail -1)
    points=$(echo "$line" | sed -n 's/.* of \([0-9]*\) points removed.*/\1/p')
    steps=$(echo "$line" | sed -n 's/.* after \([0-9]*\) steps.*/\1/p')
    echo "$pups $points $steps $loop" > "$work/$1.$2.pups"
}

# dataset FILE PATH: the values, one a line
dataset() { h5dump -d "$2" -y -w 0 -m %.17g "$1" 2>/dev/null | awk '/DATA \{/ { on = 1; next } /\}/ { on = 0 } on' |
    tr ',' '\n' | sed -n 's/^ *\([-0-9.eEinfa+]*\) *$/\1/p'; }

# compare NAME FIELD TOLERANCE SCALE: max |cpu - gpu| over the last snapshot <= TOLERANCE * SCALE (SCALE "max": the
# largest |value| of the CPU's field)
compare() {
    f=$(h5ls "$work/$1.cpu/impact.h5/snapshots" 2>/dev/null | awk '$1 ~ /^[0-9]+$/ { print $1 }' | sort | tail -1)
    dataset "$work/$1.cpu/impact.h5" "/snapshots/$f/$2" > "$work/a"
    dataset "$work/$1.gpu/impact.h5" "/snapshots/$f/$2" > "$work/b"
    result=$(paste "$work/a" "$work/b" | awk -v tol="$3" -v scale="$4" '
        { d = $1 - $2; if (d < 0) d = -d; if (d > dmax || d != d) dmax = d; a = $1 < 0 ? -$1 : $1; if (a > amax) amax = a; n++ }
        END { s = scale == "max" ? amax : scale; ok = n > 0 && dmax <= tol * s;
              printf "%s %d %.3g %.3g\n", ok ? "PASS" : "FAIL", n, dmax, tol * s }')
    set -- "$@" $result
    printf '| %-9s | %6s | %9s | %10s | %10s |\n' "$2" "$5" "$6" "$7" "$8"
    [ "$5" = PASS ] || failed=1
}

verdicts() { dataset "$1/impact.h5" /summary/verdict | tr '\n' ' '; }

echo
echo "## 1. The same small impact on the CPU and the GPU"
echo
impact_case small 1e-6 0.5e-6 4e-9 "diameter = 8e-6" "velocity = 810" "substrate_diameter = 20e-6" \
    "substrate_height = 8e-6" "bonding = energy"
run small cpu 0 && run small gpu 1 || { echo "FAIL gpu_check: the small impact did not run"; exit 1; }
echo "| field     | result | points    | max diff   | tolerance  |"
echo "| --------- | ------ | --------- | ---------- | ---------- |"
compare small x 1e-3 1e-6
compare small v 1e-3 810
compare small T 1 1
compare small pressure 1e-3 max
compare small von_mises 1e-3 max
compare small eps_p 1e-3 1
compare small D_bond 1e-3 1
cv=$(verdicts "$work/small.cpu") gv=$(verdicts "$work/small.gpu")
if [ "$cv" = "$gv" ]; then echo "| verdicts  | PASS   | $cv |"; else echo "| verdicts  | FAIL   | cpu $cv, gpu $gv |"; failed=1; fi
# run to run: the GPU twice, the same bits (h5diff: every dataset, the timing attributes aside)
run small gpu 1 && mv "$work/small.gpu" "$work/small.gpu1" && run small gpu 1
if h5diff -q "$work/small.gpu1/impact.h5" "$work/small.gpu/impact.h5" /snapshots /snapshots > /dev/null 2>&1; then
    echo "| repeat    | PASS   | two GPU runs give the same snapshots |"
else
    echo "| repeat    | FAIL   | two GPU runs differ |"
    failed=1
fi

case " $parts " in *" 2 "*) ;; *)
    [ "$failed" = 0 ] && echo "PASS gpu_check" || echo "FAIL gpu_check"
    exit "$failed" ;;
esac
echo
echo "## 2. Point updates per second"
echo
echo "| case                                   | device | points    | steps | PUPS       | loop s | GPU/CPU |"
echo "| -------------------------------------- | ------ | --------- | ----- | ---------- | ------ | ------- |"
row() { # label name device [cpu pups]
    read -r pups points steps loop < "$work/$2.$3.pups"
    ratio=${4:+$(awk -v a="$pups" -v b="$4" 'BEGIN { printf "%.0f", a / b }')}
    printf '| %-38s | %-6s | %9s | %5s | %10s | %6s | %7s |\n' "$1" "$3" "$points" "$steps" "$pups" "$loop" "${ratio:--}"
}
row "small, 8 um, 1.0/0.5, 4 ns" small cpu
read -r cpu_pups _ < "$work/small.cpu.pups"
row "small, 8 um, 1.0/0.5, 4 ns" small gpu "$cpu_pups"
# ~1e6 points: 14 um on a 30 x 10 um cylinder, grid 0.7 um, spacing 0.2 um (bench_impact.sh's large case)
impact_case m1 0.7e-6 0.2e-6 2e-9 "substrate_diameter = 30e-6" "substrate_height = 10e-6"
run m1 gpu 1 && row "14 um, 0.7/0.2 (1e6 points), 2 ns" m1 gpu "$cpu_pups"
# ~1e7 points: the same at spacing 0.0875 um (grid 0.35 um)
impact_case m10 0.35e-6 0.0875e-6 0.3e-9 "substrate_diameter = 30e-6" "substrate_height = 10e-6"
run m10 gpu 1 && row "14 um, 0.35/0.0875 (1e7 points), 0.3 ns" m10 gpu "$cpu_pups"
# the thesis-grade case (cases/tang2021_single_14um.ini: grid 0.7 um, spacing 0.175 um), its first 5 of 60 ns (a twelfth)
impact_case thesis 0.7e-6 0.175e-6 5e-9 "substrate_diameter = 30e-6" "substrate_height = 10e-6" "bonding = energy"
run thesis gpu 1 && row "thesis 14 um, 0.7/0.175, 5 of 60 ns" thesis gpu "$cpu_pups"
echo
echo "GPU/CPU: the GPU's PUPS over the small case's CPU PUPS ($(nproc) cores); $(($(date +%s) - start)) s in all"
[ "$failed" = 0 ] && echo "PASS gpu_check" || echo "FAIL gpu_check"
exit "$failed"
