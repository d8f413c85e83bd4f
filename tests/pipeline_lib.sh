# Shell helpers of the pipeline tests (sourced by tests/test_pipeline.sh and tests/test_mpi.sh).

# values FILE DATASET: the dataset's numbers, one per line, at full precision.
values() {
    h5dump -y -w 0 -m '%.17g' -d "$2" "$1" 2>/dev/null |
        awk '/DATA [{]/ && !done { on = 1; next } on && /^ *[}]/ { on = 0; done = 1 } on { print }' |
        tr ',' '\n' | tr -d ' ' | grep -v '^$'
}

# same_h5 A B: 0 when the two files hold the same groups, datasets (bit for bit: h5diff -d 0 also compares NaN
# positions) and attributes, apart from the attributes that legitimately differ between runs: created
# (timing), program_version (the build), case (the resolved case text, whose comments say where it was
# read from; case_hash is compared) and the build record of any /code group (compiler, flags, libraries: the
# builds compared may differ).  Else 1, with the differences in $why.
same_h5() {
    why=""
    for f in "$1" "$2"; do
        if [ ! -f "$f" ]; then
            why="$f does not exist"
            return 1
        fi
    done
    h5diff -c "$1" "$2" >"$T/h5diff.out" 2>&1
    h5status=$?
    if [ "$h5status" -gt 1 ]; then
        why="h5diff failed: $(head -n 3 "$T/h5diff.out" | tr '\n' ' ')"
        return 1
    fi
    awk '/^attribute: <(created|program_version|case) of / || /^attribute: <[^ ]* of <[^>]*\/code>>/ { skip = 1; next }
         /differences found$/ { if (skip) { skip = 0; next } }
         NF { print }' "$T/h5diff.out" >"$T/h5diff.left"
    if [ -s "$T/h5diff.left" ]; then
        why="$(head -n 6 "$T/h5diff.left" | tr '\n' ' ')"
        return 1
    fi
    return 0
}

# same_run_dir A B STAGES...: same_h5 on RUN_DIR/STAGE.h5 of both directories for every stage named.
same_run_dir() {
    a=$1
    b=$2
    shift 2
    for stage in "$@"; do
        if ! same_h5 "$a/$stage.h5" "$b/$stage.h5"; then
            why="$stage.h5: $why"
            return 1
        fi
    done
    return 0
}

# nozzle_case OUT [DT]: tests/fixtures/pipeline_small.ini with cases/al6061_n2.ini's [nozzle] (N2 at 6.55 MPa, 698 K:
# exit Mach 3.9, a bow shock at the target) instead of its hand-set release speeds and jet constants, so that the
# particles' speeds and temperatures differ by diameter; the spray's dt DT when given.  Run from the repository root.
nozzle_case() {
    sed -e '/^release_speed_m/d' -e '/^\[jet\]/,/^$/{/^C1\|^C3\|^virtual_origin\|^core_length/d}' \
        -e "s/^dt = .*/dt = ${2:-1e-6}/" tests/fixtures/pipeline_small.ini >"$1"
    sed -n '/^\[nozzle\]/,/^$/p' cases/al6061_n2.ini >>"$1"
}
