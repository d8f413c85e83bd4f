#!/bin/sh
# The GPU step's own code (mpm/cuda/step.cu) against the CPU step, without a GPU: BUILD/cuda-emu/spraycoat runs
# the device's kernels on the CPU through tests/cuda_emu (docs/gpu.md, "The emulation"), and each case here runs
# there with --device cpu and --device gpu; the last snapshot's fields and every series row's diagnostics must agree
# within 1e-7 of their scale.  The step shares the per-point physics (stress_point.h, bonding_law.h), the nodal
# update with its contact (contact_node.h) and the boundary forces (boundary_point.h) with the CPU, and ports the
# rest (the transfers of grid.c and solver.c, conduction.c, the diagnostics' grid velocity): a change made to one
# side and not to the other shows here as a difference of the order of the field, where the two orders of summation
# (the CPU's scatter, the device's gather) leave 1e-11 of the speed after 100 steps.  The cases cover the step's
# paths: two bodies with the energy model (contact_scheme = once, its two corrections, bonds), a quarter model with
# heat conduction and the strain model (mirror nodes, the heat kernel's images), two particles on the substrate
# (three bodies at a node: the sweeps), the thesis scheme with friction, the rigid wall.  What the emulation cannot
# check (a race that both orders of the threads hide, the device's memory, timing): scripts/gpu_check.sh on a device.
# Two cases run again with the threads in reverse order (the same bits, or the threads race), and with the points
# reordered in memory every step or never (the same bits).  Last, a checkpoint written on one device is resumed on
# the other, both ways.
set -u
. tests/wait_lib.sh
BIN=${SPRAYCOAT_BIN:-build/spraycoat}
EMU="$(dirname "$BIN")/cuda-emu/spraycoat"
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
failed=0
# the cases' length: 73 steps, 110 for the resume (a difference in any path shows from the first steps of contact);
# under the sanitizers (make asan), where the emulated step runs ten times slower, 30 and 73: the same paths, each
# checked for memory errors
t_case=1e-9 t_resume=1.5e-9
[ "${SPRAYCOAT_SANITIZED:-0}" = 1 ] && t_case=0.4e-9 t_resume=1e-9

if [ ! -x "$EMU" ]; then
    echo "FAIL gpu_emulated: $EMU is missing (make builds it with the other programs)"
    exit 1
fi
"$EMU" --version | grep -q "^  gpu  *CUDA step emulated" && echo "PASS gpu_emulated_version" ||
    { echo "FAIL gpu_emulated_version: $EMU --version does not name the emulated step"; failed=1; }

# case NAME T_END [lines]: the small impact of scripts/gpu_check.sh (8 um at 810 m/s, 1.0/0.5 um), to T_END
impact_case() {
    name=$1 t_end=$2
    shift 2
    {
        printf '[run]\ncheckpoint_wall = 0\n[impact]\ngrid = 1e-6\nspacing = 0.5e-6\nt_end = %s\n' "$t_end"
        printf 'snapshot_every = %s\nseries_every = %s\n' "$t_end" "$(awk -v t="$t_end" 'BEGIN { print t / 3 }')"
        printf 'diameter = 8e-6\nvelocity = 810\nsubstrate_diameter = 20e-6\nsubstrate_height = 8e-6\n'
        for line in "$@"; do printf '%s\n' "$line"; done
        printf '[material.aluminium]\n'
    } > "$T/$name.ini"
}

# dataset FILE PATH: the values, one a line
dataset() { h5dump -d "$2" -y -w 0 -m %.17g "$1" 2> /dev/null | awk '/DATA \{/ { on = 1; next } /\}/ { on = 0 } on' |
    tr ',' '\n' | sed -n 's/^ *\([-0-9.eEinfa+][-0-9.eEinfa+]*\) *$/\1/p'; }

# compare_values NAME LABEL FILE_A FILE_B SCALE: the values of the two files (one a line) pairwise, max |a - b| <=
# 1e-7 SCALE (SCALE "max": the largest |value| of A); a value missing on one side fails, NaN only where both are
compare_values() {
    result=$(paste "$3" "$4" | awk -v scale="$5" '
        { n++; if (NF < 2) bad = 1
          if ($1 ~ /nan/ || $2 ~ /nan/) { if (!($1 ~ /nan/ && $2 ~ /nan/)) bad = 1; next }
          d = $1 - $2; if (d < 0) d = -d; if (d > dmax) dmax = d
          a = $1 < 0 ? -$1 : $1; if (a > amax) amax = a }
        END { s = scale == "max" ? amax : scale; ok = n > 0 && !bad && dmax <= 1e-7 * s
              printf "%s %d values, max |cpu - gpu| %.3g, bound %.3g\n", ok ? "PASS" : "FAIL", n, dmax, 1e-7 * s }')
    case $result in
        PASS*) echo "PASS gpu_emulated_$1_$2 (${result#PASS })" ;;
        *) echo "FAIL gpu_emulated_$1_$2: ${result#FAIL }"; failed=1 ;;
    esac
}

# compare_runs NAME CPU_DIR OTHER_DIR FIELD SCALE: the last snapshot's FIELD of the two runs (compare_values)
compare_runs() {
    snap=$(h5ls "$2/impact.h5/snapshots" 2> /dev/null | awk '$1 ~ /^[0-9]+$/ { print $1 }' | sort | tail -1)
    dataset "$2/impact.h5" "/snapshots/$snap/$4" > "$T/a"
    dataset "$3/impact.h5" "/snapshots/$snap/$4" > "$T/b"
    compare_values "$1" "$4" "$T/a" "$T/b" "$5"
}

# compare_series NAME CPU_DIR OTHER_DIR: the diagnostics of every series row (docs/physics.md "Diagnostics": the
# energies, the verdict's v_com and v_rest, PBCP, the interface counts), each within 1e-7 of its largest value
compare_series() {
    for field in ke internal_energy plastic_work energy_absorbed v_com v_rest pbcp contacted_points interface_nodes \
        bonded_nodes; do
        dataset "$2/impact.h5" "/series/$field" > "$T/a"
        dataset "$3/impact.h5" "/series/$field" > "$T/b"
        compare_values "$1" "series_$field" "$T/a" "$T/b" max
    done
}

# compare_fields NAME CPU_DIR OTHER_DIR FIELD...: each FIELD at its scale
compare_fields() {
    name=$1 a=$2 b=$3
    shift 3
    for field in "$@"; do
        case $field in
            x) compare_runs "$name" "$a" "$b" x 1e-6 ;;
            v) compare_runs "$name" "$a" "$b" v 810 ;;
            T) compare_runs "$name" "$a" "$b" T 300 ;;
            eps_p | D_bond) compare_runs "$name" "$a" "$b" "$field" 1 ;;
            *) compare_runs "$name" "$a" "$b" "$field" max ;;
        esac
    done
}

# run NAME FIELD...: the case on both devices, then the fields compared
run() {
    name=$1
    shift
    for device in cpu gpu; do
        if ! "$EMU" impact "$T/$name.ini" -o "$T/$name.$device" --device "$device" --threads 1 \
            > "$T/$name.$device.log" 2>&1; then
            echo "FAIL gpu_emulated_$name: the $device run failed: $(tail -c 400 "$T/$name.$device.log")"
            failed=1
            return
        fi
    done
    grep -q "CUDA emulated on the CPU" "$T/$name.gpu.log" ||
        { echo "FAIL gpu_emulated_$name: the gpu run's log does not name the emulated device"; failed=1; }
    compare_fields "$name" "$T/$name.cpu" "$T/$name.gpu" "$@"
    compare_series "$name" "$T/$name.cpu" "$T/$name.gpu"
}

impact_case two_bodies "$t_case" "bonding = energy"
run two_bodies x v T pressure von_mises eps_p D_bond

impact_case quarter_conduction "$t_case" "bonding = strain" "symmetry = quarter" "conduction = on"
run quarter_conduction x v T pressure eps_p D_bond

# two 4 um particles side by side, touching the substrate and each other's neighbourhood: nodes of three bodies
printf 'shape,x,y,z,vx,vy,vz,d,h,material\nsphere,-2.2e-6,0,2.2e-6,0,0,-700,4e-6,0,aluminium\n' > "$T/pair.csv"
printf 'sphere,2.2e-6,0,2.2e-6,0,0,-760,4e-6,0,aluminium\n' >> "$T/pair.csv"
impact_case three_bodies "$t_case" "bonding = energy" "substrate_material = aluminium" "bodies = pair.csv"
sed -i '/^diameter = \|^velocity = /d' "$T/three_bodies.ini"
run three_bodies x v pressure eps_p D_bond

impact_case thesis_friction "$t_case" "bonding = strain" "contact_scheme = thesis" "contact = friction"
run thesis_friction x v pressure eps_p

impact_case rigid_wall "$t_case" "substrate = rigid"
run rigid_wall x v pressure eps_p

# same_bits NAME LABEL SETTING WHAT CAUSE: the case's gpu run again with the environment's SETTING (VAR=VALUE);
# every snapshot and series row must hold the same values (h5diff -d 0), else CAUSE changes the results.
same_bits() {
    name=$1 label=$2 setting=$3 what=$4 cause=$5 dir="$T/$1.gpu_$2"
    if ! env "$setting" "$EMU" impact "$T/$name.ini" -o "$dir" --device gpu --threads 1 > "$dir.log" 2>&1; then
        echo "FAIL gpu_emulated_${name}_$label: the run failed: $(tail -c 400 "$dir.log")"
        failed=1
        return
    fi
    for group in snapshots series; do
        h5diff -r -d 0 "$T/$name.gpu/impact.h5" "$dir/impact.h5" "/$group" "/$group" > "$T/diff" 2>&1
        case $? in
            0) echo "PASS gpu_emulated_${name}_${label}_$group (the same values $what)" ;;
            1) echo "FAIL gpu_emulated_${name}_${label}_$group: $cause changes the results:" \
                "$(awk '/^dataset:/ { name = $2 } /differences found/ && $1 > 0 { print name, $1 }' "$T/diff" |
                    head -4 | tr '\n' ' ')"
                failed=1 ;;
            *) echo "FAIL gpu_emulated_${name}_${label}_$group: h5diff could not compare the runs: $(head -c 300 "$T/diff")"
                failed=1 ;;
        esac
    done
}

# The step's threads do not race: each writes only its own entries, and reads in a launch only what earlier launches
# wrote, so its bits cannot depend on the order in which a device runs them.  The emulation runs blocks, threads and
# the phases between barriers first to last; SPRAYCOAT_CUDA_EMU_ORDER=reverse runs them last to first, and a race
# (a thread reading an entry that another writes in the same launch) then changes the results.  The cases of the
# most kernels, run again in reverse.
for name in quarter_conduction three_bodies; do
    same_bits "$name" reversed SPRAYCOAT_CUDA_EMU_ORDER=reverse "with blocks and threads last to first" \
        "the threads' order (a race)"
done

# The points' storage order changes no bit (mpm/cuda/step.cu: every sum over points in id order): the runs above
# reorder the points by cell every 16 steps; the three-body case again with the points reordered every step, the
# quarter with conduction with the points never reordered.
same_bits three_bodies reorder_every_step SPRAYCOAT_GPU_REORDER_EVERY=1 "with the points reordered every step" \
    "the points' storage order"
same_bits quarter_conduction reorder_never SPRAYCOAT_GPU_REORDER_EVERY=0 "with the points never reordered" \
    "the points' storage order"

# A checkpoint of one device resumed on the other (docs/gpu.md "Use"): the impact on FROM, stopped by SIGTERM
# once it has written its first checkpoint (every 20 steps; exit 143, a checkpoint of the step it stopped at),
# resumed with `spraycoat resume --device TO`, ends as the uninterrupted CPU run.
impact_case resume "$t_resume" "bonding = energy"
sed -i 's/^checkpoint_wall = 0$/checkpoint_wall = 0\ncheckpoint_steps = 20/; s/^series_every = .*/series_every = 5e-10/' \
    "$T/resume.ini"
resume_across() {
    from=$1 to=$2 dir="$T/resume.$1_$2"
    "$EMU" impact "$T/resume.ini" -o "$dir" --device "$from" --threads 1 > "$dir.log" 2>&1 &
    pid=$!
    wait_until "$pid" 60 exists "$dir/checkpoints/*.h5"
    kill -TERM "$pid" 2> /dev/null
    wait "$pid"
    status=$?
    if [ "$status" -ne 143 ]; then
        echo "FAIL gpu_emulated_resume_$1_$2: the $from run ended with status $status, not 143 (stopped after a" \
            "checkpoint): $(tail -c 300 "$dir.log")"
        failed=1
        return
    fi
    if ! "$EMU" resume "$dir" --device "$to" --threads 1 > "$dir.resume.log" 2>&1 ||
        ! grep -q "resuming from .*checkpoints" "$dir.resume.log"; then
        echo "FAIL gpu_emulated_resume_$1_$2: the resume on $to: $(tail -c 300 "$dir.resume.log")"
        failed=1
        return
    fi
    [ "$to" = cpu ] || grep -q "CUDA emulated on the CPU" "$dir.resume.log" ||
        { echo "FAIL gpu_emulated_resume_$1_$2: the resume's log does not name the emulated device"; failed=1; }
    compare_fields "resume_$1_$2" "$T/resume.cpu" "$dir" x v T pressure eps_p D_bond
    compare_series "resume_$1_$2" "$T/resume.cpu" "$dir"
}
if "$EMU" impact "$T/resume.ini" -o "$T/resume.cpu" --device cpu --threads 1 > "$T/resume.cpu.log" 2>&1; then
    resume_across gpu cpu
    resume_across cpu gpu
else
    echo "FAIL gpu_emulated_resume: the uninterrupted run failed: $(tail -c 300 "$T/resume.cpu.log")"
    failed=1
fi

# A device fault: the emulation fails the copy of the diagnostics' sums (SPRAYCOAT_CUDA_EMU_FAIL_COPY: 2 bodies x
# 120 bytes, struct point_sums of mpm/diagnostics_point.h; on a device a kernel's fault surfaces so, at the next
# copy).  The run stops as a fault of the machine (exit status 3, as a full disk: a rerun may pass; `vcrit` records a
# failed simulation, exit 1's, as failed and never runs it again) at its first series row after the start, the
# message names the step, the time and what failed, no results file is written, and the progress line says how far
# it got.
fault_dir="$T/fault"
SPRAYCOAT_CUDA_EMU_FAIL_COPY=240 "$EMU" impact "$T/two_bodies.ini" -o "$fault_dir" --device gpu --threads 1 \
    > "$fault_dir.log" 2>&1
status=$?
why=""
[ "$status" = 3 ] || why="exit status $status, not 3;"
grep -q "^spraycoat: impact: step [1-9][0-9]* (t = [0-9.e+-]* s): summing the diagnostics on the GPU: .*launch failure" \
    "$fault_dir.log" || why="$why the message does not name the step, the time and the failed sum;"
[ -e "$fault_dir/impact.h5" ] && why="$why a results file was written;"
grep -q "impact: stopped, [1-9][0-9]* ps" "$fault_dir.log" || why="$why the progress line does not say how far it got;"
if [ -z "$why" ]; then
    echo "PASS gpu_emulated_device_fault (exit 3 at $(sed -n 's/^spraycoat: impact: \(step [0-9]*\).*/\1/p' "$fault_dir.log"))"
else
    echo "FAIL gpu_emulated_device_fault: $why $(tail -c 300 "$fault_dir.log")"
    failed=1
fi

exit "$failed"
