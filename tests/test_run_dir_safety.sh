#!/bin/sh
# The run directory survives what adversarial use did to it (issue 24, hardening items 3, 4, 7, 8 and 11):
#  - temporaries never follow a symbolic link planted at NAME.tmp (core/atomic.h);
#  - a case that passes the quick checks but cannot be set up (a cylinder overlapping a sphere) fails before
#    anything in an existing run directory is written;
#  - SIGTERM / SIGINT stop the render and couple stages with 143 / 130;
#  - RUN_DIR/stages keeps unfinished work: a later single-stage command adds to it instead of replacing it, an
#    empty stage list is refused;
#  - a second process takes the run directory's lock before it reads any checkpoint there.
#  - when another case fails writing spray.h5 (exit 3), the first case's results stay whole: up to date, with their
#    own spray.xdmf.
# Prints "PASS name" / "FAIL name: why".  Run from the repository root.
set -u
bin=${SPRAYCOAT_BIN:-build/spraycoat}
base=tests/bad_cases/valid_base.ini
small=tests/fixtures/pipeline_small.ini

. tests/wait_lib.sh # blocked_write
T=$(mktemp -d) || { echo "FAIL safety_setup: mktemp -d failed"; exit 1; }
trap 'rm -rf "$T"' EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

report() { # NAME: PASS when $why is empty
    if [ -z "$why" ]; then echo "PASS $1"; else echo "FAIL $1: $why"; fi
}

# ---- 3: planted links at every temporary name of the spray stage and the run directory -------------------------
R=$T/links
mkdir -p "$R"
printf 'precious\n' >"$T/victim"
for name in case.ini.tmp stages.tmp spray.h5.tmp spray.xdmf.tmp; do
    ln -s "$T/victim" "$R/$name"
done
why=""
"$bin" spray "$base" -o "$R" >"$T/links.out" 2>&1 || why="spray exited $? ($(tail -n 1 "$T/links.out"))"
[ "$(cat "$T/victim")" = "precious" ] || why="${why:+$why; }the link's target was overwritten"
for name in case.ini stages spray.h5 spray.xdmf; do
    [ -f "$R/$name" ] && [ ! -L "$R/$name" ] || why="${why:+$why; }$name is not a regular file"
done
report temporaries_never_follow_links

# ---- 4: a case that fails when its points are seeded leaves a finished run directory alone ----------------------
R=$T/finished
"$bin" spray "$base" -o "$R" >/dev/null 2>&1
cp "$R/case.ini" "$T/case.before"
cp "$R/stages" "$T/stages.before"
cat >"$T/overlap.csv" <<'EOF'
shape,x,y,z,vx,vy,vz,d,h,material
cylinder,0,0,9e-6,0,0,-810,8e-6,8e-6,aluminium
sphere,0,0,12e-6,0,0,-810,8e-6,0,aluminium
EOF
sed 's/^bodies = .*/bodies = overlap.csv/' tests/bad_cases/impact_bodies_overlap.ini >"$T/overlap.ini"
"$bin" impact "$T/overlap.ini" -o "$R" >"$T/overlap.out" 2>&1
status=$?
why=""
[ "$status" -eq 2 ] || why="exit status $status, not 2 ($(tail -n 1 "$T/overlap.out"))"
cmp -s "$R/case.ini" "$T/case.before" || why="${why:+$why; }case.ini of the finished run was replaced"
cmp -s "$R/stages" "$T/stages.before" || why="${why:+$why; }stages of the finished run was replaced"
"$bin" check "$T/overlap.ini" >/dev/null 2>&1
[ $? -eq 2 ] || why="${why:+$why; }check passes a case whose bodies overlap"
report set_up_failure_before_run_dir

# ---- 11: the lock comes before any checkpoint is read -----------------------------------------------------------
R=$T/locked
"$bin" spray "$base" -o "$R" >/dev/null 2>&1
rm -f "$R/spray.h5"
mkdir -p "$R/checkpoints"
printf 'not a checkpoint' >"$R/checkpoints/spray_00000010.h5"
why=""
if command -v flock >/dev/null 2>&1; then
    flock -n "$R" sh -c "'$bin' spray '$base' -o '$R' >'$T/locked.out' 2>&1; echo \$? >'$T/locked.status'"
    status=$(cat "$T/locked.status")
    [ "$status" -eq 3 ] || why="exit status $status, not 3"
    grep -q 'in use' "$T/locked.out" || why="${why:+$why; }no 'in use' message"
    if grep -q -i 'damaged\|cannot read checkpoint' "$T/locked.out"; then
        why="${why:+$why; }read a checkpoint before taking the lock: $(grep -i -m 1 'damaged\|cannot read' "$T/locked.out")"
    fi
else
    why="flock(1) is not installed (util-linux)"
fi
report lock_before_checkpoints

# ---- 8: RUN_DIR/stages keeps the unfinished stages --------------------------------------------------------------
R=$T/stages
"$bin" run "$small" -o "$R" --stages spray,couple >/dev/null 2>&1
# what a pipeline stopped in its impact stage leaves behind
printf 'run:spray,couple,impact,render\n' >"$R/stages"
"$bin" spray "$small" -o "$R" >/dev/null 2>&1
why=""
grep -q 'impact' "$R/stages" || why="a later spray command dropped the unfinished impact stage: $(cat "$R/stages")"
grep -q '^run:' "$R/stages" || why="${why:+$why; }the record is no longer a pipeline's: $(cat "$R/stages")"
report later_command_keeps_unfinished_stages

why=""
"$bin" run "$small" -o "$T/empty" --stages "" >"$T/empty.out" 2>&1
status=$?
[ "$status" -eq 2 ] || why="run --stages \"\" exited $status, not 2"
R2=$T/emptyrecord
"$bin" spray "$base" -o "$R2" >/dev/null 2>&1
printf 'run:\n' >"$R2/stages"
"$bin" resume "$R2" >"$T/emptyrecord.out" 2>&1
status=$?
[ "$status" -eq 2 ] || why="${why:+$why; }resume of a stages file 'run:' exited $status, not 2"
report empty_stage_lists_refused

# ---- 7: signals stop render and couple ----------------------------------------------------------------------------
# signal_stage NAME MARK SIGNAL STATUS COMMAND...: start COMMAND; once its log shows MARK (the stage has begun its
# long part), stop it, send SIGNAL, let it go on (so the signal arrives in the middle, however fast the machine)
# and expect exit STATUS
signal_stage() {
    _name=$1 _mark=$2 _signal=$3 _want=$4
    shift 4
    "$@" >"$T/$_name.out" 2>&1 &
    _pid=$!
    _waited=0
    until grep -q "$_mark" "$T/$_name.out" 2>/dev/null || [ "$_waited" -ge 6000 ]; do
        sleep 0.01
        _waited=$((_waited + 1))
    done
    kill -STOP "$_pid" 2>/dev/null
    kill "-$_signal" "$_pid" 2>/dev/null
    kill -CONT "$_pid" 2>/dev/null
    wait "$_pid"
    _status=$?
    why=""
    [ "$_status" -eq "$_want" ] || why="exit status $_status after SIG$_signal, not $_want ($(tail -n 1 "$T/$_name.out"))"
}
R=$T/stages
"$bin" impact "$small" -o "$R" >/dev/null 2>&1
signal_stage render "spray figures from" TERM 143 "$bin" render "$small" -o "$R"
report render_stops_at_sigterm

# many seeds at tight tolerances: the couple stage's flights take a few seconds
sed 's/^runs = 4$/runs = 1400\nrtol = 1e-12\natol = 1e-14/' \
    "$small" >"$T/many_seeds.ini"
"$bin" spray "$T/many_seeds.ini" -o "$T/seeds" >/dev/null 2>&1
signal_stage couple "wall region" INT 130 "$bin" couple "$T/many_seeds.ini" -o "$T/seeds"
[ -e "$T/seeds/couple.h5" ] && why="${why:+$why; }couple.h5 written by an interrupted stage"
grep -q 'couple: done' "$T/couple.out" && why="${why:+$why; }the interrupted stage's log says done"
report couple_stops_at_sigint

# ---- a failed write damages nothing and leaves no stale output trusted: another case's spray fails writing spray.h5
# in a finished run directory (the temporary's name blocked by a folder: exit 3); the first case's results stay whole,
# up to date with their own spray.xdmf (app.h stage_write_outputs: the index is published after spray.h5 is written)
R=$T/mixed
"$bin" spray "$base" -o "$R" >/dev/null 2>&1
cp "$R/spray.xdmf" "$T/xdmf.before"
sed 's/^seed = .*/seed = 8/' "$base" >"$T/other_seed.ini"
blocked_write "$R" spray.h5 "$T/mixed1.out" "$bin" spray "$T/other_seed.ini" -o "$R"
"$bin" spray "$base" -o "$R" >"$T/mixed2.out" 2>&1
again=$?
why=""
[ "$blocked" -eq 3 ] || why="the blocked write exited $blocked, not 3 ($(tail -n 1 "$T/mixed1.out"))"
[ "$again" -eq 0 ] || why="${why:+$why; }the first case again exited $again ($(tail -n 1 "$T/mixed2.out"))"
grep -q "spray.h5 is up to date" "$T/mixed2.out" || why="${why:+$why; }the first case's results were damaged (not up to date)"
cmp -s "$T/xdmf.before" "$R/spray.xdmf" || why="${why:+$why; }spray.xdmf is not the first case's"
report failed_write_leaves_nothing_stale

# a run directory on a read-only file system: exit 3 with the reason of the write that failed (it said "cannot
# remove the stale temporary file case.ini.tmp" of a file that was not there: a read-only file system refuses the
# unlink of a missing file).  Needs a tmpfs mounted read-only; where mounting is not allowed the check is not run.
mkdir -p "$T/ro"
if mount -t tmpfs tmpfs "$T/ro" 2>/dev/null; then
    mkdir -p "$T/ro/run"
    if mount -o remount,ro "$T/ro" 2>/dev/null; then
        "$bin" spray "$base" -o "$T/ro/run" >"$T/ro.out" 2>&1
        status=$?
        why=""
        [ $status -eq 3 ] || why="exit $status, not 3"
        grep -q 'spraycoat: cannot create .*/ro/run/case.ini.tmp: Read-only file system' "$T/ro.out" ||
            why="${why:+$why; }the message: $(tail -n 1 "$T/ro.out")"
        report read_only_run_dir_says_why
    else
        echo "  read-only file system: cannot remount read-only here; not run"
    fi
    umount "$T/ro" 2>/dev/null
else
    echo "  read-only file system: mounting a tmpfs is not allowed here; not run"
fi
