#!/bin/sh
# A kit that runs the GPU step on the lent device machine (docs/gpu.md, "On the lent device machine"): that machine
# has the CUDA driver, nvcc, compute-sanitizer and ncu but not HDF5, SUNDIALS, Cairo, libinih or UDUNITS-2, and
# cannot install them.  So the CUDA binary is built here (make CUDA=1; cudart is linked statically) and copied into
# KIT together with the HDF5 tools gpu_check.sh reads and every shared library they load except glibc's own (libc,
# libm, libpthread, libdl, librt, libresolv, libnsl, libanl, libutil and the rest of glibc: the device machine's
# glibc is newer, and its parts must come from one glibc; the other libraries built against Debian 12's run on it).
# KIT is an ignored build-* folder; name it in the device call's carry.  KIT/COMMIT records what it was built from
# (gpu_check.sh prints it): build the kit here just before the device call, never on the device (no HDF5 headers
# there: step.cu's build stops at hdf5.h).
#   usage: scripts/gpu_kit.sh [KIT]                 (default build-gpu-kit)
#   then, on the device: scripts/gpu_check.sh KIT    (it finds KIT/lib and KIT's tools by itself)
set -eu
kit=${1:-build-gpu-kit}
case $kit in build-*) ;; *)
    echo "gpu_kit: KIT must be a build-* folder (ignored by git, so it travels only when carried): $kit" >&2
    exit 2 ;;
esac
# the HDF5 tools first: where they are missing (the device machine) the build would stop at hdf5.h
for tool in h5dump h5diff h5ls; do
    command -v "$tool" > /dev/null || {
        echo "gpu_kit: $tool is missing (hdf5-tools; scripts/bootstrap installs it); the kit is built on the" \
            "development machine, not on the device machine" >&2
        exit 2
    }
done
make -j"$(nproc)" CUDA=1 BUILD=build-cuda build-cuda/spraycoat
rm -rf "$kit"
mkdir -p "$kit/lib"
cp build-cuda/spraycoat "$kit/"
for tool in h5dump h5diff h5ls; do
    cp "$(command -v "$tool")" "$kit/"
done
# glibc's libraries stay behind (the loader ld-linux has no path in ldd's third column)
glibc='lib(c|m|mvec|pthread|dl|rt|resolv|nsl|anl|util|BrokenLocale|thread_db|nss_[a-z0-9_]+|c_malloc_debug)'
for binary in "$kit"/spraycoat "$kit"/h5dump "$kit"/h5diff "$kit"/h5ls; do
    ldd "$binary" | awk '$3 ~ /^\// { print $3 }'
done | sort -u | grep -v -E "/($glibc|ld-linux-x86-64)\.so" | while read -r lib; do
    cp -L "$lib" "$kit/lib/"
done
# what the kit was built from: the commit (with -dirty for uncommitted edits) and the binary's sources_id, which
# gpu_check.sh compares with the sources of the tree it runs in
{
    printf 'commit %s (%s)\n' "$(git describe --always --dirty --tags 2> /dev/null || echo unknown)" \
        "$(git rev-parse HEAD 2> /dev/null || echo unknown)"
    printf 'sources_id %s\n' "$("$kit/spraycoat" --version | sed -n 's/^  sources_id  *//p')"
    printf 'built %s on %s\n' "$(date -u '+%Y-%m-%d %H:%M UTC')" "$(uname -n)"
} > "$kit/COMMIT"
echo "gpu_kit: $kit holds $(ls "$kit/lib" | wc -l) libraries, $(du -sh "$kit" | cut -f1) (the device call carries at most 64 MiB)"
sed 's/^/gpu_kit: /' "$kit/COMMIT"
