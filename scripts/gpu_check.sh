#!/bin/sh
# The GPU step checked in one call on a machine with an NVIDIA GPU (sm_90: H100/H200; docs/gpu.md): builds with
# make CUDA=1 (unless BUILD already holds a spraycoat built so), runs a small impact with --device cpu and --device
# gpu and compares the last snapshot's fields and the verdicts (also as a quarter, with heat conduction and both), then
# times the GPU step at about 1e6 and 1e7 points and on a fraction of the thesis-grade 14 um impact (whole and as a
# quarter), and prints one table.  Written to finish in under 8 minutes
# on an H200 (the CPU reference run, 2 threads of 16 cores, is the longest part: about a minute).
#   usage: scripts/gpu_check.sh [BUILD]           (default build-cuda)
# BUILD may be the kit of scripts/gpu_kit.sh (a folder with the binary, the HDF5 tools and lib/): on the lent device
# machine, which cannot build spraycoat, `scripts/gpu_check.sh build-gpu-kit` with the kit carried.
# Parts (GPU_CHECK_PARTS, default "0 1 2 3"): 0 compute-sanitizer's memcheck on a tiny impact (where installed);
# 1 the comparison with the CPU, run to run, and settled verdicts; 2 the PUPS table; 3 an Nsight Compute profile of
# one step's kernels at 1e6 points (where ncu is installed; the kernels' time, DRAM and SM throughput).
set -u
gpu=${GPU_CHECK_DEVICE:-gpu}
parts=${GPU_CHECK_PARTS:-0 1 2 3}
build=${1:-build-cuda}
bin="$build/spraycoat"
if [ -d "$build/lib" ]; then # a kit of scripts/gpu_kit.sh: its libraries and HDF5 tools
    # after the kit's: the driver's libcuda where the machine mounts it (cudart finds it through the loader's path)
    LD_LIBRARY_PATH="$build/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}:/usr/local/nvidia/lib64:/usr/local/nvidia/lib"
    PATH="$build:$PATH:/usr/local/cuda/bin"
    export LD_LIBRARY_PATH PATH
fi
want() { case " $parts " in *" $1 "*) return 0 ;; esac; return 1; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
jobs=$(nproc 2>/dev/null || echo 4)
start=$(date +%s)
failed=0

note() { printf '%s\n' "$*" >&2; }

# a binary with the GPU step (make CUDA=1, or the emulation on the CPU of BUILD/cuda-emu: docs/gpu.md) is used as it is
if [ "$gpu" = gpu ] && ! "$bin" --version 2>/dev/null | grep -q "^  gpu  *CUDA step"; then
    note "building $bin with make CUDA=1 ($jobs jobs)"
    make -j"$jobs" CUDA=1 BUILD="$build" "$bin" > "$work/build.log" 2>&1 || {
        tail -30 "$work/build.log"
        echo "FAIL gpu_check: make CUDA=1 failed"
        exit 1
    }
fi
command -v nvidia-smi > /dev/null 2>&1 && nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader >&2
if [ "$gpu" = gpu ]; then # what the first device run needs to know if cudart finds no driver
    ldconfig -p 2> /dev/null | grep -m 1 'libcuda\.so\.1' >&2 || note "libcuda.so.1 is not in the loader's cache"
    "$bin" --version 2>&1 | head -n 2 >&2
fi

# case NAME GRID SPACING T_END [extra lines]
impact_case() {
    name=$1 grid=$2 spacing=$3 t_end=$4
    shift 4
    {
        printf '[run]\ncheckpoint_wall = 0\n[impact]\ngrid = %s\nspacing = %s\nt_end = %s\n' "$grid" "$spacing" "$t_end"
        printf 'snapshot_every = %s\nseries_every = %s\n' "$t_end" "$(awk -v t="$t_end" 'BEGIN { print t < 8e-9 ? t / 8 : 1e-9 }')"
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
    tr ',' '\n' | sed -n 's/^ *\([-0-9.eEinfa+][-0-9.eEinfa+]*\) *$/\1/p'; }

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
same_verdicts() { # NAME: the CPU's and the GPU's verdicts of run NAME, one table row
    cv=$(verdicts "$work/$1.cpu") gv=$(verdicts "$work/$1.gpu")
    if [ "$cv" = "$gv" ]; then echo "| verdicts  | PASS   | $cv |"; else echo "| verdicts  | FAIL   | cpu $cv, gpu $gv |"; failed=1; fi
}

# variant NAME LINE FIELD...: part 1's small impact with the [impact] LINE added, on both devices: the FIELDs of the
# last snapshot compared (part 1's tolerances) and the verdicts
variant() {
    name=$1 line=$2
    shift 2
    printf '\nThe same impact with %s:\n\n' "$line"
    impact_case "$name" 1e-6 0.5e-6 4e-9 "diameter = 8e-6" "velocity = 810" "substrate_diameter = 20e-6" \
        "substrate_height = 8e-6" "bonding = energy" "$line"
    run "$name" cpu 0 && run "$name" gpu 1 || { echo "FAIL gpu_check: the impact with $line did not run"; exit 1; }
    echo "| field     | result | points    | max diff   | tolerance  |"
    echo "| --------- | ------ | --------- | ---------- | ---------- |"
    for field in "$@"; do
        case $field in
            x) compare "$name" x 1e-3 1e-6 ;;
            v) compare "$name" v 1e-3 810 ;;
            T) compare "$name" T 1 1 ;;
            *) compare "$name" "$field" 1e-3 1 ;;
        esac
    done
    same_verdicts "$name"
}
# last_row_sum DIR FIELD: the sum over the bodies of the last row of /series/FIELD
last_row_sum() {
    nb=$(dataset "$1/impact.h5" /summary/verdict | wc -l)
    dataset "$1/impact.h5" "/series/$2" | tail -n "$nb" | awk '{ s += $1 } END { printf "%d", s }'
}

# 0. compute-sanitizer's memcheck on a tiny impact: out-of-bounds or misaligned accesses, leaks on the device
if want 0 && [ "$gpu" = gpu ] && command -v compute-sanitizer > /dev/null 2>&1; then
    echo
    echo "## 0. compute-sanitizer memcheck, 4 um on a 1.0/0.5 um grid, 0.3 ns"
    echo
    impact_case tiny 1e-6 0.5e-6 0.3e-9 "diameter = 4e-6" "velocity = 800" "substrate_diameter = 10e-6" \
        "substrate_height = 4e-6" "bonding = energy"
    compute-sanitizer --tool memcheck --leak-check full --print-limit 20 "$bin" impact "$work/tiny.ini" \
        -o "$work/tiny.san" --device gpu > "$work/sanitizer.log" 2>&1
    status=$?
    tail -4 "$work/sanitizer.log"
    if [ "$status" = 0 ] && grep -q "ERROR SUMMARY: 0 errors" "$work/sanitizer.log"; then
        echo "PASS sanitizer"
    else
        sed -n '1,60p' "$work/sanitizer.log"
        echo "FAIL sanitizer (exit status $status)"
        failed=1
    fi
fi

if want 1; then
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
    # the interface nodes of the last series row, all bodies (the GPU counts them on its grid): the runs separate
    # from round-off, so within 5 % + 2 nodes (a first guess, as the fields' tolerances), and some must be counted
    ci=$(last_row_sum "$work/small.cpu" interface_nodes) gi=$(last_row_sum "$work/small.gpu" interface_nodes)
    cb=$(last_row_sum "$work/small.cpu" bonded_nodes) gb=$(last_row_sum "$work/small.gpu" bonded_nodes)
    if awk -v c="$ci" -v g="$gi" -v cb="$cb" -v gb="$gb" 'function near(a, b) { d = a - b; if (d < 0) d = -d; return d <= 0.05 * a + 2 }
        BEGIN { exit !(c > 0 && g >= 0 && gb >= 0 && near(c, g) && near(cb, gb)) }'; then
        echo "| interface | PASS   | cpu $cb of $ci nodes bonded, gpu $gb of $gi |"
    else
        echo "| interface | FAIL   | cpu $cb of $ci nodes bonded, gpu $gb of $gi (within 5 % + 2, cpu > 0) |"
        failed=1
    fi
    same_verdicts small
    # run to run: the GPU twice, the same bits (h5diff: every dataset, the timing attributes aside)
    run small gpu 1 && mv "$work/small.gpu" "$work/small.gpu1" && run small gpu 1
    if h5diff -q "$work/small.gpu1/impact.h5" "$work/small.gpu/impact.h5" /snapshots /snapshots > /dev/null 2>&1; then
        echo "| repeat    | PASS   | two GPU runs give the same snapshots |"
    else
        echo "| repeat    | FAIL   | two GPU runs differ |"
        failed=1
fi

# the same impact as a quarter (the mirror planes x = 0 and y = 0), with heat conduction (heat_kernel on the
# device, conduction.c on the CPU), and both (the conduction's mirror images)
variant smallq "symmetry = quarter" x v eps_p D_bond
variant smallc "conduction = on" x v T eps_p
variant smallqc "symmetry = quarter
conduction = on" x v T eps_p

# settled verdicts: the same particle to rest on both devices, one rebound (600 m/s) and one bond (950 m/s); the
# runs separate from round-off, so the summary's numbers are printed, and the verdicts must agree
echo
echo "| speed | device | verdict | settled at ns | PBCP      | v_rest m/s | bonded interface |"
echo "| ----- | ------ | ------- | ------------- | --------- | ---------- | ---------------- |"
summary() { # DIR: verdict t_settled pbcp v_rest bonded_interface of body 1
    for f in verdict t_settled pbcp v_rest bonded_interface; do dataset "$1/impact.h5" /summary/$f | sed -n 2p; done | tr '\n' ' '; }
for speed in 600 950; do
    impact_case "settle$speed" 1e-6 0.5e-6 100e-9 "diameter = 8e-6" "velocity = $speed" \
        "substrate_diameter = 20e-6" "substrate_height = 8e-6" "bonding = energy"
    run "settle$speed" cpu 0 && run "settle$speed" gpu 1 || { echo "FAIL gpu_check: settle$speed did not run"; exit 1; }
    for device in cpu gpu; do
        set -- $(summary "$work/settle$speed.$device")
        printf '| %5s | %-6s | %7s | %13.2f | %9.4f | %10.3f | %16.4f |\n' "$speed" "$device" "$1" "$(awk -v t="$2" 'BEGIN { print t * 1e9 }')" "$3" "$4" "$5"
        eval "verdict_$device=$1"
    done
    [ "$verdict_cpu" = "$verdict_gpu" ] || { echo "| verdict $speed m/s: FAIL, cpu $verdict_cpu gpu $verdict_gpu |"; failed=1; }
done

fi
if want 2; then
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
    run m1 cpu 0 && row "14 um, 0.7/0.2 (1e6 points), 2 ns" m1 cpu
    read -r m1_cpu_pups _ < "$work/m1.cpu.pups"
    run m1 gpu 1 && row "14 um, 0.7/0.2 (1e6 points), 2 ns" m1 gpu "$m1_cpu_pups"
    # the same without reordering the points in memory by cell (the same bits; docs/gpu.md): what the reordering gains
    cp "$work/m1.ini" "$work/m1_unordered.ini"
    export SPRAYCOAT_GPU_REORDER_EVERY=0
    run m1_unordered gpu 1 && row "the same, points never reordered" m1_unordered gpu "$m1_cpu_pups"
    unset SPRAYCOAT_GPU_REORDER_EVERY
    if h5diff -r -d 0 "$work/m1.gpu/impact.h5" "$work/m1_unordered.gpu/impact.h5" /snapshots /snapshots > "$work/order.diff" 2>&1 &&
        h5diff -r -d 0 "$work/m1.gpu/impact.h5" "$work/m1_unordered.gpu/impact.h5" /series /series >> "$work/order.diff" 2>&1; then
        order_check="PASS: the same bits reordered and never reordered"
    else
        order_check="FAIL: the storage order changes the results ($(awk '/differences found/ && $1 > 0' "$work/order.diff" | wc -l) datasets differ)"
        failed=1
    fi
    # ~1e7 points: the same at spacing 0.0875 um (grid 0.35 um)
    impact_case m10 0.35e-6 0.0875e-6 0.3e-9 "substrate_diameter = 30e-6" "substrate_height = 10e-6"
    run m10 gpu 1 && row "14 um, 0.35/0.0875 (1e7 points), 0.3 ns" m10 gpu "$m1_cpu_pups"
    # the thesis-grade case (cases/tang2021_single_14um.ini: grid 0.7 um, spacing 0.175 um), its first 5 of 60 ns (a twelfth)
    impact_case thesis 0.7e-6 0.175e-6 5e-9 "substrate_diameter = 30e-6" "substrate_height = 10e-6" "bonding = energy"
    run thesis gpu 1 && row "thesis 14 um, 0.7/0.175, 5 of 60 ns" thesis gpu "$m1_cpu_pups"
    # the same as a quarter (symmetry = quarter, as vcrit and calibrate run it): a quarter of the points
    impact_case thesisq 0.7e-6 0.175e-6 5e-9 "substrate_diameter = 30e-6" "substrate_height = 10e-6" \
        "bonding = energy" "symmetry = quarter"
    run thesisq gpu 1 && row "thesis 14 um quarter, 5 of 60 ns" thesisq gpu "$m1_cpu_pups"
    echo
    echo "GPU/CPU: the GPU's PUPS over the CPU's on the same case (small) or the 1e6-point case (the larger ones), CPU on all $(nproc) cores; $(($(date +%s) - start)) s in all"
    echo "1e6 points reordered by cell every 16 steps against never: ${order_check:-not run}"
fi

# 3. Nsight Compute on one step's kernels (after 20 steps) of the 1e6-point case, and on one reordering's: time,
# DRAM and SM throughput
ncu=$(command -v ncu || ls /opt/nvidia/nsight-compute/*/ncu 2> /dev/null | head -n 1)
if want 3 && [ "$gpu" = gpu ] && [ -n "$ncu" ]; then
    echo
    echo "## 3. Nsight Compute, 14 um at 0.7/0.2 um (1e6 points), the kernels of one step and of one reordering"
    echo
    impact_case prof 0.7e-6 0.2e-6 0.5e-9 "substrate_diameter = 30e-6" "substrate_height = 10e-6"
    # a step is about 34 launches (the sort's and the reductions' CUB kernels included): 40 from the 21st step on,
    # without the reordering (its ~20 launches at steps 0 and 16 would shift the window), then the reordering's own
    # kernels (the second reordering, at step 16: 12 permutations and the slots; the upload's slots and the first
    # reordering's 13 launches skipped)
    SPRAYCOAT_GPU_REORDER_EVERY=0 "$ncu" --clock-control none --launch-skip 680 --launch-count 40 \
        --section SpeedOfLight --section Occupancy \
        "$bin" impact "$work/prof.ini" -o "$work/prof" --device gpu > "$work/ncu.log" 2>&1 ||
        { tail -20 "$work/ncu.log"; echo "ncu failed"; }
    rm -rf "$work/prof"
    "$ncu" --clock-control none --kernel-name regex:'permute|slot_kernel' --launch-skip 14 --launch-count 13 \
        --section SpeedOfLight "$bin" impact "$work/prof.ini" -o "$work/prof" --device gpu >> "$work/ncu.log" 2>&1 ||
        { tail -20 "$work/ncu.log"; echo "ncu failed (the reordering's kernels)"; }
    [ -n "${OUT:-}" ] && cp "$work/ncu.log" "$OUT/ncu.log"
    awk '/^  [A-Za-z_].*\(/ { name = $1 } /Duration/ { t = $NF " " $(NF-1) } /DRAM Throughput/ { dram = $NF }
         /Compute \(SM\) Throughput/ { sm = $NF; printf "| %-40s | %12s | DRAM %6s %% | SM %6s %% |\n", substr(name, 1, 40), t, dram, sm }' \
        "$work/ncu.log"
fi

[ "$failed" = 0 ] && echo "PASS gpu_check" || echo "FAIL gpu_check"
exit "$failed"
