#!/bin/sh
# Several processes (`make MPI=1`; `make test` builds build-mpi/ and sets SPRAYCOAT_MPI_BIN): `mpirun -np 2`
# gives the same files as one process for
#   the pipeline (spray and couple on rank 0, the four impact runs shared out),
#   a pipeline stopped by SIGTERM during the impact runs and resumed under mpirun,
#   a vcrit search with method = logistic (the two diameters shared out, the bisections, sweeps and fits
#   replayed by rank 0),
#   a bonding calibration (the runs shared out, the fit by rank 0, the ranks' records kept: 8 runs together),
#   a calibration on v_crit (method = vcrit: each search's runs shared out, every rank follows the iteration),
#   a sweep (the spray runs shared out, the map by rank 0),
#   the pipeline's impact runs on the GPU step emulated with two devices, one a rank (the MPI build's cuda-emu).
set -u
BIN=${SPRAYCOAT_BIN:-build/spraycoat}
MPI_BIN=${SPRAYCOAT_MPI_BIN:-}
CASE0=tests/fixtures/pipeline_small.ini
if [ -z "$MPI_BIN" ] || [ ! -x "$MPI_BIN" ] || ! command -v mpirun >/dev/null 2>&1; then
    echo "mpi: no MPI build (SPRAYCOAT_MPI_BIN unset or mpirun missing; \`make test\` builds build-mpi/): not run"
    exit 0
fi
T=$(mktemp -d)
bg=""
cleanup() {
    [ -n "$bg" ] && kill -9 "$bg" 2>/dev/null
    rm -rf "$T"
}
trap cleanup EXIT
trap 'exit 1' HUP INT TERM
. tests/pipeline_lib.sh
. tests/wait_lib.sh
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
MPIRUN="mpirun -np 2 --oversubscribe"
pass() { echo "PASS $1"; }
fail() { echo "FAIL $1: $2"; }
STAGES=spray,couple,impact

# ---- 1. the pipeline: one process, then two ----------------------------------------------------------------
"$BIN" run "$CASE0" --stages "$STAGES" -o "$T/one" >"$T/one.log" 2>&1
one=$?
$MPIRUN "$MPI_BIN" run "$CASE0" --stages "$STAGES" -o "$T/two" >"$T/two.log" 2>&1
two=$?
if [ "$one" -eq 0 ] && [ "$two" -eq 0 ] && grep -q '\[rank 1\] info: impact_r' "$T/two.log" &&
    same_run_dir "$T/one" "$T/two" spray couple impact; then
    pass mpi_pipeline_same_as_one_process
else
    fail mpi_pipeline_same_as_one_process "exit $one / $two; $why $(grep -c '\[rank 1\]' "$T/two.log") rank-1 lines"
fi

# ---- 2. SIGTERM to mpirun during the impact runs, then resume under mpirun -----------------------------------
# impact runs of 64 ns (16 times the fixture's, about 2 s a run here), so that the signal comes while they run (at
# 16 ns the stage ended on a fast idle machine before mpirun had forwarded it)
sed 's/^t_end = 4e-9/t_end = 64e-9/' "$CASE0" >"$T/long.ini"
"$BIN" run "$T/long.ini" --stages "$STAGES" -o "$T/long_one" >"$T/long_one.log" 2>&1
$MPIRUN "$MPI_BIN" run "$T/long.ini" --stages "$STAGES" -o "$T/term" >"$T/term.log" 2>&1 &
bg=$!
wait_until "$bg" 60 exists "$T/term/checkpoints/impact_r*.h5"
kill -TERM "$bg" 2>/dev/null
wait "$bg" 2>/dev/null
term=$?
bg=""
# mpirun forwards SIGTERM to the ranks (which write a checkpoint and exit 143) and exits non-zero itself
stopped=0
[ "$term" -ne 0 ] && [ ! -e "$T/term/impact.h5" ] && ls "$T"/term/checkpoints/impact_r*.h5 >/dev/null 2>&1 && stopped=1
$MPIRUN "$MPI_BIN" resume "$T/term" >"$T/resume.log" 2>&1
resumed=$?
if [ "$stopped" -eq 1 ] && [ "$resumed" -eq 0 ] && same_run_dir "$T/long_one" "$T/term" spray couple impact; then
    pass mpi_resume_same_as_one_process
else
    fail mpi_resume_same_as_one_process "mpirun exit $term, stopped mid-stage $stopped, resume exit $resumed; $why $(grep 'spraycoat' "$T/resume.log" | tail -n 1)"
fi

# ---- 3. vcrit with the diameters shared out ------------------------------------------------------------------
cat >"$T/vcrit.ini" <<EOF
[run]
threads = 1

[impact]
grid = 2e-6
spacing = 1e-6
substrate_diameter = 20e-6
substrate_height = 6e-6
t_end = 10e-9
; the energy model bonds within 10 ns (as in tests/test_vcrit.sh)
bonding = energy
; verdicts that settle within 10 ns (as tests/test_vcrit.sh): a short window, any drift, v_rest over all points
settle_window = 2e-9
settle_vcom = 1e4
settle_pbcp = 1
vrest_filter = 1e4

[material.aluminium]

[vcrit]
diameters = 10e-6,8e-6
v_low = 200
v_high = 1200
tolerance = 200
; the bisection, its sweep and the logistic fit, all replayed by rank 0 from both ranks' records
method = logistic
sweep_step = 50
sweep_count = 2
EOF
"$BIN" vcrit "$T/vcrit.ini" -o "$T/vcrit_one" >"$T/vcrit_one.log" 2>&1
one=$?
$MPIRUN "$MPI_BIN" vcrit "$T/vcrit.ini" -o "$T/vcrit_two" >"$T/vcrit_two.log" 2>&1
two=$?
# the records are kept: rank 0's and rank 1's files hold together exactly the runs that vcrit.csv counts
why=""
recorded=$(cat "$T"/vcrit_two/vcrit_runs*.csv 2>/dev/null | grep -c '^[0-9]')
counted=$(awk -F, 'NR > 1 && !/^#/ { n += $NF } END { print n + 0 }' "$T/vcrit_two/vcrit.csv" 2>/dev/null)
[ -s "$T/vcrit_two/vcrit_runs_rank1.csv" ] && [ "$recorded" -eq "${counted:-0}" ] ||
    why="the ranks' records hold $recorded runs, vcrit.csv counts $counted;"
if [ "$one" -eq 0 ] && [ "$two" -eq 0 ] && cmp -s "$T/vcrit_one/vcrit.csv" "$T/vcrit_two/vcrit.csv" &&
    same_h5 "$T/vcrit_one/vcrit.h5" "$T/vcrit_two/vcrit.h5" && grep -q '\[rank 1\] info: vcrit' "$T/vcrit_two.log" &&
    [ -z "$why" ]; then
    pass mpi_vcrit_same_as_one_process
else
    fail mpi_vcrit_same_as_one_process "exit $one / $two; $why $(diff "$T/vcrit_one/vcrit.csv" "$T/vcrit_two/vcrit.csv" | head -n 4 | tr '\n' ' ')"
fi

# ---- a bonding calibration (its eight runs shared out, the fit by rank 0) ----------------------------------------
cat >"$T/calibrate.ini" <<EOF
[run]
threads = 1

[impact]
grid = 2e-6
spacing = 1e-6
substrate_height = 6e-6
t_end = 4e-9
bonding = energy

[material.aluminium]

[calibrate]
diameters = 8e-6,10e-6
velocities = 900,850
substrate_diameters = 20e-6,24e-6
Gc_min = 100
Gc_max = 3000
Gc_count = 2
Gc_rate_min = 1e10
Gc_rate_max = 5e11
Gc_rate_count = 2
EOF
"$BIN" calibrate "$T/calibrate.ini" -o "$T/calibrate_one" >"$T/calibrate_one.log" 2>&1
one=$?
$MPIRUN "$MPI_BIN" calibrate "$T/calibrate.ini" -o "$T/calibrate_two" >"$T/calibrate_two.log" 2>&1
two=$?
if [ "$one" -eq 0 ] && [ "$two" -eq 0 ] && cmp -s "$T/calibrate_one/calibrate.csv" "$T/calibrate_two/calibrate.csv" &&
    cmp -s "$T/calibrate_one/calibrate_outcomes.csv" "$T/calibrate_two/calibrate_outcomes.csv" &&
    grep -q '\[rank 1\] info: calibrate' "$T/calibrate_two.log" &&
    [ "$(cat "$T"/calibrate_two/calibrate_runs*.csv 2>/dev/null | grep -c '^[0-9]')" -eq 8 ]; then
    pass mpi_calibrate_same_as_one_process
else
    fail mpi_calibrate_same_as_one_process "exit $one / $two; $(diff "$T/calibrate_one/calibrate_outcomes.csv" \
        "$T/calibrate_two/calibrate_outcomes.csv" | head -n 4 | tr '\n' ' ')"
fi

# ---- a calibration on v_crit (each search's runs shared out, every rank follows the iteration) -------------------
sed -e '/^\[vcrit\]/,$d' "$T/vcrit.ini" >"$T/calibrate_vcrit.ini"
cat >>"$T/calibrate_vcrit.ini" <<EOF
[vcrit]
v_low = 200
v_high = 1200
tolerance = 50

[calibrate]
method = vcrit
diameters = 10e-6,8e-6
velocities = 850,800
Gc_min = 300
Gc_max = 1500
fit_tolerance = 25
EOF
"$BIN" calibrate "$T/calibrate_vcrit.ini" -o "$T/calibrate_vcrit_one" >"$T/calibrate_vcrit_one.log" 2>&1
one=$?
$MPIRUN "$MPI_BIN" calibrate "$T/calibrate_vcrit.ini" -o "$T/calibrate_vcrit_two" >"$T/calibrate_vcrit_two.log" 2>&1
two=$?
if [ "$one" -eq 0 ] && [ "$two" -eq 0 ] && grep -q ',1$' "$T/calibrate_vcrit_one/calibrate.csv" &&
    cmp -s "$T/calibrate_vcrit_one/calibrate.csv" "$T/calibrate_vcrit_two/calibrate.csv" &&
    cmp -s "$T/calibrate_vcrit_one/calibrate_vcrit.csv" "$T/calibrate_vcrit_two/calibrate_vcrit.csv" &&
    grep -q '\[rank 1\] info: vcrit' "$T/calibrate_vcrit_two.log"; then
    pass mpi_calibrate_vcrit_same_as_one_process
else
    fail mpi_calibrate_vcrit_same_as_one_process "exit $one / $two; $(diff "$T/calibrate_vcrit_one/calibrate_vcrit.csv" \
        "$T/calibrate_vcrit_two/calibrate_vcrit.csv" 2>&1 | head -n 4 | tr '\n' ' ') $(tail -n 2 "$T/calibrate_vcrit_two.log")"
fi

# ---- a sweep (its four spray runs shared out, the map by rank 0) ----------------------------------------------
sed -e 's/^max_injected = 1500/max_injected = 200/' -e 's/^t_end = 8e-4/t_end = 3e-4/' "$CASE0" >"$T/sweep.ini"
printf '[sweep]\nx_key = jet.C1\nx_values = 250,350\ny_key = spray.release_speed_max\ny_values = 700,900\n' \
    >>"$T/sweep.ini"
"$BIN" sweep "$T/sweep.ini" -o "$T/sweep_one" >"$T/sweep_one.log" 2>&1
one=$?
$MPIRUN "$MPI_BIN" sweep "$T/sweep.ini" -o "$T/sweep_two" >"$T/sweep_two.log" 2>&1
two=$?
same_runs=1
for run in x0_y0 x1_y0 x0_y1 x1_y1; do
    same_h5 "$T/sweep_one/runs/$run/spray.h5" "$T/sweep_two/runs/$run/spray.h5" || same_runs=0
done
if [ "$one" -eq 0 ] && [ "$two" -eq 0 ] && [ $same_runs -eq 1 ] &&
    same_h5 "$T/sweep_one/sweep.h5" "$T/sweep_two/sweep.h5" && grep -q '\[rank 1\] info: sweep: run' "$T/sweep_two.log"; then
    pass mpi_sweep_same_as_one_process
else
    fail mpi_sweep_same_as_one_process "exit $one / $two; same runs $same_runs; $why $(grep -c '\[rank 1\] info: sweep: run' "$T/sweep_two.log") runs on rank 1"
fi

# ---- one rank per GPU (issue 25: ensembles of impact runs over several GPUs) -----------------------------------
# The GPU step emulated on the CPU (BUILD/cuda-emu/spraycoat of the MPI build, docs/gpu.md "The emulation") with two
# devices (SPRAYCOAT_CUDA_EMU_DEVICES=2): under mpirun each rank takes the device of its local rank
# (OMPI_COMM_WORLD_LOCAL_RANK), rank 0 device 0 and rank 1 device 1, and the pipeline's impact runs shared out over
# them give the files of one process on one device, bit for bit (the step's bits do not depend on the device).
why=""
EMU_ONE="$(dirname "$BIN")/cuda-emu/spraycoat" EMU_MPI="$(dirname "$MPI_BIN")/cuda-emu/spraycoat"
if [ -x "$EMU_ONE" ] && [ -x "$EMU_MPI" ]; then
    sed -e 's/^t_end = 4e-9/t_end = 1e-9/' -e 's/^snapshot_every = 2e-9/snapshot_every = 1e-9/' "$CASE0" >"$T/gpu.ini"
    SPRAYCOAT_CUDA_EMU_DEVICES=2 "$EMU_ONE" run "$T/gpu.ini" --stages "$STAGES" --device gpu -o "$T/gpu_one" \
        >"$T/gpu_one.log" 2>&1
    one=$?
    SPRAYCOAT_CUDA_EMU_DEVICES=2 $MPIRUN "$EMU_MPI" run "$T/gpu.ini" --stages "$STAGES" --device gpu \
        -o "$T/gpu_two" >"$T/gpu_two.log" 2>&1
    two=$?
    on_device() { grep -c "$1 info: impact: the step runs on GPU $2 of 2: CUDA emulated" "$T/gpu_two.log"; }
    rank0=$(grep -v '\[rank [1-9]' "$T/gpu_two.log" | grep -c "info: impact: the step runs on GPU 0 of 2: CUDA emulated")
    rank1=$(on_device '\[rank 1\]' 1)
    if [ "$one" -eq 0 ] && [ "$two" -eq 0 ] && [ "$rank0" -ge 1 ] && [ "$rank1" -ge 1 ] &&
        [ "$(on_device '\[rank 1\]' 0)" -eq 0 ] && same_run_dir "$T/gpu_one" "$T/gpu_two" spray couple impact; then
        pass "mpi_one_rank_per_gpu (emulated: $rank0 impact runs on device 0, $rank1 on device 1)"
    else
        fail mpi_one_rank_per_gpu "exit $one / $two; runs on device 0 (rank 0) $rank0, on device 1 (rank 1) $rank1; $why $(tail -n 2 "$T/gpu_two.log")"
    fi
elif "$BIN" --version | grep -q "^  gpu  *CUDA step (nvcc"; then
    echo "mpi_one_rank_per_gpu: not run (a CUDA=1 build has no emulation; scripts/gpu_check.sh runs on devices)"
else
    fail mpi_one_rank_per_gpu "no $EMU_ONE or $EMU_MPI (make test builds both)"
fi
