#!/bin/sh
# ParaView opens the XDMF files (docs/files.md, "XDMF"): ParaView's Python (pvpython, or python3 with the
# paraview module; Debian packages paraview and python3-paraview, `scripts/bootstrap --paraview`) reads
# impact.xdmf of a single impact run, and impact.xdmf, impact_run_NNNN.xdmf and spray.xdmf of a small
# pipeline, and of an oblique impact whose points leave the grid box (later snapshots have fewer points), with
# the reader ParaView picks by default (OpenDataFile), the Xdmf3 readers (Xdmf3ReaderS,
# Xdmf3ReaderT) and the legacy one (XDMFReader), and checks them against the HDF5 files: at every time step the
# number of points is the length of the snapshot's (or /particles') x, the number of cells equals it (one
# vertex cell a point: a Polyvertex topology without connectivity gives 0 cells in the Xdmf3 readers and the
# Surface and Points representations draw nothing), the time steps are the snapshots (values and count), and
# the point arrays are the group's datasets other than x.  spray.xdmf is the time series of spray.h5
# /snapshots/NNNNNN (snapshot_every), or the final /particles without time when the run took no snapshots.
# deposit.xdmf of a traversing spray (cases/traverse_demo.ini) is the height map /deposit/height: one node a
# cell, (ny - 1)(nx - 1) quads between them, the one array `height`, no time.
#
# Without ParaView's Python prints SKIP and the reason.  VisIt is not packaged in Debian 12 (no test).
# `tests/test_paraview.sh RUN_DIR...` checks those run folders instead of making new ones.
# Run from the repository root with $SPRAYCOAT_BIN (tests/run_tests.sh sets it).  Needs h5ls, h5dump.
set -u

BIN=${SPRAYCOAT_BIN:-build/spraycoat}
IMPACT_CASE=tests/bad_cases/valid_impact_base.ini
PIPELINE_CASE=tests/fixtures/pipeline_small.ini

if command -v pvpython >/dev/null 2>&1; then
    PV="pvpython --force-offscreen-rendering"
elif /usr/bin/python3 -c 'import paraview.simple' >/dev/null 2>&1; then
    PV=/usr/bin/python3
else
    echo "SKIP paraview: ParaView's Python is not installed (Debian packages paraview python3-paraview; \`scripts/bootstrap --paraview\` installs them)"
    exit 0
fi
for tool in h5ls h5dump; do
    if ! command -v "$tool" >/dev/null 2>&1; then
        echo "FAIL paraview ($tool not found: install hdf5-tools)"
        exit 1
    fi
done

T=$(mktemp -d) || exit 1
trap 'rm -rf "$T"' EXIT

if [ $# -gt 0 ]; then
    dirs="$*"
else
    if [ ! -x "$BIN" ]; then
        echo "FAIL paraview (no $BIN; run from the repository root after make)"
        exit 1
    fi
    if ! "$BIN" impact "$IMPACT_CASE" -o "$T/impact" >"$T/impact.log" 2>&1; then
        echo "FAIL paraview_impact_run ($(tail -n 3 "$T/impact.log" | tr '\n' ' '))"
        exit 1
    fi
    # the base case at 70 degrees and 1500 m/s with no box margin for 10 ns: points leave the box from ~6 ns
    sed -e 's/^t_end = .*/t_end = 10e-9\nsnapshot_every = 2e-9\nbox_margin = 0\nangle = 70/' \
        -e 's/^velocity = .*/velocity = 1500/' "$IMPACT_CASE" >"$T/removing.ini"
    if ! "$BIN" impact "$T/removing.ini" -o "$T/removing" >"$T/removing.log" 2>&1; then
        echo "FAIL paraview_removing_run ($(tail -n 3 "$T/removing.log" | tr '\n' ' '))"
        exit 1
    fi
    first=$(h5ls "$T/removing/impact.h5/snapshots/000000/x" | sed -n 's/.*{\([0-9]*\),.*/\1/p')
    last=$(h5ls "$T/removing/impact.h5/snapshots/000005/x" | sed -n 's/.*{\([0-9]*\),.*/\1/p')
    if [ -z "$first" ] || [ -z "$last" ] || [ "$last" -ge "$first" ]; then
        echo "FAIL paraview_removing_run (no points removed: $first points at first, ${last:-?} at the end)"
    fi
    if ! "$BIN" run "$PIPELINE_CASE" -o "$T/pipeline" >"$T/pipeline.log" 2>&1; then
        echo "FAIL paraview_pipeline_run ($(tail -n 3 "$T/pipeline.log" | tr '\n' ' '))"
        exit 1
    fi
    if ! "$BIN" spray cases/traverse_demo.ini -o "$T/traverse" >"$T/traverse.log" 2>&1; then
        echo "FAIL paraview_traverse_run ($(tail -n 3 "$T/traverse.log" | tr '\n' ' '))"
        exit 1
    fi
    dirs="$T/impact $T/removing $T/pipeline $T/traverse"
fi

cat >"$T/check.py" <<'EOF'
import glob, os, re, subprocess, sys
from paraview.simple import OpenDataFile, Xdmf3ReaderS, Xdmf3ReaderT, XDMFReader, Delete

def datasets(h5):
    """{path: first dimension} of every dataset of the HDF5 file."""
    out = subprocess.run(["h5ls", "-r", h5], capture_output=True, text=True, check=True).stdout
    found = {}
    for line in out.splitlines():
        m = re.match(r"^(\S+)\s+Dataset \{(\d+)", line)
        if m:
            found[m.group(1)] = int(m.group(2))
    return found

def attribute_t(h5, group):
    out = subprocess.run(["h5dump", "-a", group + "/t", "-m", "%.17g", h5], capture_output=True, text=True).stdout
    m = re.search(r"\(0\): (\S+)", out)
    return float(m.group(1)) if m else None

def deposit_shape(h5):
    """(ny, nx) of spray.h5:/deposit/height."""
    out = subprocess.run(["h5ls", h5 + "/deposit/height"], capture_output=True, text=True, check=True).stdout
    m = re.search(r"Dataset \{(\d+), (\d+)\}", out)
    return int(m.group(1)), int(m.group(2))

def expected_cells(xdmf, points):
    """Cells ParaView must make: one vertex a point, but for deposit.xdmf (a mesh of quads between the nodes)."""
    folder, name = os.path.split(xdmf)
    if name != "deposit.xdmf":
        return points
    ny, nx = deposit_shape(os.path.join(folder, "spray.h5"))
    return (ny - 1) * (nx - 1)

def values(h5, dataset):
    """Every number of a 1-D dataset."""
    out = subprocess.run(["h5dump", "-d", dataset, "-m", "%.17g", h5], capture_output=True, text=True).stdout
    data = out.split("DATA {", 1)[1].split("}", 1)[0]
    return [float(v) for v in re.findall(r"(?<=[\s,:])(-?[0-9][0-9.eE+-]*)(?=,|\s|$)", re.sub(r"\(\d+\):", ":", data))]

def deposit_bounds_problem(xdmf, bounds):
    """deposit.xdmf must lie in the target plane with x and y those of /deposit/x and /deposit/y (a 2-D mesh went
    to ParaView's y-z plane)."""
    h5 = os.path.join(os.path.dirname(xdmf), "spray.h5")
    x, y = values(h5, "/deposit/x"), values(h5, "/deposit/y")
    want = (x[0], x[-1], y[0], y[-1])
    if any(abs(g - w) > 1e-9 * max(1.0, abs(w)) for g, w in zip(bounds[:4], want)) or bounds[4] != bounds[5]:
        return "bounds %s, expected x %g..%g, y %g..%g in one z plane" % (bounds, *want)
    return None

def expected(xdmf):
    """[(time or None, points, array names)] from the HDF5 file the XDMF file indexes."""
    folder, name = os.path.split(xdmf)
    if name == "deposit.xdmf":  # the height map: one node a cell of /deposit/height, no time
        ny, nx = deposit_shape(os.path.join(folder, "spray.h5"))
        return [(None, ny * nx, ["height"])]
    h5 = os.path.join(folder, "spray.h5" if name == "spray.xdmf" else "impact.h5")
    sets = datasets(h5)
    m = re.match(r"impact_run_(\d+)\.xdmf$", name)
    if name == "spray.xdmf" and not any(re.match(r"/snapshots/\d{6}/", p) for p in sets):
        # snapshot_every = 0: the final particles, no time
        names = sorted(p.split("/")[-1] for p in sets if p.startswith("/particles/") and p != "/particles/x")
        return [(None, sets["/particles/x"], names)]
    if name == "spray.xdmf":
        base = "/snapshots"  # the spray's time series: one step a snapshot
    elif m:
        base = "/run_%s/snapshots" % m.group(1)
    elif any(p.startswith("/snapshots/") for p in sets):
        base = "/snapshots"
    else:
        base = "/run_0000/snapshots"  # impact.xdmf of several runs is the first run's
    groups = sorted({p.rsplit("/", 1)[0] for p in sets if re.match(re.escape(base) + r"/\d{6}/", p)})
    steps = []
    for g in groups:
        names = sorted(p.split("/")[-1] for p in sets if p.startswith(g + "/") and p != g + "/x")
        steps.append((attribute_t(h5, g), sets[g + "/x"], names))
    return steps

failed = 0
def report(ok, label, why):
    global failed
    print(("PASS %s" % label) if ok else ("FAIL %s (%s)" % (label, why)))
    failed += not ok

readers = [("default", lambda f: OpenDataFile(f)), ("Xdmf3ReaderS", lambda f: Xdmf3ReaderS(FileName=[f])),
           ("Xdmf3ReaderT", lambda f: Xdmf3ReaderT(FileName=[f])), ("XDMFReader", lambda f: XDMFReader(FileNames=[f]))]
for folder in sys.argv[1:]:
    files = sorted(glob.glob(os.path.join(folder, "*.xdmf")))
    if not files:
        report(False, "paraview_files", "no XDMF file in %s" % folder)
    for xdmf in files:
        want = expected(xdmf)
        for label, make in readers:
            tag = "paraview_%s_%s_%s" % (os.path.basename(folder.rstrip("/")), os.path.basename(xdmf), label)
            reader = make(xdmf)
            tv = reader.TimestepValues  # a list, one number (one time step) or nothing
            times = [] if tv is None else list(tv) if hasattr(tv, "__len__") else [tv]
            problems = []
            timed = want[0][0] is not None
            if timed and len(times) != len(want):
                problems.append("%d time steps, the HDF5 file %d snapshots" % (len(times), len(want)))
            if not timed and times:
                problems.append("%d time steps, expected none" % len(times))
            for k, (t, points, names) in enumerate(want):
                if timed:
                    if k >= len(times):
                        break
                    if t is None or abs(times[k] - t) > 1e-12 * max(1.0, abs(t)):
                        problems.append("time %d is %r, the snapshot's t %r" % (k, times[k], t))
                    reader.UpdatePipeline(times[k])
                else:
                    reader.UpdatePipeline()
                info = reader.GetDataInformation()
                got_points, got_cells = info.GetNumberOfPoints(), info.GetNumberOfCells()
                got_names = sorted(reader.PointData.keys())
                if got_points != points:
                    problems.append("step %d: %d points, the HDF5 file %d" % (k, got_points, points))
                if got_cells != expected_cells(xdmf, points):
                    problems.append("step %d: %d cells, expected %d" % (k, got_cells, expected_cells(xdmf, points)))
                if os.path.basename(xdmf) == "deposit.xdmf":
                    problem = deposit_bounds_problem(xdmf, info.GetBounds())
                    if problem:
                        problems.append(problem)
                if got_names != names:
                    problems.append("step %d: arrays %s, the HDF5 datasets %s" % (k, got_names, names))
            report(not problems, tag, "; ".join(problems[:4]))
            Delete(reader)
sys.exit(1 if failed else 0)
EOF

# shellcheck disable=SC2086 # $PV is a command and its option
$PV "$T/check.py" $dirs >"$T/check.out" 2>&1
status=$?
grep -E '^(PASS|FAIL) ' "$T/check.out"
# 1: a check failed (its FAIL line printed); anything else: the reader crashed or the script broke
if [ "$status" -ne 0 ] && { [ "$status" -ne 1 ] || ! grep -q '^FAIL ' "$T/check.out"; }; then
    echo "FAIL paraview (ParaView's Python exited with $status: $(grep -v -E '^(PASS|FAIL) ' "$T/check.out" | tail -n 5 | tr '\n' ' '))"
fi
exit 0
