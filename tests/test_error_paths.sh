#!/bin/sh
# Out of memory one way (core/error.h, issue 24): in the program's sources (core, dem, mpm, render, coupling,
# app) no out-of-memory error is a failed simulation (SC_ESIM, exit 1: kept for NaN and blow-ups) and nothing
# ends in abort() but the allow-listed internal errors below; allocation failures go through SC_FAIL_OOM,
# SC_FAIL_OOM_AT, sc_calloc or SC_DIE_OOM (status SC_EIO, exit 3).  Prints "PASS name" / "FAIL name: why".
# Run from the repository root.
set -u
dirs="core dem mpm render coupling app"
failed=0

for d in $dirs; do
    if [ ! -d "$d" ]; then
        echo "FAIL error_paths_setup: no folder $d (run from the repository root)"
        exit 1
    fi
done

# SC_ESIM and "out of memory" in one statement (the pattern of `return sc_error_set(SC_ESIM, ..., "out of
# memory")`, `SC_FAIL(SC_ESIM, "out of memory")`, `ptr ? ... : SC_ESIM` with an out-of-memory comment)
hits=$(grep -rn --include='*.c' --include='*.h' 'SC_ESIM[^;]*out of memory\|out of memory[^;]*SC_ESIM' $dirs)
if [ -n "$hits" ]; then
    echo "FAIL oom_not_esim: out of memory reported as SC_ESIM (a failed simulation); use SC_FAIL_OOM:"
    printf "%s\n" "$hits"
    failed=1
else
    echo "PASS oom_not_esim"
fi

# abort(): allowed only where it marks a bug in the program itself, never input or the machine's resources:
#   core/config.c config_bug: a key asked for that is not registered, a registry entry that contradicts itself
#     (a programmer's error, found by any test that loads a case; the core dump is what one wants then);
#   core/balance.c balance_shares: more than 2^32 - 1 items, which every caller caps first.
# Everything else (out of memory above all) exits through SC_DIE_OOM or returns a status.
allowed="core/config.c:1 core/balance.c:1"
hits=$(grep -rn --include='*.c' --include='*.h' 'abort()' $dirs | grep -v '^[^:]*:[0-9]*: *\(/\*\|\*\)')
bad=""
for file in $(echo "$hits" | cut -d: -f1 | sort -u); do
    count=$(echo "$hits" | grep -c "^$file:")
    ok=0
    for entry in $allowed; do
        [ "$entry" = "$file:$count" ] && ok=1
    done
    [ "$ok" = 1 ] || bad="$bad $file ($count)"
done
if [ -n "$bad" ]; then
    echo "FAIL no_abort: abort() in$bad; out of memory goes through SC_DIE_OOM (exit 3), an error through a status:"
    printf "%s\n" "$hits"
    failed=1
else
    echo "PASS no_abort"
fi

# the old out-of-memory message of dem/particles.c's or_die (now SC_DIE_OOM's one message)
hits=$(grep -rn --include='*.c' 'out of memory (%zu bytes requested)' $dirs)
if [ -n "$hits" ]; then
    echo "FAIL one_oom_message: an out-of-memory message of its own; use SC_DIE_OOM:"
    printf "%s\n" "$hits"
    failed=1
else
    echo "PASS one_oom_message"
fi

exit $failed
