#!/bin/sh
# A full disk or a file-size limit while a stage writes (docs/architecture.md: exit 3 on an I/O error, and a
# reader never sees a half-written file).  The spray stage and the impact stage of
# small cases run under `ulimit -f` limits that stop them at different files: spray.h5, the impact snapshots,
# its checkpoints and impact.h5 (whose snapshots are copied in at the end: HDF5's H5Ocopy crashed there with
# SIGSEGV, issue 24).  Each must end with exit status 3, a message saying the file size limit was exceeded (or
# the disk is full), no NAME.tmp left in the run directory, and the finished spray.h5 of an earlier run unchanged.
#
# The program ignores SIGXFSZ itself (app/main.c), so a write over the limit fails with EFBIG instead of killing
# it; this test does not ignore the signal for it.  Run from the repository root with $SPRAYCOAT_BIN
# (tests/run_tests.sh sets it).  About 5 s.
set -u

BIN=${SPRAYCOAT_BIN:-build/spraycoat}
case $BIN in
/*) ;;
*/*) BIN=$(pwd)/$BIN ;;
esac
SPRAY_DEMO=cases/mz2015_demo.ini

failures=0
pass() { echo "PASS $1"; }
fail() {
    echo "FAIL $1 ($2)"
    failures=$((failures + 1))
}

if [ ! -x "$BIN" ] || [ ! -r "$SPRAY_DEMO" ]; then
    echo "FAIL disk_full (no $BIN or $SPRAY_DEMO; run from the repository root after make)"
    exit 1
fi

T=$(mktemp -d) || exit 1
trap 'rm -rf "$T"' EXIT
trap 'exit 1' HUP INT TERM

# the spray demo shortened to 2 ms (spray.h5 of about 850 kB), and a twin with another seed
sed -e 's/^t_end *=.*/t_end = 2e-3/' -e 's/^checkpoint_steps *=.*/checkpoint_steps = 500/' "$SPRAY_DEMO" >"$T/spray.ini"
# (without checkpoints: the limit is to stop it at spray.h5)
sed -e 's/^seed *=.*/seed = 99/' -e 's/^checkpoint_steps *=.*/checkpoint_steps = 0/' "$T/spray.ini" >"$T/spray_other.ini"
if ! grep -q '^t_end = 2e-3$' "$T/spray.ini" || ! grep -q '^seed = 99$' "$T/spray_other.ini" ||
    ! grep -q '^checkpoint_steps = 0$' "$T/spray_other.ini"; then
    echo "FAIL disk_full ($SPRAY_DEMO no longer has the lines t_end, checkpoint_steps and seed this test rewrites)"
    exit 1
fi
# one particle on a coarse grid for 1 ns: ~4,100 points, snapshots of ~500 kB every 0.25 ns, a checkpoint every
# 4 steps (~1 MB), impact.h5 of ~2.5 MB; under a second
cat >"$T/impact.ini" <<'EOF'
[run]
checkpoint_steps = 4

[impact]
diameter = 10e-6
velocity = 810
grid = 2e-6
spacing = 1e-6
substrate = cylinder
substrate_diameter = 24e-6
substrate_height = 8e-6
t_end = 1e-9
snapshot_every = 0.25e-9
series_every = 0.1e-9

[material.aluminium]
EOF

# the earlier, finished output every limited run must leave alone
if ! "$BIN" spray "$T/spray.ini" -o "$T/done" >"$T/done.log" 2>&1 || [ ! -f "$T/done/spray.h5" ]; then
    echo "FAIL disk_full (the unlimited spray run failed: $(tail -n 3 "$T/done.log" | tr '\n' ' '))"
    exit 1
fi
before=$(cksum <"$T/done/spray.h5")

# `ulimit -f` counts 1024-byte blocks in bash, 512-byte blocks in dash and POSIX: find out which
block=$(
    cd "$T" || exit 1
    trap '' XFSZ
    ulimit -f 2
    head -c 1536 /dev/zero >probe 2>/dev/null
    wc -c <probe
)
case $block in
1024) per_kb=2 ;;
1536) per_kb=1 ;;
*)
    echo "FAIL disk_full (cannot tell the block size of ulimit -f: a 2-block limit let $block bytes through)"
    exit 1
    ;;
esac

# limited NAME KB STAGE CASE: run STAGE of CASE in a copy of $T/done with files limited to KB kilobytes and check
# the status, the message, the temporaries and spray.h5
limited() {
    name=$1
    run=$T/run_$name
    rm -rf "$run"
    cp -R "$T/done" "$run"
    (
        ulimit -f $(($2 * per_kb)) || exit 99
        exec "$BIN" "$3" "$4" -o "$run"
    ) >"$T/$name.out" 2>"$T/$name.err"
    status=$?
    message=$(grep 'spraycoat:' "$T/$name.err" | head -n 1)
    leftovers=$(find "$run" -name '*.tmp' | tr '\n' ' ')
    if [ "$status" -ne 3 ]; then
        fail "$name" "exit status $status, expected 3: $(tail -n 2 "$T/$name.err" | tr '\n' ' ')"
    elif ! printf '%s\n' "$message" | grep -qi 'file size limit exceeded\|no space left on device'; then
        fail "$name" "the message does not say the file size limit was exceeded or the disk is full: $message"
    elif printf '%s\n' "$message" | grep -qi 'input/output error'; then
        fail "$name" "the message blames an input/output error: $message"
    elif [ -n "$leftovers" ]; then
        fail "$name" "temporary files left behind: $leftovers"
    elif [ "$(cksum <"$run/spray.h5")" != "$before" ]; then
        fail "$name" "the finished spray.h5 of the earlier run changed"
    else
        pass "$name"
    fi
}

# spray.h5 itself (the rerun of another seed stops while writing it; the old one must survive whole)
limited spray_h5 400 spray "$T/spray_other.ini"
# the impact stage: its first snapshot, a checkpoint, and impact.h5 at three sizes (the snapshots copied in)
limited impact_snapshot 300 impact "$T/impact.ini"
limited impact_checkpoint 800 impact "$T/impact.ini"
limited impact_h5_1200 1200 impact "$T/impact.ini"
limited impact_h5_1600 1600 impact "$T/impact.ini"
limited impact_h5_2400 2400 impact "$T/impact.ini"
# the render stage's figures (Cairo said only "error while writing to output stream", not why)
limited render_figures 40 render "$T/spray.ini"

[ "$failures" -eq 0 ]
