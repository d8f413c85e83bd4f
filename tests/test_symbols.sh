#!/bin/sh
# Module boundaries (docs/architecture.md: one public header per module states its whole API; everything else is
# static or module-private):
#   - every external function and global of a module's objects carries the module's prefix: dem_ in dem/, mpm_ in
#     mpm/, render_ in render/, couple_ or coupling_ in coupling/; core/ and app/ are sets of small modules, each
#     file with the prefixes listed below;
#   - a module's private headers (every M/*.h but the public M/M.h) are included only by M/*.c and M/*.h, never
#     by the public header, and by a test only when the test says so in a comment that names the header and says
#     "module-private" (a white-box test of that module).
# Usage: tests/test_symbols.sh [BUILD] (default: the folder of $SPRAYCOAT_BIN, else build).
set -u
cd "$(dirname "$0")/.."
bin=${SPRAYCOAT_BIN:-build/spraycoat}
build=${1:-$(dirname "$bin")}

# The prefixes each object of core/ and app/ may export (besides its own, these are the only ones).
core_prefixes() {
    case "$1" in
        atomic) echo "atomic_" ;;
        balance) echo "balance_" ;;
        config) echo "case_" ;;
        csv) echo "csv_" ;;
        error) echo "sc_" ;;
        h5io) echo "h5_" ;;
        interrupt) echo "interrupt_" ;;
        isa) echo "isa_" ;;
        log) echo "log_" ;;
        logistic) echo "logistic_" ;;
        memory) echo "memory_" ;;
        parallel) echo "parallel_" ;;
        rng) echo "rng_" ;;
        root) echo "root_" ;;
        run_keys) echo "run_" ;;
        units) echo "units_" ;;
        version) echo "spraycoat_version spraycoat_sources_id spraycoat_build_info" ;;
        *) echo "" ;;
    esac
}
app_prefixes() {
    case "$1" in
        main) echo "main" ;;
        info) echo "info_" ;;
        # the kernels' names, each a jump to its level's compilation, and their table (app/isa_dispatch.c)
        isa_dispatch) echo "isa_dispatch_ dem_ mpm_" ;;
        rundir) echo "app_ run_dir_ stage_ stages_ spraycoat_registry" ;;
        stage_loop) echo "stage_" ;;
        xdmf) echo "xdmf_" ;;
        couple_stage) echo "couple_stage_ couple_stage_read_bodies couple_stage_bodies_free" ;;
        vcrit_stage) echo "vcrit_stage_ vcrit_case_keys vcrit_runs_ vcrit_verdict_name" ;;
        calibrate_stage) echo "calibrate_stage_ calibrate_case_keys" ;;
        calibrate_vcrit) echo "calibrate_vcrit_" ;;
        sweep_stage) echo "sweep_stage_ sweep_case_keys" ;;
        *_stage) echo "$1_" ;;
        *) echo "" ;;
    esac
}

# check_objects MODULE: one line per external symbol without an allowed prefix; PASS/FAIL symbols_MODULE.
check_objects() {
    module=$1
    bad=0
    found=0
    for o in "$build/$module"/*.o; do
        [ -f "$o" ] || continue
        found=1
        name=$(basename "$o" .o)
        case "$module" in
            dem | mpm | render) allowed="${module}_" ;;
            coupling) allowed="couple_ coupling_" ;;
            core) allowed=$(core_prefixes "$name") ;;
            app) allowed=$(app_prefixes "$name") ;;
        esac
        if [ -z "$allowed" ]; then
            echo "  $module/$name.o: no prefixes listed for this file in tests/test_symbols.sh"
            bad=$((bad + 1))
            continue
        fi
        # defined external symbols; OpenMP's named critical sections (.gomp_critical_user_*) and AddressSanitizer's
        # one-definition-rule indicators (__odr_asan.*) are not names of ours
        for sym in $(nm -g --defined-only "$o" | awk 'NF == 3 { print $3 }' | grep -v -e '^\.gomp_critical_user_' -e '^__odr_asan\.'); do
            ok=0
            for p in $allowed; do
                case "$sym" in "$p"*) ok=1 ;; esac
            done
            if [ "$ok" -eq 0 ]; then
                echo "  $module/$name.o exports $sym (allowed: $allowed)"
                bad=$((bad + 1))
            fi
        done
    done
    if [ "$found" -eq 0 ]; then
        echo "FAIL symbols_$module (no objects in $build/$module: build first)"
    elif [ "$bad" -eq 0 ]; then
        echo "PASS symbols_$module"
    else
        echo "FAIL symbols_$module ($bad external names without the module's prefix)"
    fi
    unprefixed=$((unprefixed + bad))
}

unprefixed=0
for module in core dem mpm render coupling app; do
    check_objects "$module"
done

# check_private MODULE: nothing outside MODULE/ includes its private headers, except tests that declare it; the
# public header MODULE/MODULE.h includes none of them.
check_private() {
    module=$1
    bad=0
    for header in "$module"/*.h; do
        [ -f "$header" ] || continue
        [ "$header" = "$module/$module.h" ] && continue
        for file in $(grep -rlF --include='*.c' --include='*.h' "#include \"$header\"" . | sed 's|^\./||'); do
            case "$file" in
                "$module/$module.h")
                    echo "  the public header $file includes the private $header"
                    bad=$((bad + 1)) ;;
                "$module"/*) ;;
                tests/*)
                    if ! grep -q 'module-private' "$file" || ! grep -v '#include' "$file" | grep -qF "$header"; then
                        echo "  $file includes the private $header without a module-private comment naming it"
                        bad=$((bad + 1))
                    fi ;;
                *)
                    echo "  $file includes the private $header"
                    bad=$((bad + 1)) ;;
            esac
        done
    done
    if [ "$bad" -eq 0 ]; then
        echo "PASS private_headers_$module"
    else
        echo "FAIL private_headers_$module ($bad includes of private headers)"
        private_failures=$((private_failures + 1))
    fi
}

private_failures=0
for module in dem mpm render coupling app; do
    check_private "$module"
done
echo "  ($unprefixed external names without their module's prefix)"
[ "$unprefixed" -eq 0 ] && [ "$private_failures" -eq 0 ]
