#!/bin/sh
# The libFuzzer harnesses of the case reader and the two CSV readers (tests/fuzz/, `make fuzz`): built with clang,
# AddressSanitizer and UBSan into build-fuzz/ and run for FUZZ_SECONDS (20) each from the kept corpus
# tests/fuzz/corpus/; any crash, sanitizer report or abort fails (its input is kept and named).  `make fuzz`
# and `make validate` run them for 600 s each.  Without clang (and its libFuzzer) prints SKIP and the reason:
# scripts/bootstrap installs the Debian package clang.  Prints "PASS name" / "FAIL name: why".  Run from the
# repository root.
set -u
seconds=${FUZZ_SECONDS:-20}
build=${FUZZ_BUILD:-build-fuzz}

tmp=$(mktemp -d) || { echo "FAIL fuzz_setup: mktemp -d failed"; exit 1; }
trap 'rm -rf "$tmp"' EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

if ! command -v clang >/dev/null 2>&1; then
    echo "SKIP fuzz: clang is not installed (Debian package clang, which ships libFuzzer; scripts/bootstrap installs it)"
    exit 0
fi
printf 'int LLVMFuzzerTestOneInput(const unsigned char *d, unsigned long n);\nint LLVMFuzzerTestOneInput(const unsigned char *d, unsigned long n) { (void)d; (void)n; return 0; }\n' \
    >"$tmp/probe.c"
if ! clang -fsanitize=fuzzer,address,undefined "$tmp/probe.c" -o "$tmp/probe" >"$tmp/probe.log" 2>&1; then
    echo "SKIP fuzz: clang cannot build a libFuzzer program here: $(head -c 200 "$tmp/probe.log")"
    exit 0
fi

if make -s FUZZ_BUILD="$build" fuzz-build >"$tmp/build.log" 2>&1; then
    echo "PASS fuzz_build"
else
    echo "FAIL fuzz_build: make fuzz-build failed: $(grep -m 3 'error' "$tmp/build.log" | tr '\n' ' ' | cut -c1-400)"
    exit 0
fi

for target in fuzz_case fuzz_particles_csv fuzz_bodies_csv; do
    if FUZZ_BUILD="$build" FUZZ_SECONDS="$seconds" FUZZ_ARTIFACTS="$tmp/artifacts" tests/fuzz/run.sh "$target" \
        >"$tmp/$target.log" 2>&1; then
        echo "PASS ${target}_${seconds}s"
    else
        mkdir -p "${TMPDIR:-/tmp}/spraycoat_fuzz_crashes"
        cp "$tmp/artifacts/$target"-* "${TMPDIR:-/tmp}/spraycoat_fuzz_crashes/" 2>/dev/null
        echo "FAIL ${target}_${seconds}s: crash (inputs copied to ${TMPDIR:-/tmp}/spraycoat_fuzz_crashes/):" \
            "$(grep -m 1 -E 'ERROR|runtime error|internal error|deadly signal' "$tmp/$target.log" | cut -c1-300)"
    fi
done
exit 0
