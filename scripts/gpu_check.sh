#!/bin/sh
# The GPU step checked in one call on a machine with an NVIDIA GPU (sm_90: H100/H200; docs/gpu.md): builds with
# make CUDA=1 (unless BUILD already holds a spraycoat built so), runs a small impact with --device cpu and --device
# gpu and compares the last snapshot's fields point by point id and the verdicts (also as a quarter, with heat
# conduction and both), then times the GPU step at about 1e6 and 1e7 points and on a fraction of the thesis-grade
# 14 um impact (whole and as a quarter), and prints one table.  Written to finish in under 8 minutes on an H200 (the
# CPU reference runs, on all 16 cores, are the longest part: about a minute).
#   usage: scripts/gpu_check.sh [BUILD]           (default build-cuda)
# BUILD may be the kit of scripts/gpu_kit.sh (a folder with the binary, the HDF5 tools and lib/): on the lent device
# machine, which cannot build spraycoat, `scripts/gpu_check.sh build-gpu-kit` with the kit carried.
# Parts (GPU_CHECK_PARTS, default "0 1 2 3"): 0 compute-sanitizer's memcheck on a tiny impact (SKIP where it is not
# installed or cannot run, as on a gVisor machine); 1 the comparison with the CPU, run to run, and settled verdicts;
# 2 the PUPS table; 3 an Nsight Compute profile of one step's kernels at 1e6 points (SKIP where ncu is not
# installed; the kernels' time, DRAM and SM throughput).
# A run that fails or times out is a FAIL row, and the check goes on to the next; the exit status is 1 if any row
# failed.  Each run is limited to GPU_CHECK_TIMEOUT seconds (default 240), and no run starts once GPU_CHECK_BUDGET
# seconds (default 500, for a device call of 540) have passed: the runs left are FAIL rows saying so, and the
# summary is printed before the call's own limit.  GPU_CHECK_DEVICE=cpu runs the "gpu" side on the CPU too (a dry run);
# GPU_CHECK_QUICK=1 doubles every case's grid and spacing and cuts its time to a tenth (a dry run of the script's
# plumbing on the emulation, build/cuda-emu: its numbers mean nothing).  With $OUT set, the runs' logs
# ($OUT/gpu_check_logs.tgz) and the profiler's and the sanitizer's (ncu_step.log, ncu_reorder.log, sanitizer.log)
# are copied there.
set -u
gpu=${GPU_CHECK_DEVICE:-gpu}
parts=${GPU_CHECK_PARTS:-0 1 2 3}
per_run=${GPU_CHECK_TIMEOUT:-240}
budget=${GPU_CHECK_BUDGET:-500}
quick=${GPU_CHECK_QUICK:-0}
build=${1:-build-cuda}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
jobs=$(nproc 2>/dev/null || echo 4)
start=$(date +%s)
failed=0
failures=""

note() { printf '%s\n' "$*" >&2; }
# bad LABEL: a row failed
bad() { failed=1; failures="$failures $1"; }

bin="$build/spraycoat"
if [ -d "$build/lib" ]; then
    # a kit of scripts/gpu_kit.sh: its programs run with its libraries and then the driver's libcuda where the
    # machine mounts it (cudart finds it through the loader's path), through wrappers in $work/bin; the kit's
    # libraries (Debian 12's libstdc++, libssl, ...) are not put before the machine's own for anything else
    # (nvidia-smi, ncu, compute-sanitizer, the shell's tools)
    kit=$(cd "$build" && pwd)
    mkdir "$work/bin"
    for tool in spraycoat h5dump h5diff h5ls; do
        cat > "$work/bin/$tool" <<EOF
#!/bin/sh
LD_LIBRARY_PATH="$kit/lib\${LD_LIBRARY_PATH:+:\$LD_LIBRARY_PATH}:/usr/local/nvidia/lib64:/usr/local/nvidia/lib"
export LD_LIBRARY_PATH
exec "$kit/$tool" "\$@"
EOF
        chmod +x "$work/bin/$tool"
    done
    PATH="$work/bin:$PATH:/usr/local/cuda/bin"
    export PATH
    bin="$work/bin/spraycoat"
fi
want() { case " $parts " in *" $1 "*) return 0 ;; esac; return 1; }

# a binary with the GPU step (make CUDA=1, or the emulation on the CPU of BUILD/cuda-emu: docs/gpu.md) is used as it is
if [ "$gpu" = gpu ] && ! "$bin" --version 2>/dev/null | grep -q "^  gpu  *CUDA step"; then
    note "building $bin with make CUDA=1 ($jobs jobs)"
    make -j"$jobs" CUDA=1 BUILD="$build" "$bin" > "$work/build.log" 2>&1 || {
        tail -30 "$work/build.log"
        echo "FAIL gpu_check: make CUDA=1 failed"
        exit 1
    }
fi
# on_device: the gpu side runs on a real device (not GPU_CHECK_DEVICE=cpu, not the emulation)
on_device=0
if [ "$gpu" = gpu ] && ! "$bin" --version 2>/dev/null | grep -q "^  gpu .*emulated"; then on_device=1; fi

# What is being checked: the binary's git line and sources_id against the sources of this tree (the digest of
# the Makefile's RESULT_SRC, as make computes SOURCES_ID), and the kit's record of its build
echo "# gpu_check $(date -u '+%Y-%m-%d %H:%M UTC'), $(uname -n), BUILD $build, parts $parts"
command -v nvidia-smi > /dev/null 2>&1 && nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader
if [ "$on_device" = 1 ]; then # what the first device run needs to know if cudart finds no driver
    ldconfig -p 2> /dev/null | grep -m 1 'libcuda\.so\.1' >&2 || note "libcuda.so.1 is not in the loader's cache"
fi
"$bin" --version > "$work/version.txt" 2>&1
bin_git=$(sed -n 's/^  git  *//p' "$work/version.txt")
bin_id=$(sed -n 's/^  sources_id  *//p' "$work/version.txt")
echo "binary: $(head -n 1 "$work/version.txt"), git ${bin_git:-?}, sources_id ${bin_id:-?}, gpu: $(sed -n 's/^  gpu  *//p' "$work/version.txt")"
[ -f "$build/COMMIT" ] && sed 's/^/kit: /' "$build/COMMIT"
tree_id=""
if [ -f Makefile ] && [ -d mpm ]; then
    tree_id=$(for f in $(printf '%s\n' core/*.[ch] dem/*.[ch] mpm/*.[ch] mpm/cuda/*.cu mpm/cuda/*.h coupling/*.[ch] \
        app/*.[ch] | LC_ALL=C sort); do [ -f "$f" ] && cat "$f"; done | sha256sum | cut -c1-16)
fi
stale=""
if [ -z "$tree_id" ]; then
    echo "note: no sources here to compare the binary with (run from the repository's root)"
elif [ "$tree_id" = "$bin_id" ]; then
    echo "the binary was built from this tree's sources (sources_id $tree_id)"
else
    stale="the binary's sources_id ${bin_id:-?} is not this tree's $tree_id"
    echo "STALE: $stale: its results are those of git ${bin_git:-?}; rebuild the kit here (scripts/gpu_kit.sh)" \
        "just before the device call"
fi
[ "$quick" = 1 ] && echo "GPU_CHECK_QUICK=1: every case coarser and shorter; a dry run of the script, not a check"

# limit: the seconds the next run may take: GPU_CHECK_TIMEOUT, at most what is left of GPU_CHECK_BUDGET (10 s kept
# for the summary); under 5: none
limit() {
    left=$((budget - ($(date +%s) - start) - 10))
    [ "$left" -gt "$per_run" ] && left=$per_run
    [ "$left" -ge 5 ] || left=0
    echo "$left"
}
# timed SECONDS LOG COMMAND...: the command under timeout, its output into LOG; its exit status (124: timed out)
timed() {
    t=$1 log=$2
    shift 2
    timeout -k 10 "$t" "$@" > "$log" 2>&1
}

# impact_case NAME GRID SPACING T_END [extra lines]: the case's .ini (series every eighth of T_END, at most 1 ns,
# unless a line sets series_every)
impact_case() {
    name=$1 grid=$2 spacing=$3 t_end=$4
    shift 4
    if [ "$quick" = 1 ]; then
        grid=$(awk -v a="$grid" 'BEGIN { print 2 * a }') spacing=$(awk -v a="$spacing" 'BEGIN { print 2 * a }')
        t_end=$(awk -v a="$t_end" 'BEGIN { print a / 10 }')
    fi
    {
        printf '[run]\ncheckpoint_wall = 0\n[impact]\ngrid = %s\nspacing = %s\nt_end = %s\n' "$grid" "$spacing" "$t_end"
        printf 'snapshot_every = %s\n' "$t_end"
        case "$*" in
            *series_every*) ;;
            *) printf 'series_every = %s\n' "$(awk -v t="$t_end" 'BEGIN { print t < 8e-9 ? t / 8 : 1e-9 }')" ;;
        esac
        for line in "$@"; do printf '%s\n' "$line"; done
        printf '[material.aluminium]\n'
    } > "$work/$name.ini"
}

# run NAME DEVICE THREADS: the log's PUPS and loop time into $work/NAME.DEVICE.{log,pups}; on failure (exit status,
# timeout, no time left) the reason in $work/NAME.DEVICE.why and status 1
run() {
    rm -rf "$work/$1.$2" "$work/$1.$2.pups" "$work/$1.$2.why"
    device=$2
    [ "$device" = gpu ] && device=$gpu
    t=$(limit)
    if [ "$t" = 0 ]; then
        echo "not run: GPU_CHECK_BUDGET's $budget s are spent" > "$work/$1.$2.why"
        return 1
    fi
    timed "$t" "$work/$1.$2.log" "$bin" impact "$work/$1.ini" -o "$work/$1.$2" --device "$device" --threads "$3"
    status=$?
    if [ "$status" != 0 ]; then
        case $status in
            124 | 137) printf 'timed out after %s s: ' "$t" ;;
            *) printf 'exit status %s: ' "$status" ;;
        esac > "$work/$1.$2.why"
        # the program's own message (spraycoat: ...), else the log's last lines
        { grep -m 2 '^spraycoat:\|rror' "$work/$1.$2.log" || tail -n 2 "$work/$1.$2.log"; } | cut -c1-300 |
            tr '\n' ' ' >> "$work/$1.$2.why"
        return 1
    fi
    line=$(grep "point updates/s" "$work/$1.$2.log" | tail -1)
    pups=$(echo "$line" | sed -n 's/.* s, \([0-9.e+]*\) point updates\/s.*/\1/p')
    loop=$(echo "$line" | sed -n 's/.*time loop \([0-9.]*\) s wall.*/\1/p')
    line=$(grep "points removed" "$work/$1.$2.log" | tail -1)
    points=$(echo "$line" | sed -n 's/.* of \([0-9]*\) points removed.*/\1/p')
    steps=$(echo "$line" | sed -n 's/.* after \([0-9]*\) steps.*/\1/p')
    echo "${pups:--} ${points:--} ${steps:--} ${loop:--}" > "$work/$1.$2.pups"
}
# try NAME DEVICE THREADS: run, and where it fails a FAIL row naming the run and why
try() {
    run "$@" && return 0
    echo "| run       | FAIL   | $1 on $2: $(cat "$work/$1.$2.why") |"
    bad "$1.$2"
    return 1
}
# both NAME: the case on the CPU (all cores) and on the GPU, each tried whatever the other gave; 1 if either failed
both() {
    try "$1" cpu 0
    cpu_status=$?
    try "$1" gpu 1 && [ "$cpu_status" = 0 ]
}

# dataset FILE PATH: the values, one a line
dataset() { h5dump -d "$2" -y -w 0 -m %.17g "$1" 2>/dev/null | awk '/DATA \{/ { on = 1; next } /\}/ { on = 0 } on' |
    tr ',' '\n' | sed -n 's/^ *\([-0-9.eEinfa+][-0-9.eEinfa+]*\) *$/\1/p'; }

# last_snapshot DIR: the name of the run's last snapshot group
last_snapshot() { h5ls "$1/impact.h5/snapshots" 2>/dev/null | awk '$1 ~ /^[0-9]+$/ { print $1 }' | sort -n | tail -1; }

# same_ids NAME: the last snapshots' point ids of the CPU's and the GPU's run (into $work/ids.cpu, ids.gpu), one row:
# the same set of points on both (the fields are compared by id, so a point removed on one device only is left out
# of the fields' rows and fails this one)
same_ids() {
    snap=$(last_snapshot "$work/$1.cpu")
    dataset "$work/$1.cpu/impact.h5" "/snapshots/$snap/id" > "$work/ids.cpu"
    dataset "$work/$1.gpu/impact.h5" "/snapshots/$snap/id" > "$work/ids.gpu"
    result=$(awk -v a="$work/ids.cpu" -v b="$work/ids.gpu" 'BEGIN {
        while ((getline x < a) > 0) { na++; in_a[x] = 1 }
        while ((getline x < b) > 0) { nb++; if (x in in_a) common++ }
        printf "%s %d %d %d\n", (na > 0 && na == nb && common == na) ? "PASS" : "FAIL", na, nb, na - common }')
    set -- "$@" ${result:-FAIL 0 0 0}
    if [ "$2" = PASS ]; then
        echo "| ids       | PASS   | $3 points in snapshot $snap, the same ids on both devices |"
    else
        echo "| ids       | FAIL   | cpu $3 points, gpu $4, $5 of the cpu's not on the gpu (snapshot ${snap:-none}): the fields compare the common ids |"
        bad "$1.ids"
    fi
}

# compare NAME FIELD TOLERANCE SCALE: the last snapshot's FIELD on both devices, point by point id (same_ids wrote
# the ids); max |cpu - gpu| <= TOLERANCE * SCALE passes (SCALE "max": the largest |value| of the CPU's field); the
# RMS, the 99th percentile and the count of the differences beyond the tolerance are printed for setting the
# tolerances from the first device runs.  NaN on one side only counts as beyond the tolerance.
compare() {
    snap=$(last_snapshot "$work/$1.cpu")
    rm -f "$work/diffs"
    dataset "$work/$1.cpu/impact.h5" "/snapshots/$snap/$2" > "$work/val.cpu"
    dataset "$work/$1.gpu/impact.h5" "/snapshots/$snap/$2" > "$work/val.gpu"
    result=$(awk -v ia="$work/ids.cpu" -v ib="$work/ids.gpu" -v va="$work/val.cpu" -v vb="$work/val.gpu" \
        -v tol="$3" -v scale="$4" -v dfile="$work/diffs" 'BEGIN {
        while ((getline x < ia) > 0) id_a[na++] = x
        while ((getline x < ib) > 0) pos_b[x] = nb++
        while ((getline x < va) > 0) a[ka++] = x
        while ((getline x < vb) > 0) b[kb++] = x
        w = na > 0 ? ka / na : 0
        if (w < 1 || w != int(w) || nb == 0 || kb != w * nb) { print "FAIL 0 - - - - -"; exit }
        for (k = 0; k < ka; k++) { v = a[k] + 0; if (v < 0) v = -v; if (a[k] !~ /nan/ && v > amax) amax = v }
        s = scale == "max" ? amax : scale
        bound = tol * s
        printf "" > dfile
        for (i = 0; i < na; i++) {
            if (!(id_a[i] in pos_b)) continue
            j = pos_b[id_a[i]]
            for (c = 0; c < w; c++) {
                x = a[i * w + c]; y = b[j * w + c]
                if (x ~ /nan/ || y ~ /nan/) { if (!(x ~ /nan/ && y ~ /nan/)) { over++; nan++ }; continue }
                d = x - y; if (d < 0) d = -d
                n++; sum2 += d * d; if (d > dmax) dmax = d; if (d > bound) over++
                printf "%.17g\n", d > dfile
            }
        }
        close(dfile)
        ok = n > 0 && over == 0
        printf "%s %d %.3g %.3g %d %.3g %d\n", ok ? "PASS" : "FAIL", n, dmax, n ? sqrt(sum2 / n) : 0, over, bound, nan }')
    set -- "$@" ${result:-FAIL 0 - - - - -}
    # the 99th percentile: the difference at rank ceil(0.99 n)
    p99=$(sort -g "$work/diffs" 2>/dev/null | awk -v n="$6" 'NR == int(0.99 * n + 0.999) { printf "%.3g", $1; exit }')
    printf '| %-9s | %6s | %9s | %10s | %10s | %10s | %7s | %10s |\n' "$2" "$5" "$6" "$7" "$8" "${p99:--}" "$9" "${10}"
    [ "${11}" = 0 ] || [ "${11}" = - ] || echo "|           |        | ${11} values NaN on one device only |"
    [ "$5" = PASS ] || bad "$1.$2"
}
compare_header() {
    echo "| field     | result | values    | max diff   | rms diff   | p99 diff   | > tol   | tolerance  |"
    echo "| --------- | ------ | --------- | ---------- | ---------- | ---------- | ------- | ---------- |"
}

verdicts() { dataset "$1/impact.h5" /summary/verdict | tr '\n' ' '; }
same_verdicts() { # NAME: the CPU's and the GPU's verdicts of run NAME, one table row
    cv=$(verdicts "$work/$1.cpu") gv=$(verdicts "$work/$1.gpu")
    if [ -n "$cv" ] && [ "$cv" = "$gv" ]; then
        echo "| verdicts  | PASS   | $cv |"
    else
        echo "| verdicts  | FAIL   | cpu ${cv:-none}, gpu ${gv:-none} |"
        bad "$1.verdicts"
    fi
}

# small_case: part 1's small impact (8 um at 810 m/s, 1.0/0.5 um, 4 ns), also part 2's first rows
small_case() {
    impact_case small 1e-6 0.5e-6 4e-9 "diameter = 8e-6" "velocity = 810" "substrate_diameter = 20e-6" \
        "substrate_height = 8e-6" "bonding = energy"
}

# variant NAME LINE FIELD...: part 1's small impact with the [impact] LINE added, on both devices: the FIELDs of the
# last snapshot compared (part 1's tolerances) and the verdicts
variant() {
    name=$1 line=$2
    shift 2
    printf '\nThe same impact with %s:\n\n' "$line"
    impact_case "$name" 1e-6 0.5e-6 4e-9 "diameter = 8e-6" "velocity = 810" "substrate_diameter = 20e-6" \
        "substrate_height = 8e-6" "bonding = energy" "$line"
    both "$name" || return
    compare_header
    same_ids "$name"
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
if want 0; then
    echo
    echo "## 0. compute-sanitizer memcheck, 4 um on a 1.0/0.5 um grid, 0.3 ns"
    echo
    if [ "$on_device" = 0 ]; then
        echo "SKIP sanitizer: no device (GPU_CHECK_DEVICE=$gpu or the emulation)"
    elif ! command -v compute-sanitizer > /dev/null 2>&1; then
        echo "SKIP sanitizer: compute-sanitizer is not installed"
    elif [ "$(limit)" = 0 ]; then
        echo "SKIP sanitizer: GPU_CHECK_BUDGET's $budget s are spent"
    else
        impact_case tiny 1e-6 0.5e-6 0.3e-9 "diameter = 4e-6" "velocity = 800" "substrate_diameter = 10e-6" \
            "substrate_height = 4e-6" "bonding = energy"
        t=$(limit)
        timed "$t" "$work/sanitizer.log" compute-sanitizer --target-processes all --tool memcheck --leak-check full \
            --print-limit 20 "$bin" impact "$work/tiny.ini" -o "$work/tiny.san" --device gpu
        status=$?
        [ -n "${OUT:-}" ] && cp "$work/sanitizer.log" "$OUT/sanitizer.log"
        tail -4 "$work/sanitizer.log"
        if [ "$status" = 0 ] && grep -q "ERROR SUMMARY: 0 errors" "$work/sanitizer.log"; then
            echo "PASS sanitizer"
        elif [ "$status" = 124 ] || [ "$status" = 137 ]; then
            echo "FAIL sanitizer (timed out after $t s)"
            bad sanitizer
        elif ! grep -q "ERROR SUMMARY" "$work/sanitizer.log" || grep -q "Device not supported" "$work/sanitizer.log"; then
            # it did not check (on gVisor: "Device not supported", then error 999 at the first allocation)
            echo "SKIP sanitizer: compute-sanitizer could not check here (exit status $status):" \
                "$(grep -m 1 -i 'error\|not supported' "$work/sanitizer.log" | cut -c1-200)"
        else
            sed -n '1,60p' "$work/sanitizer.log"
            echo "FAIL sanitizer (exit status $status)"
            bad sanitizer
        fi
    fi
fi

if want 1; then
    echo
    echo "## 1. The same small impact on the CPU and the GPU"
    echo
    small_case
    if both small; then
        compare_header
        same_ids small
        compare small x 1e-3 1e-6
        compare small v 1e-3 810
        compare small T 1 1
        compare small pressure 1e-3 max
        compare small von_mises 1e-3 max
        compare small eps_p 1e-3 1
        compare small D_bond 1e-3 1
        # the interface nodes of the last series row, all bodies (the GPU counts them on its grid): the runs
        # separate from round-off, so within 5 % + 2 nodes (a first guess, as the fields' tolerances), and some
        # must be counted
        ci=$(last_row_sum "$work/small.cpu" interface_nodes) gi=$(last_row_sum "$work/small.gpu" interface_nodes)
        cb=$(last_row_sum "$work/small.cpu" bonded_nodes) gb=$(last_row_sum "$work/small.gpu" bonded_nodes)
        if awk -v c="$ci" -v g="$gi" -v cb="$cb" -v gb="$gb" 'function near(a, b) { d = a - b; if (d < 0) d = -d; return d <= 0.05 * a + 2 }
            BEGIN { exit !(c > 0 && g >= 0 && gb >= 0 && near(c, g) && near(cb, gb)) }'; then
            echo "| interface | PASS   | cpu $cb of $ci nodes bonded, gpu $gb of $gi |"
        else
            echo "| interface | FAIL   | cpu $cb of $ci nodes bonded, gpu $gb of $gi (within 5 % + 2, cpu > 0) |"
            bad small.interface
        fi
        same_verdicts small
        # run to run: the GPU again, the same bits (h5diff: every snapshot dataset)
        mv "$work/small.gpu" "$work/small.gpu1"
        if try small gpu 1; then
            h5diff -q "$work/small.gpu1/impact.h5" "$work/small.gpu/impact.h5" /snapshots /snapshots > /dev/null 2>&1
            case $? in
                0) echo "| repeat    | PASS   | two GPU runs give the same snapshots |" ;;
                1) echo "| repeat    | FAIL   | two GPU runs differ |"; bad small.repeat ;;
                *) echo "| repeat    | FAIL   | h5diff could not compare the two GPU runs |"; bad small.repeat ;;
            esac
        fi
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
        both "settle$speed" || continue
        for device in cpu gpu; do
            set -- $(summary "$work/settle$speed.$device") - - - - -
            # numbers as numbers, anything else (nan: not settled, -: not read) as it is
            awk -v s="$speed" -v d="$device" -v v="$1" -v t="$2" -v p="$3" -v r="$4" -v b="$5" '
                function f(x, fmt, scale) { return x ~ /^[-+0-9.eE]+$/ ? sprintf(fmt, x * scale) : x }
                BEGIN { printf "| %5s | %-6s | %7s | %13s | %9s | %10s | %16s |\n", s, d, v, f(t, "%.2f", 1e9),
                        f(p, "%.4f", 1), f(r, "%.3f", 1), f(b, "%.4f", 1) }'
            eval "verdict_$device=\$1"
        done
        [ "$verdict_cpu" != - ] && [ "$verdict_cpu" = "$verdict_gpu" ] ||
            { echo "| verdict $speed m/s: FAIL, cpu $verdict_cpu gpu $verdict_gpu |"; bad "settle$speed"; }
    done
fi

if want 2; then
    echo
    echo "## 2. Point updates per second"
    echo
    echo "| case                                   | device | points    | steps | PUPS       | loop s | GPU/CPU |"
    echo "| -------------------------------------- | ------ | --------- | ----- | ---------- | ------ | ------- |"
    # row LABEL NAME DEVICE [CPU_PUPS]: the run's numbers, or a FAIL row where it gave none
    row() {
        f="$work/$2.$3.pups"
        if [ -s "$f" ]; then
            read -r pups points steps loop < "$f"
            ratio=$(awk -v a="$pups" -v b="${4:--}" 'BEGIN { if (b + 0 > 0 && a + 0 > 0) printf "%.3g", a / b; else print "-" }')
            printf '| %-38s | %-6s | %9s | %5s | %10s | %6s | %7s |\n' "$1" "$3" "$points" "$steps" "$pups" "$loop" "$ratio"
        else
            why=$(cat "$work/$2.$3.why" 2> /dev/null)
            printf '| %-38s | %-6s | FAIL: %s |\n' "$1" "$3" "${why:-no numbers}"
            bad "$2.$3"
        fi
    }
    # pups_of NAME DEVICE: the run's PUPS, empty where it has none
    pups_of() { [ -s "$work/$1.$2.pups" ] && awk '{ print $1 }' "$work/$1.$2.pups"; }
    if [ ! -s "$work/small.cpu.pups" ] || [ ! -s "$work/small.gpu.pups" ]; then # part 1 did not run it
        small_case
        run small cpu 0
        run small gpu 1
    fi
    row "small, 8 um, 1.0/0.5, 4 ns" small cpu
    row "small, 8 um, 1.0/0.5, 4 ns" small gpu "$(pups_of small cpu)"
    # ~1e6 points: 14 um on a 30 x 10 um cylinder, grid 0.7 um, spacing 0.2 um (bench_impact.sh's large case)
    impact_case m1 0.7e-6 0.2e-6 2e-9 "substrate_diameter = 30e-6" "substrate_height = 10e-6"
    run m1 cpu 0
    row "14 um, 0.7/0.2 (1e6 points), 2 ns" m1 cpu
    m1_cpu_pups=$(pups_of m1 cpu)
    run m1 gpu 1
    row "14 um, 0.7/0.2 (1e6 points), 2 ns" m1 gpu "$m1_cpu_pups"
    # the same without reordering the points in memory by cell (the same bits; docs/gpu.md): what the reordering gains
    cp "$work/m1.ini" "$work/m1_unordered.ini"
    SPRAYCOAT_GPU_REORDER_EVERY=0
    export SPRAYCOAT_GPU_REORDER_EVERY
    run m1_unordered gpu 1
    unset SPRAYCOAT_GPU_REORDER_EVERY
    row "the same, points never reordered" m1_unordered gpu "$m1_cpu_pups"
    if [ ! -f "$work/m1.gpu/impact.h5" ] || [ ! -f "$work/m1_unordered.gpu/impact.h5" ]; then
        order_check="FAIL: not compared (a run failed)"
        bad order
    elif h5diff -r -d 0 "$work/m1.gpu/impact.h5" "$work/m1_unordered.gpu/impact.h5" /snapshots /snapshots > "$work/order.diff" 2>&1 &&
        h5diff -r -d 0 "$work/m1.gpu/impact.h5" "$work/m1_unordered.gpu/impact.h5" /series /series >> "$work/order.diff" 2>&1; then
        order_check="PASS: the same bits reordered and never reordered"
    else
        order_check="FAIL: the storage order changes the results ($(awk '/differences found/ && $1 > 0' "$work/order.diff" | wc -l) datasets differ)"
        bad order
    fi
    # ~1e7 points: the same at spacing 0.0875 um (grid 0.35 um)
    impact_case m10 0.35e-6 0.0875e-6 0.3e-9 "substrate_diameter = 30e-6" "substrate_height = 10e-6"
    run m10 gpu 1
    row "14 um, 0.35/0.0875 (1e7 points), 0.3 ns" m10 gpu "$m1_cpu_pups"
    # the thesis-grade case (cases/tang2021_single_14um.ini: grid 0.7 um, spacing 0.175 um), its first 5 of 60 ns (a twelfth)
    impact_case thesis 0.7e-6 0.175e-6 5e-9 "substrate_diameter = 30e-6" "substrate_height = 10e-6" "bonding = energy"
    run thesis gpu 1
    row "thesis 14 um, 0.7/0.175, 5 of 60 ns" thesis gpu "$m1_cpu_pups"
    # the same as a quarter (symmetry = quarter, as vcrit and calibrate run it): a quarter of the points
    impact_case thesisq 0.7e-6 0.175e-6 5e-9 "substrate_diameter = 30e-6" "substrate_height = 10e-6" \
        "bonding = energy" "symmetry = quarter"
    run thesisq gpu 1
    row "thesis 14 um quarter, 5 of 60 ns" thesisq gpu "$m1_cpu_pups"
    echo
    echo "GPU/CPU: the GPU's PUPS over the CPU's on the same case (small) or the 1e6-point case (the larger ones), CPU on all $(nproc) cores; $(($(date +%s) - start)) s in all"
    echo "1e6 points reordered by cell every 16 steps against never: $order_check"
    m10_pups=$(pups_of m10 gpu)
    if [ -z "$m10_pups" ] || [ "$m10_pups" = - ]; then
        echo "goal (issue 25): 3e8 FP64 PUPS at ~1e7 points: not measured (the 1e7-point run gave no numbers)"
    elif awk -v p="$m10_pups" 'BEGIN { exit !(p >= 3e8) }'; then
        echo "goal (issue 25): 3e8 FP64 PUPS at ~1e7 points: MET ($m10_pups)"
    else
        echo "goal (issue 25): 3e8 FP64 PUPS at ~1e7 points: NOT MET ($m10_pups, $(awk -v p="$m10_pups" 'BEGIN { printf "%.3g %%", 100 * p / 3e8 }') of it)"
    fi
fi

# 3. Nsight Compute on one step's kernels of the 1e6-point case, and on one reordering's: time, DRAM and SM
# throughput
ncu=$(command -v ncu || ls /opt/nvidia/nsight-compute/*/ncu 2> /dev/null | head -n 1)
if want 3; then
    echo
    echo "## 3. Nsight Compute, 14 um at 0.7/0.2 um (1e6 points), the kernels of one step and of one reordering"
    echo
fi
if want 3 && [ "$on_device" = 0 ]; then
    echo "SKIP profile: no device (GPU_CHECK_DEVICE=$gpu or the emulation)"
elif want 3 && [ -z "$ncu" ]; then
    echo "SKIP profile: ncu (Nsight Compute) is not installed"
elif want 3; then
    # The case's series_every = snapshot_every = t_end: no series row or snapshot launches a kernel before the
    # last step, so that the launches before a step are whole steps.  0.5 ns is 53 steps (dt 9.5 ps, seen on the
    # CPU).  The count: the upload's slot_kernel (1), then per step, with the points never reordered
    # (SPRAYCOAT_GPU_REORDER_EVERY=0; the reordering's ~14 launches at steps 0 and 16 would shift the window), the
    # case's 2 bodies and the defaults (contact_scheme = once, bond_growth = approach: the bodies' velocities), no
    # conduction (mpm/cuda/step.cu mpm_gpu_step_points): bin_kernel, CUB's radix sort of the 64-bit keys (onesweep:
    # a histogram, an exclusive sum and one pass per 8 of the key's bits, 3 for the 2^16 to 2^24 cells here),
    # range_kernel (7); gather, body_partial, body_velocity, nodal, book (5); the absorbed work's sum (CUB's
    # reduction: 2 kernels beyond one tile), g2p, the speed's max and the failed id's min (7); gather, correct,
    # velocity, update, remove (5); reduce's 6 reductions (12): 36 a step.  The series row at t = 0 is recorded
    # before the device is attached, and the first snapshot reads the host's points, which are up to date: no
    # launch.  So step k + 1 begins at launch 1 + 36 k: skipping 1 + 36 x 20 = 721 starts the window at step 21,
    # and 73 launches hold steps 21 and 22 and the bin_kernel of 23.  The table takes the first whole step in the
    # window (from a bin_kernel to the launch before the next one), so that a miscount (another number of sort
    # passes, a reduction in one tile) still gives a whole step, or says that the window held none.
    impact_case prof 0.7e-6 0.2e-6 0.5e-9 "substrate_diameter = 30e-6" "substrate_height = 10e-6" \
        "series_every = 0.5e-9"
    t=$(limit)
    if [ "$t" = 0 ]; then
        echo "SKIP profile: GPU_CHECK_BUDGET's $budget s are spent"
    else
        SPRAYCOAT_GPU_REORDER_EVERY=0
        export SPRAYCOAT_GPU_REORDER_EVERY
        timed "$t" "$work/ncu_step.log" "$ncu" --target-processes all --clock-control none \
            --print-kernel-base function --launch-skip 721 --launch-count 73 --section SpeedOfLight \
            --section Occupancy "$bin" impact "$work/prof.ini" -o "$work/prof" --device gpu
        status=$?
        unset SPRAYCOAT_GPU_REORDER_EVERY
        [ "$status" = 0 ] || echo "ncu (one step) ended with exit status $status: $(tail -n 2 "$work/ncu_step.log" | tr '\n' ' ')"
    fi
    # the reordering's own kernels: the second reordering, at step 16 (12 permutations and the slots; the upload's
    # slot_kernel and the first reordering's 13 launches skipped: the filter counts only the launches it matches)
    rm -rf "$work/prof"
    t=$(limit)
    if [ "$t" != 0 ]; then
        timed "$t" "$work/ncu_reorder.log" "$ncu" --target-processes all --clock-control none \
            --print-kernel-base function --kernel-name regex:'permute|slot_kernel' --launch-skip 14 \
            --launch-count 13 --section SpeedOfLight "$bin" impact "$work/prof.ini" -o "$work/prof" --device gpu
        status=$?
        [ "$status" = 0 ] || echo "ncu (the reordering) ended with exit status $status: $(tail -n 2 "$work/ncu_reorder.log" | tr '\n' ' ')"
    fi
    [ -n "${OUT:-}" ] && cp "$work"/ncu_*.log "$OUT/" 2> /dev/null
    # one row per profiled kernel: the name (the function's, as --print-kernel-base function prints it; a
    # demangled "void ns::name<...>(...)" is cut to "name"), its duration, DRAM and SM throughput
    ncu_rows() {
        awk 'function flush() { if (name != "") printf "%s\t%s\t%s\t%s\n", name, t, dram, sm; name = "" }
            /^  [^ =].* \([0-9]+, [0-9]+, [0-9]+\)x\([0-9]+, [0-9]+, [0-9]+\)/ {
                flush(); s = $0; sub(/^ +/, "", s); sub(/ *\([0-9]+, [0-9]+, [0-9]+\)x\(.*/, "", s)
                sub(/^void /, "", s); sub(/[(<].*/, "", s); n = split(s, part, "::"); name = part[n]
                t = "-"; dram = "-"; sm = "-"; next }
            name != "" && /^ +Duration/ { t = $NF " " $(NF - 1) }
            name != "" && /^ +DRAM Throughput/ { dram = $NF }
            name != "" && /^ +Compute \(SM\) Throughput/ { sm = $NF }
            END { flush() }' "$1"
    }
    # ncu_table ROWS: the rows as a table, with the sum of the durations
    ncu_table() {
        echo "| kernel                                   |     duration | DRAM          | SM          |"
        echo "| ---------------------------------------- | ------------ | ------------- | ----------- |"
        # the duration's unit: us (or usecond, as older versions print it), ms, ns, s; 1,234.5: no separators
        awk -F '\t' '{ split($2, d, " "); gsub(/,/, "", d[1])
                       u = d[2] ~ /^m/ ? 1000 : d[2] ~ /^n/ ? 0.001 : d[2] ~ /^s/ ? 1e6 : 1
                       total += d[1] * u
                       printf "| %-40s | %12s | DRAM %6s %% | SM %6s %% |\n", substr($1, 1, 40), $2, $3, $4 }
                     END { printf "| %-40s | %9.1f us |              |             |\n", NR " launches", total }' "$1"
    }
    ncu_rows "$work/ncu_step.log" > "$work/step.rows" 2> /dev/null
    # the first whole step: from the first bin_kernel to the launch before the next
    awk -F '\t' '$1 == "bin_kernel" { b++ } b == 1' "$work/step.rows" > "$work/step.one"
    if [ ! -s "$work/step.rows" ]; then
        echo "SKIP profile: ncu profiled no kernel (on gVisor it cannot read the counters; $work/ncu_step.log:" \
            "$(grep -m 1 -i 'error\|fail' "$work/ncu_step.log" 2> /dev/null | cut -c1-200))"
    elif [ "$(awk -F '\t' '$1 == "bin_kernel"' "$work/step.rows" | wc -l)" -ge 2 ]; then
        echo "One step (the window's first whole step, $(wc -l < "$work/step.one") launches; the window held $(wc -l < "$work/step.rows")):"
        echo
        ncu_table "$work/step.one"
    else
        echo "The window held no whole step (fewer than two bin_kernel launches among $(wc -l < "$work/step.rows")):" \
            "the launches per step differ from the count above; every profiled launch:"
        echo
        ncu_table "$work/step.rows"
    fi
    ncu_rows "$work/ncu_reorder.log" > "$work/reorder.rows" 2> /dev/null
    if [ -s "$work/reorder.rows" ]; then
        echo
        echo "One reordering (step 16):"
        echo
        ncu_table "$work/reorder.rows"
    fi
fi

if [ -n "${OUT:-}" ]; then
    (cd "$work" && tar -czf "$OUT/gpu_check_logs.tgz" ./*.log ./*.ini 2> /dev/null)
fi
echo
[ -n "$stale" ] && echo "STALE: $stale (the results are of the binary's sources, not of this tree)"
echo "$(($(date +%s) - start)) s in all"
if [ "$failed" = 0 ]; then
    echo "PASS gpu_check${stale:+ (of a STALE binary)}"
else
    echo "FAIL gpu_check${stale:+ (of a STALE binary)}:$failures"
fi
exit "$failed"
