#!/bin/sh
# The GPU step (docs/gpu.md) without a GPU: the device is chosen with [run] device or --device, and a binary built
# without the GPU step refuses gpu with exit status 2 and a message naming the key and make CUDA=1 (or, built with
# it, on a machine without a device: exit 2 naming the missing device); then, when nvcc is installed, the CUDA
# sources compile (mpm/cuda/*.cu with the flags of make CUDA=1, into build-cuda/, kept for the next run: a compile
# check, nothing runs on a device).  Without nvcc that part prints SKIP.  scripts/gpu_check.sh runs the step on a
# device.
set -u
BIN=${SPRAYCOAT_BIN:-build/spraycoat}
CASE=tests/bad_cases/valid_impact_base.ini
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
failed=0
pass() { echo "PASS $1"; }
fail() {
    echo "FAIL $1: $2"
    failed=1
}

# refuse_gpu NAME ARGS...: exit 2, and the message says why (no GPU step in this build, or no device)
refuse_gpu() {
    name=$1
    shift
    "$BIN" impact "$@" -o "$T/run_$name" > "$T/$name.out" 2>&1
    status=$?
    if [ "$status" -ne 2 ]; then
        fail "$name" "exit status $status, not 2: $(tail -c 300 "$T/$name.out")"
    elif grep -q "device" "$T/$name.out" &&
        grep -q "make CUDA=1\|no CUDA device" "$T/$name.out"; then
        pass "$name"
    else
        fail "$name" "the message names neither make CUDA=1 nor a missing device: $(tail -c 300 "$T/$name.out")"
    fi
}

if command -v nvidia-smi > /dev/null 2>&1 && nvidia-smi -L > /dev/null 2>&1; then
    echo "  a GPU is present: device = gpu may run here (scripts/gpu_check.sh checks it)"
else
    refuse_gpu device_option_gpu "$CASE" --device gpu
    { cat "$CASE"; } | sed 's/^seed = 7$/seed = 7\ndevice = gpu/' > "$T/gpu.ini"
    refuse_gpu device_key_gpu "$T/gpu.ini"
    grep -q "gpu.ini:[0-9]*: \[run\] device" "$T/device_key_gpu.out" && pass device_key_names_line ||
        fail device_key_names_line "no FILE:LINE: [run] device in: $(tail -c 300 "$T/device_key_gpu.out")"
fi
"$BIN" impact "$CASE" --device tpu -o "$T/run_tpu" > "$T/tpu.out" 2>&1
status=$?
[ "$status" -eq 2 ] && grep -q "cpu|gpu\|cpu, gpu" "$T/tpu.out" && pass device_option_unknown ||
    fail device_option_unknown "exit status $status: $(tail -c 300 "$T/tpu.out")"

NVCC=$(command -v nvcc 2> /dev/null || true)
[ -z "$NVCC" ] && [ -x /usr/local/cuda/bin/nvcc ] && NVCC=/usr/local/cuda/bin/nvcc
if [ -z "$NVCC" ]; then
    echo "SKIP cuda_compile: nvcc is not installed (the CUDA toolkit; make CUDA=1 needs it)"
else
    objects=$(ls mpm/cuda/*.cu | sed 's|^\(.*\)\.cu$|build-cuda/\1.o|')
    # shellcheck disable=SC2086
    if make --no-print-directory CUDA=1 NVCC="$NVCC" BUILD=build-cuda $objects > "$T/nvcc.log" 2>&1; then
        pass cuda_compile
    else
        fail cuda_compile "make CUDA=1 $objects: $(tail -c 1500 "$T/nvcc.log")"
    fi
fi
exit "$failed"
