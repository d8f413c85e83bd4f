#!/bin/sh
# shellcheck disable=SC2012 # ls lists files this test made, named without blanks
# The restart guarantee through the public command (docs/architecture.md "Determinism and restart",
# docs/files.md): a run that is SIGKILLed at any moment, or stopped by SIGTERM/SIGINT, and then resumed ends with
# the same spray.h5 as a run that was never stopped (its /snapshots too: each once, none missing); results do not depend on the thread count; a damaged
# newest checkpoint (in its data or in an attribute) falls back to the previous one with a warning; a checkpoint of
# another case is refused; a damaged finished output (a pipeline's spray.h5, a finished impact run's file) is
# computed again on resume, with a warning, to the uninterrupted run's results.
#
# Run from the repository root with $SPRAYCOAT_BIN (tests/run_tests.sh sets both).  Needs h5ls, h5diff and
# h5dump (Debian hdf5-tools), python3 and a sleep that takes fractions of a second (GNU coreutils).
# Prints "PASS name" / "FAIL name (reason)"; other lines are a log shown when something fails.
#
# "Identical" means, for two RUN_DIR/spray.h5: the same list of datasets (h5ls -r), every dataset equal by
# `h5diff -d 0` object by object *and* byte for byte (h5dump -b; h5diff compares values, so -0 == +0 to it),
# the root attributes case_hash, format and format_version equal, every other attribute equal (units, the
# /stats counters, ...) except the root attributes `created` (a time stamp) and `program_version` (git
# describe of the build: another engineer may rebuild the program while this test runs), and the root attribute
# `case` (the resolved case text) equal up to its "; read from:" line and "; default" marks (resolved_case).
# Debian's h5diff 1.10 cannot skip attributes, hence object by object rather than whole files.
set -u
. tests/wait_lib.sh

spraycoat_bin
DEMO=cases/mz2015_demo.ini

failures=0
pass() { echo "PASS $1"; }
fail() {
    echo "FAIL $1 ($2)"
    failures=$((failures + 1))
}
note() { echo "  $*"; }

for tool in h5ls h5diff h5dump; do
    if ! command -v "$tool" >/dev/null 2>&1; then
        echo "FAIL restart ($tool not found: install hdf5-tools)"
        exit 1
    fi
done
if [ ! -x "$BIN" ] || [ ! -r "$DEMO" ]; then
    echo "FAIL restart (no $BIN or $DEMO; run from the repository root after make)"
    exit 1
fi

scratch_dir

# ---- the cases: demo.ini shortened to ~2 s, a checkpoint every 200 steps; a twin with another seed ---------------
t_end=2e-3
every=200
if [ -n "${SPRAYCOAT_SANITIZED:-}" ]; then # ASan/UBSan runs are several times slower
    t_end=1e-3
    every=100
fi
CASE=$T/short.ini
OTHER=$T/other_seed.ini
# snapshots of the particles every 100 steps (spray.h5 /snapshots): a resumed run must hold each exactly once
sed -e "s/^t_end *=.*/t_end = $t_end\nsnapshot_every = 1e-4/" -e "s/^checkpoint_steps *=.*/checkpoint_steps = $every/" \
    "$DEMO" >"$CASE"
sed -e 's/^seed *=.*/seed = 1234567/' "$CASE" >"$OTHER"
if ! grep -q "^t_end = $t_end\$" "$CASE" || ! grep -q "^snapshot_every = 1e-4\$" "$CASE" || ! grep -q "^checkpoint_steps = $every\$" "$CASE" ||
    ! grep -q '^seed = 1234567$' "$OTHER"; then
    echo "FAIL restart ($DEMO no longer has the lines t_end, checkpoint_steps and seed this test rewrites)"
    exit 1
fi

# ---- helpers --------------------------------------------------------------------------------------------------

# Start the program in the background with its stdout and stderr in file $1; its pid in $bg.
# A non-interactive sh starts background commands with SIGINT (and SIGQUIT) ignored (POSIX "Asynchronous
# Lists"), and `trap - INT` cannot undo that in dash ("signals ignored on entry cannot be trapped or reset").
# spraycoat installs its own SIGINT handler with sigaction, which replaces the inherited SIG_IGN, but to test
# SIGINT as a terminal delivers it we also start it with SIGINT at its default where env(1) can do that
# (GNU coreutils >= 8.31 `env --default-signal=INT`; env execs, so $! is still spraycoat's pid).
if env --default-signal=INT true 2>/dev/null; then
    ENV_INT="env --default-signal=INT"
else
    ENV_INT="env"
fi
start_bg() {
    out=$1
    shift
    $ENV_INT "$BIN" "$@" >"$out" 2>&1 &
    bg=$!
}
# Wait for the background program; its exit status in $status.
wait_bg() {
    wait "$bg" 2>/dev/null # without the redirection dash reports "Killed" on stderr
    status=$?
    bg=""
}

checkpoint_count() { ls "$1"/checkpoints/spray_*.h5 2>/dev/null | wc -l | tr -d ' '; }
newest_checkpoint() { ls "$1"/checkpoints/spray_*.h5 2>/dev/null | LC_ALL=C sort | tail -n 1; }

# Poll until RUN_DIR $1 holds at least $2 checkpoints (1 when the background program ended first or 30 s passed).
checkpoints_at_least() { [ "$(checkpoint_count "$1")" -ge "$2" ]; }
wait_for_checkpoints() { wait_until "$bg" 30 checkpoints_at_least "$1" "$2"; }

datasets() { h5ls -r "$1" 2>/dev/null | awk '$2 == "Dataset" { print $1 }' | LC_ALL=C sort; }

# All attributes of a file (h5dump -A: headers and attributes, no data) less its first line (the file name)
# and the root attributes named in $2 (a regular expression of names).
attributes() {
    h5dump -A "$1" 2>&1 | sed 1d | awk -v skip="^   ATTRIBUTE \"($2)\" [{]\$" '
        $0 ~ skip { skipping = 1 }
        !skipping { print }
        skipping && /^   [}]$/ { skipping = 0 }'
}

# One root attribute as h5dump -a writes it, less the first line (the file name).
root_attribute() { h5dump -a "/$2" "$1" 2>&1 | sed 1d; }

# The root attribute `case` (the resolved case text) less what legitimately differs after a resume: the
# "; read from:" line (CASE.ini, or RUN_DIR/case.ini).
resolved_case() { root_attribute "$1" case | grep -v '; read from: '; }

# same_results DIR_A DIR_B [threads]: 0 when DIR_A/spray.h5 and DIR_B/spray.h5 are identical (see the top of
# this file), else 1 with the reason in $why.  With "threads", the case text and case hash are not compared
# (they hold [run] threads, which differs on purpose).
same_results() {
    a=$1/spray.h5
    b=$2/spray.h5
    mode=${3:-}
    why=""
    for f in "$a" "$b"; do
        if [ ! -f "$f" ]; then
            why="$f does not exist"
            return 1
        fi
    done
    datasets "$a" >"$T/datasets_a"
    datasets "$b" >"$T/datasets_b"
    na=$(wc -l <"$T/datasets_a" | tr -d ' ')
    nb=$(wc -l <"$T/datasets_b" | tr -d ' ')
    if [ "$na" -ne "$nb" ]; then
        why="$na datasets in $a but $nb in $b"
        return 1
    fi
    if [ "$na" -eq 0 ]; then
        why="h5ls finds no datasets in $a"
        return 1
    fi
    if ! cmp -s "$T/datasets_a" "$T/datasets_b"; then
        why="the dataset names differ: $(diff "$T/datasets_a" "$T/datasets_b" | grep '^[<>]' | head -n 4 | tr '\n' ' ')"
        return 1
    fi
    while read -r d; do
        if ! h5diff -d 0 "$a" "$b" "$d" "$d" >"$T/h5diff.out" 2>&1; then
            why="dataset $d differs: $(head -n 6 "$T/h5diff.out" | tr '\n' ' ')"
            return 1
        fi
    done <"$T/datasets_a"
    # the values of all datasets, one after the other, as bytes
    rm -f "$T/bytes_a" "$T/bytes_b"
    selection=$(awk '{ printf " -d %s", $1 }' "$T/datasets_a")
    # shellcheck disable=SC2086 # dataset names hold no blanks (h5ls -r shows them blank-separated anyway)
    if ! h5dump $selection -b NATIVE -o "$T/bytes_a" "$a" >/dev/null 2>&1 ||
        ! h5dump $selection -b NATIVE -o "$T/bytes_b" "$b" >/dev/null 2>&1; then
        why="h5dump -b cannot write the values of the datasets"
        return 1
    fi
    if ! cmp -s "$T/bytes_a" "$T/bytes_b"; then
        why="the bytes of the datasets differ though h5diff -d 0 finds no difference (NaN or -0?)"
        return 1
    fi
    for attr in case_hash format format_version; do
        [ "$mode" = threads ] && [ "$attr" = case_hash ] && continue
        root_attribute "$a" "$attr" >"$T/attr_a"
        root_attribute "$b" "$attr" >"$T/attr_b"
        if ! grep -q 'DATA' "$T/attr_a" || ! cmp -s "$T/attr_a" "$T/attr_b"; then
            why="root attribute $attr differs: $(grep '(0):' "$T/attr_a" | tr -s ' ') vs $(grep '(0):' "$T/attr_b" | tr -s ' ')"
            return 1
        fi
    done
    skip='created|program_version|case'
    [ "$mode" = threads ] && skip='created|program_version|case|case_hash'
    attributes "$a" "$skip" >"$T/attr_a"
    attributes "$b" "$skip" >"$T/attr_b"
    if ! cmp -s "$T/attr_a" "$T/attr_b"; then
        why="attributes differ: $(diff "$T/attr_a" "$T/attr_b" | grep '^[<>]' | head -n 6 | tr -s ' ' | tr '\n' ' ')"
        return 1
    fi
    if [ "$mode" != threads ]; then
        resolved_case "$a" >"$T/attr_a"
        resolved_case "$b" >"$T/attr_b"
        if ! grep -q 'DATA' "$T/attr_a" || ! cmp -s "$T/attr_a" "$T/attr_b"; then
            why="root attribute case (the resolved case) differs: $(diff "$T/attr_a" "$T/attr_b" | grep '^[<>]' | head -n 4 | tr -s ' ' | tr '\n' ' ')"
            return 1
        fi
    fi
    return 0
}

# ---- 1. the reference: one uninterrupted run ------------------------------------------------------------------
# milliseconds since the epoch (GNU date; elsewhere whole seconds)
now_ms() {
    ms=$(date +%s%N 2>/dev/null)
    case $ms in
    *N* | "") echo $(($(date +%s) * 1000)) ;;
    *) echo $((ms / 1000000)) ;;
    esac
}
start=$(date +%s)
ref_start=$(now_ms)
if ! "$BIN" spray "$CASE" -o "$T/ref" >"$T/ref.log" 2>&1; then
    echo "FAIL restart_reference (spraycoat spray exited with status $?)"
    tail -n 5 "$T/ref.log"
    exit 1
fi
if [ ! -f "$T/ref/spray.h5" ] || [ "$(datasets "$T/ref/spray.h5" | wc -l)" -eq 0 ]; then
    echo "FAIL restart_reference (no datasets in $T/ref/spray.h5)"
    exit 1
fi
ref_ms=$(($(now_ms) - ref_start))
[ "$ref_ms" -gt 0 ] || ref_ms=1000
note "reference run: $ref_ms ms, $(datasets "$T/ref/spray.h5" | wc -l | tr -d ' ') datasets"
pass restart_reference

# The step attribute of every snapshot of DIR/spray.h5, in the order of their names, one line; and the list a
# run must hold: 100, 200, .. up to the last step (t_end / dt), each once, none missing.
snapshot_steps() {
    h5ls "$1/spray.h5/snapshots" 2>/dev/null | awk '$2 == "Group" { print $1 }' | LC_ALL=C sort | while read -r g; do
        h5dump -a "/snapshots/$g/step" "$1/spray.h5" 2>/dev/null | sed -n 's/.*(0): *\([0-9]*\).*/\1/p'
    done | tr '\n' ' '
}
expected_steps=$(awk -v t="$t_end" 'BEGIN { n = int(t / 1e-6 + 0.5); for (s = 100; s <= n; s += 100) printf "%d ", s }')
test=restart_snapshots_reference
got=$(snapshot_steps "$T/ref")
if [ "$got" = "$expected_steps" ]; then
    pass "$test"
else
    fail "$test" "snapshot steps [$got], expected [$expected_steps]"
fi

# ---- 2. SIGKILL at several moments, resume each time ----------------------------------------------------------
# The kills come at fixed fractions of the reference run's wall time after the start of `spray` (the first,
# before any checkpoint) or `resume` (the others), so that on a fast or a busy machine alike they land at
# different steps, sometimes inside a checkpoint write (which leaves a spray_*.h5.tmp behind).  On an idle
# 2-core machine the reference takes ~1.6 s, and the kills come after 0.03, 0.32, 0.48, 0.56 and 0.64 s.
# Kill 2 comes 0.1 s after the resume has written a new checkpoint, so that at least one resume (kill 3's)
# starts from a checkpoint whatever the timing.  A kill that comes after the program has finished is logged.
# Before each resume this test also leaves what a kill inside a write leaves, half-written .tmp files of a
# later checkpoint and of spray.h5 (unless a kill left real ones): every resume must ignore them.
test=restart_kill_resume
from_checkpoint=0
problem=""
kill_number=0
delays=""
for fraction in 0.02 new-checkpoint 0.20 0.30 0.35 0.40; do
    if [ "$fraction" = new-checkpoint ]; then
        delays="$delays $fraction"
    else
        delays="$delays $(awk -v ms="$ref_ms" -v f="$fraction" 'BEGIN { printf "%.3f", ms * f / 1000 }')"
    fi
done
# Before a resume of $T/killed: log what it holds in $held, plant the half-written files.
prepare_resume() {
    # first take away what this function planted last time and the program left alone
    rm -f "$T/killed/checkpoints/spray_99999999.h5.tmp"
    if [ -f "$T/planted" ] && cmp -s "$T/planted" "$T/killed/spray.h5.tmp"; then
        rm -f "$T/killed/spray.h5.tmp"
    fi
    before=$(checkpoint_count "$T/killed")
    newest=$(newest_checkpoint "$T/killed")
    tmp=$(ls "$T"/killed/checkpoints/*.tmp "$T"/killed/*.tmp 2>/dev/null | wc -l | tr -d ' ')
    held="$before checkpoint(s), ${newest:+newest $(basename "$newest"), }$tmp .tmp file(s) left by the kill"
    if [ -n "$newest" ]; then
        head -c 50000 "$newest" >"$T/planted"
        cp "$T/planted" "$T/killed/checkpoints/spray_99999999.h5.tmp"
        [ -f "$T/killed/spray.h5.tmp" ] || cp "$T/planted" "$T/killed/spray.h5.tmp"
    fi
}
# Poll until file $1 exists (1 when the program ended first or 30 s passed).
wait_for_file() { wait_until "$bg" 30 test -e "$1"; }
# Poll until the newest checkpoint of RUN_DIR $1 is no longer $2 (1 when the program ended or 30 s passed).
newest_is_not() { [ "$(newest_checkpoint "$1")" != "$2" ]; }
wait_for_new_checkpoint() { wait_until "$bg" 30 newest_is_not "$1" "$2"; }
for delay in $delays; do
    kill_number=$((kill_number + 1))
    if [ "$kill_number" -eq 1 ]; then
        start_bg "$T/killed.log.$kill_number" spray "$CASE" -o "$T/killed"
    else
        prepare_resume
        start_bg "$T/killed.log.$kill_number" resume "$T/killed"
    fi
    when="${delay} s after the start"
    if [ "$delay" = new-checkpoint ]; then
        wait_for_new_checkpoint "$T/killed" "$newest"
        sleep 0.1
        when="0.1 s after it wrote $(basename "$(newest_checkpoint "$T/killed")")"
    else
        # the first kill counts from the moment the run directory is prepared (RUN_DIR/stages written): a kill
        # before it would leave nothing to resume, and a fast solver gets there in a few milliseconds
        [ "$kill_number" -eq 1 ] && wait_for_file "$T/killed/stages"
        sleep "$delay"
    fi
    kill -9 "$bg" 2>/dev/null
    wait_bg
    how="killed (status $status)"
    [ "$status" -eq 137 ] || how="had already ended with status $status"
    if [ "$kill_number" -gt 1 ]; then
        resumed=$(sed -n 's/.*spray: \(resuming from [^ ]*\) (step \([0-9]*\).*/\1 at step \2/p' \
            "$T/killed.log.$kill_number")
        if [ -n "$resumed" ]; then
            from_checkpoint=$((from_checkpoint + 1))
        elif grep -q 'nothing to do' "$T/killed.log.$kill_number"; then
            resumed="spray.h5 is there: nothing to do"
        elif grep -q 'steps of' "$T/killed.log.$kill_number"; then
            resumed="started from step 0"
        else
            resumed="killed before it logged anything"
        fi
        note "kill $kill_number: resume with $held: $resumed; SIGKILL $when: $how"
    else
        note "kill 1: spray, SIGKILL $when: $how"
    fi
    if [ "$status" -ne 137 ] && [ "$status" -ne 0 ]; then
        problem="run $kill_number ended with status $status: $(tail -n 1 "$T/killed.log.$kill_number")"
        break
    fi
done
if [ -z "$problem" ]; then
    prepare_resume
    if "$BIN" resume "$T/killed" >"$T/killed.log.final" 2>&1; then
        note "final resume with $held:" \
            "$(grep -o 'resuming from [^ ]*\|nothing to do' "$T/killed.log.final" || echo 'from step 0')"
    else
        problem="the final resume exited with status $?: $(tail -n 1 "$T/killed.log.final")"
    fi
fi
if [ -n "$problem" ]; then
    fail "$test" "$problem"
elif [ "$from_checkpoint" -eq 0 ]; then
    fail "$test" "no resume started from a checkpoint: the kills came too early or too late, change the delays"
elif ! same_results "$T/ref" "$T/killed"; then
    fail "$test" "after $kill_number kills and resumes ($from_checkpoint from a checkpoint): $why"
else
    pass "$test"
fi

# ---- 3. SIGTERM and SIGINT: checkpoint, exit 143/130, resume --------------------------------------------------
# The signal comes as soon as the first checkpoint is seen (step 200 of 2000; the whole run takes 0.3 s on an idle
# 2-core machine now, so a further wait let it finish first), and the run is left with that checkpoint and the one
# the signal writes.
signal_run() { # NAME SIGNAL EXPECTED_STATUS RUN_DIR
    test=$1
    dir=$4
    start_bg "$T/$test.log" spray "$CASE" -o "$dir"
    if ! wait_for_checkpoints "$dir" 1; then
        wait_bg
        fail "$test" "no checkpoint appeared while the run went on (it ended with status $status)"
        return 1
    fi
    kill -s "$2" "$bg"
    wait_bg
    if [ "$status" -ne "$3" ]; then
        fail "$test" "exit status $status after SIG$2, expected $3: $(tail -n 1 "$T/$test.log")"
        return 1
    fi
    if [ "$(checkpoint_count "$dir")" -eq 0 ]; then
        fail "$test" "no checkpoint in $dir/checkpoints after SIG$2"
        return 1
    fi
    if ! grep -q 'resume' "$T/$test.log"; then
        fail "$test" "the message after SIG$2 does not mention resume: $(tail -n 1 "$T/$test.log")"
        return 1
    fi
    note "SIG$2: status $status, $(checkpoint_count "$dir") checkpoint(s), newest $(basename "$(newest_checkpoint "$dir")")"
    return 0
}
resume_and_compare() { # NAME RUN_DIR
    if ! "$BIN" resume "$2" >"$T/$1.resume.log" 2>&1; then
        fail "$1" "resume exited with status $?: $(tail -n 1 "$T/$1.resume.log")"
        return 1
    fi
    if ! grep -q 'resuming from' "$T/$1.resume.log"; then
        fail "$1" "resume did not start from a checkpoint: $(head -n 3 "$T/$1.resume.log" | tr '\n' ' ')"
        return 1
    fi
    if ! same_results "$T/ref" "$2"; then
        fail "$1" "$why"
        return 1
    fi
    return 0
}
if signal_run restart_sigterm TERM 143 "$T/term" && resume_and_compare restart_sigterm "$T/term"; then
    pass restart_sigterm
fi
# the snapshots of the run stopped by SIGTERM and resumed: each step once, none missing (same_results compared
# them with the reference's already; this names what went wrong)
test=restart_snapshots_resumed
got=$(snapshot_steps "$T/term")
if [ "$got" = "$expected_steps" ]; then
    pass "$test"
else
    fail "$test" "snapshot steps after SIGTERM and resume [$got], expected [$expected_steps]"
fi
if signal_run restart_sigint INT 130 "$T/int" && resume_and_compare restart_sigint "$T/int"; then
    pass restart_sigint
fi

# ---- 4. thread count: --threads 1 and --threads 2 give the same results ---------------------------------------
test=restart_threads
if ! "$BIN" spray "$CASE" -o "$T/threads1" --threads 1 >"$T/threads1.log" 2>&1; then
    fail "$test" "--threads 1 exited with status $?: $(tail -n 1 "$T/threads1.log")"
elif ! "$BIN" spray "$CASE" -o "$T/threads2" --threads 2 >"$T/threads2.log" 2>&1; then
    fail "$test" "--threads 2 exited with status $?: $(tail -n 1 "$T/threads2.log")"
elif ! same_results "$T/threads1" "$T/threads2" threads; then
    fail "$test" "--threads 1 against --threads 2: $why"
elif ! same_results "$T/threads1" "$T/ref" threads; then
    fail "$test" "--threads 1 against the reference ([run] threads = 0): $why"
else
    pass "$test"
fi

# ---- 5. a damaged newest checkpoint: warning, fall back to the previous one, same results -----------------------
test=restart_corrupt_checkpoint
dir=$T/corrupt
if signal_run "$test" TERM 143 "$dir"; then
    count=$(checkpoint_count "$dir")
    newest=$(newest_checkpoint "$dir")
    previous=$(ls "$dir"/checkpoints/spray_*.h5 | LC_ALL=C sort | tail -n 2 | head -n 1)
    size=$(wc -c <"$newest" | tr -d ' ')
    cp "$newest" "$T/intact.h5"
    # 4 KiB of text over the middle of the file: raw data of a dataset there fails its Fletcher32 checksum,
    # metadata there fails to parse; either way the file is damaged.
    yes 'damaged checkpoint ' | head -c 4096 | dd of="$newest" bs=1 seek=$((size / 2)) conv=notrunc 2>/dev/null
    if [ "$count" -lt 2 ]; then
        fail "$test" "only $count checkpoint(s) after SIGTERM; need 2"
    elif cmp -s "$newest" "$T/intact.h5"; then
        fail "$test" "dd did not change $newest"
    elif ! "$BIN" resume "$dir" >"$T/$test.resume.log" 2>&1; then
        fail "$test" "resume exited with status $?: $(tail -n 1 "$T/$test.resume.log")"
    elif ! grep "$newest" "$T/$test.resume.log" | grep -qi 'damaged\|corrupt\|checksum'; then
        fail "$test" "no warning naming the damaged $newest: $(head -n 3 "$T/$test.resume.log" | tr '\n' ' ')"
    elif ! grep -q "resuming from $previous " "$T/$test.resume.log"; then
        fail "$test" "did not fall back to $previous: $(grep -m 1 'resuming\|damaged' "$T/$test.resume.log")"
    elif [ "$(grep -c "checkpoint $newest is damaged" "$T/$test.resume.log")" -ne 1 ]; then
        # (a review: the stage's validation and its resume both warned)
        fail "$test" "the damaged $newest is warned of $(grep -c "checkpoint $newest is damaged" "$T/$test.resume.log") times, not once"
    elif ! same_results "$T/ref" "$dir"; then
        fail "$test" "$why"
    else
        note "damaged $(basename "$newest") ($size bytes, 4096 overwritten at $((size / 2))):" \
            "$(grep -m 1 'damaged' "$T/$test.resume.log" | sed 's/^\[[^]]*\] //')"
        pass "$test"
    fi
fi

# ---- 5b. damaged metadata: the newest checkpoint's /snapshots count with one byte flipped -----------------------
# (a review: in the earliest HDF5 file format attributes had no checksum, and the resume went on from a count of
# 11 where 27 snapshots were written: the final spray.h5 lacked 16 of them).  Now a checksum fails: warning, fall
# back to the previous checkpoint, same results.
test=restart_damaged_attribute
dir=$T/attribute
if signal_run "$test" TERM 143 "$dir"; then
    newest=$(newest_checkpoint "$dir")
    previous=$(ls "$dir"/checkpoints/spray_*.h5 | LC_ALL=C sort | tail -n 2 | head -n 1)
    count=$(h5dump -a /snapshots/count "$newest" 2>/dev/null | sed -n 's/^ *(0): *//p')
    # the count's 8 bytes (little-endian) after the attribute's name: flip its lowest byte
    offset=$(python3 -c '
import struct, sys
data = open(sys.argv[1], "rb").read()
name = data.find(b"count\0")
value = data.find(struct.pack("<q", int(sys.argv[2])), name, name + 200) if name >= 0 else -1
print(value)' "$newest" "${count:-0}" 2>/dev/null)
    if [ -z "$count" ] || [ "${offset:--1}" -lt 0 ]; then
        fail "$test" "cannot find the value of /snapshots/count ($count) in $newest"
    else
        printf "$(printf '\\%03o' $((count ^ 16)))" | dd of="$newest" bs=1 seek="$offset" conv=notrunc 2>/dev/null
        "$BIN" resume "$dir" >"$T/$test.resume.log" 2>&1
        status=$?
        if [ "$status" -ne 0 ]; then
            fail "$test" "resume exited with status $status: $(tail -n 1 "$T/$test.resume.log")"
        elif ! grep "$newest" "$T/$test.resume.log" | grep -qi 'damaged'; then
            fail "$test" "no warning naming the damaged $newest: $(head -n 3 "$T/$test.resume.log" | tr '\n' ' ')"
        elif ! grep -q "resuming from $previous " "$T/$test.resume.log"; then
            fail "$test" "did not fall back to $previous: $(grep -m 1 'resuming\|damaged' "$T/$test.resume.log")"
        elif ! same_results "$T/ref" "$dir"; then
            fail "$test" "/snapshots/count $count turned into $((count ^ 16)): $why"
        else
            note "$(grep -m 1 'damaged' "$T/$test.resume.log" | sed 's/^\[[^]]*\] //')"
            pass "$test"
        fi
    fi
fi

# ---- 6. a checkpoint of another case is refused ---------------------------------------------------------------
test=restart_other_case
# a finished run removes its checkpoints: take them from a run stopped by SIGTERM
mkdir -p "$T/other/checkpoints"
signal_run restart_other_case TERM 143 "$T/source" >/dev/null
cp "$T"/source/checkpoints/spray_*.h5 "$T/other/checkpoints/" 2>/dev/null
copied=$(checkpoint_count "$T/other")
"$BIN" spray "$OTHER" -o "$T/other" >"$T/other.log" 2>&1
status=$?
if [ "$copied" -eq 0 ]; then
    fail "$test" "the interrupted run left no checkpoint to copy"
elif [ "$status" -ne 2 ]; then
    fail "$test" "exit status $status with another case's checkpoints, expected 2: $(tail -n 1 "$T/other.log")"
elif ! grep -qi 'another case' "$T/other.log"; then
    fail "$test" "the message does not say the checkpoint belongs to another case: $(tail -n 1 "$T/other.log")"
elif [ -f "$T/other/spray.h5" ]; then
    fail "$test" "a spray.h5 was written although the run was refused"
elif [ "$(checkpoint_count "$T/other")" -ne "$copied" ]; then
    fail "$test" "the refused checkpoints were deleted ($copied before, $(checkpoint_count "$T/other") after)"
else
    note "$(tail -n 1 "$T/other.log")"
    pass "$test"
fi

# RUN_DIR/case.ini is the same case as the one run: `resume` reads it.  It spelt the defaults out as keys, so read
# back they were given values: with [nozzle] the jet's constants, which the nozzle's exit state gives unless they
# are given, took their defaults (DE 0.45 where the case gives 0.88).  A short Al6061 nozzle spray, and the spray
# of its RUN_DIR/case.ini, must give the same spray.h5.
test=resolved_case_is_the_case
sed -e 's/^t_end = 24.8e-3$/t_end = 1e-3/' -e 's/^max_injected = 400$/max_injected = 40/' \
    -e 's/^feed_every = 2500$/feed_every = 100/' -e "s|^table = vcrit_al_temperature.csv|table = $(pwd)/cases/vcrit_al_temperature.csv|" \
    cases/al6061_n2.ini | sed '/^\[path\]/,$d' >"$T/nozzle.ini"
if ! "$BIN" spray "$T/nozzle.ini" -o "$T/nozzle" >"$T/nozzle.log" 2>&1 ||
    ! "$BIN" spray "$T/nozzle/case.ini" -o "$T/nozzle_again" >"$T/nozzle_again.log" 2>&1; then
    fail "$test" "a spray failed: $(tail -n 1 "$T/nozzle.log") $(tail -n 1 "$T/nozzle_again.log")"
elif ! grep -q '^; C1 = 30  (default)$' "$T/nozzle/case.ini"; then
    fail "$test" "case.ini does not show the default C1 as a comment: $(grep 'C1 =' "$T/nozzle/case.ini")"
elif ! same_results "$T/nozzle" "$T/nozzle_again"; then
    fail "$test" "the spray of RUN_DIR/case.ini differs from the case's: $why"
else
    pass "$test"
fi

# ---- 8. a damaged finished output is computed again on resume -------------------------------------------------
# (a review: a resume took a finished output of the case as done from its case hash alone: a spray.h5 with one
# data byte flipped was "up to date; nothing to do", the couple stage then stopped on its checksum (exit 3), and
# every resume did the same; a finished impact run's impact_runs/run_0000.h5 so damaged was "done already" on every
# resume, and the gathering of impact.h5 stopped on it.)  Now such a file is read whole before it counts as done:
# a warning naming it, the stage (or the run) computed again, and spray.h5, couple.h5 and impact.h5 those of an
# uninterrupted run, bit for bit (tests/pipeline_lib.sh same_h5), as docs/architecture.md promises after a resume.
. tests/pipeline_lib.sh
PIPE=tests/fixtures/pipeline_small.ini
PIPE_STAGES=spray,couple,impact

# flip_data_byte FILE DATASET: flips one byte of the stored values of DATASET (32 of its bytes found once in FILE:
# no filter changes the bytes of spraycoat's datasets, whose Fletcher32 checksum follows them); 1 when not found.
flip_data_byte() {
    h5dump -d "$2" -b LE -o "$T/raw.bin" "$1" >/dev/null 2>&1 || return 1
    offset=$(python3 -c '
import sys
raw = open(sys.argv[1], "rb").read()[8:40]
data = open(sys.argv[2], "rb").read()
at = data.find(raw) if len(raw) == 32 else -1
print(at + 12 if at >= 0 and data.find(raw, at + 1) < 0 else -1)' "$T/raw.bin" "$1")
    [ "${offset:--1}" -ge 0 ] || return 1
    python3 -c '
import sys
with open(sys.argv[1], "r+b") as f:
    f.seek(int(sys.argv[2]))
    b = f.read(1)
    f.seek(int(sys.argv[2]))
    f.write(bytes([b[0] ^ 0xFF]))' "$1" "$offset"
}

# damaged_resume TEST DIR FILE: resumes DIR, whose FILE is damaged; pass when it ends with status 0, a warning
# naming FILE as damaged, and the results of the uninterrupted run $PREF.
damaged_resume() {
    "$BIN" resume "$2" >"$T/$1.resume.log" 2>&1
    status=$?
    if [ "$status" -ne 0 ]; then
        fail "$1" "resume exited with status $status: $(grep 'up to date\|done already' "$T/$1.resume.log" | tail -n 1) $(tail -n 1 "$T/$1.resume.log")"
    elif ! grep 'warning' "$T/$1.resume.log" | grep "$3" | grep -q 'damaged'; then
        fail "$1" "no warning naming the damaged $3: $(grep -m 2 "$(basename "$3")" "$T/$1.resume.log" | tr '\n' ' ')"
    elif ! same_run_dir "$PREF" "$2" spray couple impact; then
        fail "$1" "not the uninterrupted run's results: $why"
    else
        note "$(grep -m 1 'damaged' "$T/$1.resume.log" | sed 's/^\[[^]]*\] //')"
        pass "$1"
    fi
}

PREF=$T/pipe_ref
if ! "$BIN" run "$PIPE" --stages "$PIPE_STAGES" -o "$PREF" >"$T/pipe_ref.log" 2>&1; then
    fail restart_damaged_output "the uninterrupted pipeline run failed: $(tail -n 1 "$T/pipe_ref.log")"
else
    # spray.h5 of a pipeline stopped right after its spray stage (the directory as the spray stage left it)
    test=restart_damaged_output_spray
    dir=$T/pipe_spray
    mkdir "$dir" && cp "$PREF/case.ini" "$PREF/stages" "$PREF/spray.h5" "$PREF/spray.xdmf" "$dir/"
    if ! flip_data_byte "$dir/spray.h5" /impacts/v_in || h5dump -d /impacts/v_in "$dir/spray.h5" >/dev/null 2>&1; then
        fail "$test" "could not damage /impacts/v_in of $dir/spray.h5 (its bytes not found once, or still readable)"
    else
        damaged_resume "$test" "$dir" "$dir/spray.h5"
    fi

    # a finished impact run: the pipeline stopped by a failed write of run 1's file (exit 3) after run 0's
    test=restart_damaged_output_impact_run
    dir=$T/pipe_run
    mkdir -p "$dir/impact_runs"
    blocked_write "$dir/impact_runs" run_0001.h5 "$T/$test.first.log" "$BIN" run "$PIPE" --stages "$PIPE_STAGES" -o "$dir"
    run0=$dir/impact_runs/run_0000.h5
    if [ "$blocked" -ne 3 ] || [ ! -f "$run0" ] || [ -e "$dir/impact.h5" ]; then
        fail "$test" "the blocked run (status $blocked) did not stop after run 0's file: $(tail -n 1 "$T/$test.first.log")"
    elif ! flip_data_byte "$run0" /series/ke || h5dump -d /series/ke "$run0" >/dev/null 2>&1; then
        fail "$test" "could not damage /series/ke of $run0 (its bytes not found once, or still readable)"
    else
        damaged_resume "$test" "$dir" "$run0"
    fi
fi

note "total $(($(date +%s) - start)) s"
[ "$failures" -eq 0 ]
