#!/bin/sh
# A kit that runs the GPU step on the lent device machine (docs/gpu.md, "On the lent device machine"): that machine
# has the CUDA driver, nvcc, compute-sanitizer and ncu but not HDF5, SUNDIALS, Cairo, libinih or UDUNITS-2, and
# cannot install them.  So the CUDA binary is built here (make CUDA=1; cudart is linked statically) and copied into
# KIT together with the HDF5 tools gpu_check.sh reads and every shared library they load except the C library's own
# (the device machine's glibc is newer; the libraries built against Debian 12's run on it).  KIT is an ignored
# build-* folder; name it in the device call's carry.
#   usage: scripts/gpu_kit.sh [KIT]                 (default build-gpu-kit)
#   then, on the device: scripts/gpu_check.sh KIT    (it finds KIT/lib and KIT's tools by itself)
set -eu
kit=${1:-build-gpu-kit}
case $kit in build-*) ;; *)
    echo "gpu_kit: KIT must be a build-* folder (ignored by git, so it travels only when carried): $kit" >&2
    exit 2 ;;
esac
make -j"$(nproc)" CUDA=1 BUILD=build-cuda build-cuda/spraycoat
rm -rf "$kit"
mkdir -p "$kit/lib"
cp build-cuda/spraycoat "$kit/"
for tool in h5dump h5diff h5ls; do
    path=$(command -v "$tool") || { echo "gpu_kit: $tool is missing (hdf5-tools; scripts/bootstrap installs it)" >&2; exit 2; }
    cp "$path" "$kit/"
done
for binary in "$kit"/spraycoat "$kit"/h5dump "$kit"/h5diff "$kit"/h5ls; do
    ldd "$binary" | awk '$3 ~ /^\// { print $3 }'
done | sort -u | grep -v -E '/(libc|libm|libpthread|libdl|librt|ld-linux-x86-64)\.so' | while read -r lib; do
    cp -L "$lib" "$kit/lib/"
done
echo "gpu_kit: $kit holds $(ls "$kit/lib" | wc -l) libraries, $(du -sh "$kit" | cut -f1) (the device call carries at most 64 MiB)"
