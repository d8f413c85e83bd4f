#!/bin/sh
# `spraycoat vcrit` on a tiny case (an 8 um particle on a 2 um grid, 10 ns per run: about 2 s in all here):
# vcrit.csv and vcrit.h5 exist; each v_crit lies in [v_low, v_high], or the diameter is a '#' line with NaN and
# the reason; a spray case with `[deposition] rule = table` naming vcrit.csv or vcrit.h5 passes `spraycoat
# check`; a search stopped by SIGTERM (exit 143) and resumed reuses the recorded runs and writes the same table;
# a search whose bracket fails reports 'not bracketed'; the record of the runs is kept and a later search over one
# of the diameters reuses it (runs nothing), one on another substrate does not; a CoR run recorded as bonded below
# v_crit is reported as "not monotone"; outcome = adhered counts a held particle as a success; method = logistic
# adds its sweep and gives the 50 % point of an independent logistic fit to the runs (the middle of the gap where the
# outcomes are separable, which vcrit.csv, vcrit.h5 and the report say; the bisection's v_crit when that point lies
# beyond every speed run); with reference_diameter a
# particle twice the size on a scaled set-up makes the same runs (rate-free material); a rigid substrate is
# accepted by `check` and searched; a record of the runs that cannot be read stops the search before any run (exit
# 3); after a search of another case fails writing vcrit.h5 (exit 3), the first case
# is searched again rather than found up to date beside the other's vcrit.csv; at an angle the table's v_crit is
# the normal component; a 2-D table missing a whole temperature is refused; a 1-D table with a diameter that was not
# bracketed is read with a warning naming it.  Prints "PASS name" /
# "FAIL name (reason)".
# Run from the repository root with $SPRAYCOAT_BIN (tests/run_tests.sh sets both).
set -u
. tests/wait_lib.sh

spraycoat_bin
BASE=tests/bad_cases/valid_base.ini

pass() { echo "PASS $1"; }
fail() { echo "FAIL $1 ($2)"; }

if [ ! -x "$BIN" ] || [ ! -r "$BASE" ]; then
    echo "FAIL vcrit (no $BIN or $BASE; run from the repository root after make)"
    exit 1
fi
scratch_dir

V_LOW=200
V_HIGH=1200
write_case() { # write_case FILE V_HIGH: tests/fixtures/vcrit_tiny.ini and a [vcrit] section
    cat tests/fixtures/vcrit_tiny.ini - >"$1" <<EOF

[vcrit]
diameters = 10e-6,8e-6
v_low = $V_LOW
v_high = $2
tolerance = 200
EOF
}
CASE=$T/vcrit_tiny.ini
write_case "$CASE" "$V_HIGH"

# ---- 1. the search: outputs, v_crit inside the bracket or NaN with a reason --------------------------------------
RUN=$T/ref
if "$BIN" vcrit "$CASE" -o "$RUN" >"$T/ref.log" 2>&1; then
    why=""
    [ -s "$RUN/vcrit.csv" ] || why="$why no vcrit.csv;"
    [ -s "$RUN/vcrit.h5" ] || why="$why no vcrit.h5;"
    # the record of the runs is kept with the outputs, one line per run of the table's `runs` column
    recorded=$(grep -c '^[0-9]' "$RUN/vcrit_runs.csv" 2>/dev/null)
    counted=$(awk -F, 'NR > 1 && !/^#/ { n += $NF } END { print n + 0 }' "$RUN/vcrit.csv")
    [ "${recorded:-0}" -gt 0 ] && [ "$recorded" -eq "$counted" ] ||
        why="$why vcrit_runs.csv has ${recorded:-no} runs, vcrit.csv counts $counted;"
    [ "$(head -n 1 "$RUN/vcrit.csv")" = "diameter,v_crit,pbcp,v_rest,runs" ] || why="$why header is not diameter,v_crit,pbcp,v_rest,runs;"
    rows=$(sed 1d "$RUN/vcrit.csv" | wc -l | tr -d ' ')
    [ "$rows" -eq 2 ] || why="$why $rows rows for 2 diameters;"
    # data rows: v_crit within [v_low, v_high], diameters ascending; '#' rows: nan and 'not bracketed'
    bad=$(sed 1d "$RUN/vcrit.csv" | awk -F, -v lo="$V_LOW" -v hi="$V_HIGH" '
        /^#/ { if ($2 != "nan" || $0 !~ /not bracketed/) print "row without a reason: " $0; next }
        { if (!($2 + 0 >= lo && $2 + 0 <= hi)) print "v_crit outside the bracket: " $0
          if (NR > 1 && $1 + 0 <= last) print "diameters not ascending: " $0; last = $1 + 0 }')
    [ -n "$bad" ] && why="$why $bad;"
    if [ -z "$why" ]; then pass vcrit_outputs; else fail vcrit_outputs "$why"; fi
    sed 's/^/  /' "$RUN/vcrit.csv"
else
    fail vcrit_outputs "spraycoat vcrit exited with status $?: $(tail -n 3 "$T/ref.log" | tr '\n' ' ')"
    exit 1
fi

# ---- 2. the spray stage reads the table (CSV and HDF5) ----------------------------------------------------------
if grep -q '^[0-9]' "$RUN/vcrit.csv"; then
    for file in vcrit.csv vcrit.h5; do
        sed -e 's/^rule = adhesion$/rule = table/' -e "s|^alpha_adh = .*|table = $RUN/$file|" "$BASE" >"$T/spray.ini"
        if ! grep -q '^rule = table$' "$T/spray.ini"; then
            fail "vcrit_table_readable_${file#vcrit.}" "$BASE no longer has the lines rule = adhesion and alpha_adh"
        elif "$BIN" check "$T/spray.ini" >"$T/check.log" 2>&1; then
            pass "vcrit_table_readable_${file#vcrit.}"
        else
            fail "vcrit_table_readable_${file#vcrit.}" "$(grep '^spraycoat:' "$T/check.log" | head -n 1)"
        fi
    done
else
    fail vcrit_table_readable "no diameter was bracketed, so there is no table to read: $(tr '\n' ' ' <"$RUN/vcrit.csv")"
fi

# ---- 3. SIGTERM after some runs, then resume: recorded runs are reused, the same table ------------------------
RUN2=$T/term
"$BIN" vcrit "$CASE" -o "$RUN2" >"$T/term.log" 2>&1 &
bg=$!
wait_until "$bg" 24 rows_at_least "$RUN2/vcrit_runs.csv" 2
kill -TERM "$bg" 2>/dev/null
wait "$bg" 2>/dev/null
status=$?
bg=""
why=""
if [ -f "$RUN2/vcrit.csv" ]; then
    echo "  note: the search finished before SIGTERM arrived"
else
    [ "$status" -eq 143 ] || why="$why exit status $status, expected 143;"
    recorded=$(grep -c '^[0-9]' "$RUN2/vcrit_runs.csv" 2>/dev/null)
    "$BIN" resume "$RUN2" >"$T/resume.log" 2>&1 || why="$why resume failed: $(tail -n 2 "$T/resume.log" | tr '\n' ' ');"
    grep -q "${recorded:-x} runs recorded" "$T/resume.log" || why="$why resume did not reuse the $recorded recorded runs;"
    grep -q '^critical velocity' "$T/resume.log" || why="$why resume's closing summary has no v_crit table;"
fi
cmp -s "$RUN/vcrit.csv" "$RUN2/vcrit.csv" || why="$why vcrit.csv differs from the uninterrupted search's;"
h5diff -d 0 "$RUN/vcrit.h5" "$RUN2/vcrit.h5" /search /search >/dev/null 2>&1 || why="$why vcrit.h5:/search differs;"
if [ -z "$why" ]; then pass vcrit_sigterm_resume; else fail vcrit_sigterm_resume "$why"; fi

# ---- 4. the kept record: a search over one of the diameters reuses its runs (none run again, the same row); a
# search on another substrate does not ------------------------------------------------------------------------------
RUN5=$T/again
cp -r "$RUN" "$RUN5"
sed 's/^diameters = .*/diameters = 10e-6/' "$CASE" >"$T/one.ini"
why=""
if "$BIN" vcrit "$T/one.ini" -o "$RUN5" >"$T/one.log" 2>&1; then
    grep -q '(0 runs in this process' "$T/one.log" || why="$why the search over 10 um ran again:$(grep -o '([0-9]* runs in this process' "$T/one.log");"
    [ "$(grep '^1e-05,' "$RUN5/vcrit.csv")" = "$(grep '^1e-05,' "$RUN/vcrit.csv")" ] ||
        why="$why the 10 um row differs: $(grep '^1e-05,' "$RUN5/vcrit.csv");"
else
    why="$why the search over 10 um failed: $(tail -n 2 "$T/one.log" | tr '\n' ' ');"
fi
sed 's/^substrate_height = .*/substrate_height = 8e-6/' "$T/one.ini" >"$T/other.ini"
if "$BIN" vcrit "$T/other.ini" -o "$RUN5" >"$T/other.log" 2>&1; then
    grep -q '(0 runs in this process' "$T/other.log" && why="$why the runs of another substrate were reused;"
else
    why="$why the search on another substrate failed: $(tail -n 2 "$T/other.log" | tr '\n' ' ');"
fi
if [ -z "$why" ]; then pass vcrit_record_reused; else fail vcrit_record_reused "$why"; fi

# ---- 4a. a failed write damages nothing and leaves no stale output trusted (app.h stage_write_outputs): a search of
# another case (10 um alone, its runs recorded) in the same run directory fails writing vcrit.h5 (its temporary's
# name blocked by a folder: exit 3): the first case's results stay whole, up to date with their own CSVs; then the
# same search fails writing vcrit_cor.csv, after vcrit.csv of the other case was published: the first case is no
# longer up to date (its vcrit.h5 went before any file of the other case) and writes its own tables again ----------
RUN9=$T/mixed
cp -r "$RUN" "$RUN9"
stale_step() { # stale_step BLOCKED_FILE EXPECT_UP_TO_DATE(0|1) LABEL
    blocked_write "$RUN9" "$1" "$T/mixed1.log" "$BIN" vcrit "$T/one.ini" -o "$RUN9"
    "$BIN" vcrit "$CASE" -o "$RUN9" >"$T/mixed2.log" 2>&1
    again=$?
    [ $blocked -eq 3 ] || why="$why $3: the blocked write exited $blocked, not 3: $(tail -n 1 "$T/mixed1.log");"
    [ $again -eq 0 ] || why="$why $3: the first case's search again exited $again: $(tail -n 1 "$T/mixed2.log");"
    up=0
    grep -q "vcrit.h5 is up to date" "$T/mixed2.log" && up=1
    [ $up -eq "$2" ] || why="$why $3: the first case was up to date: $up, expected $2;"
    cmp -s "$RUN/vcrit.csv" "$RUN9/vcrit.csv" || why="$why $3: vcrit.csv is not the first case's: $(tr '\n' ' ' <"$RUN9/vcrit.csv");"
    cmp -s "$RUN/vcrit_cor.csv" "$RUN9/vcrit_cor.csv" || why="$why $3: vcrit_cor.csv is not the first case's;"
}
why=""
stale_step vcrit.h5 1 "vcrit.h5 blocked"
stale_step vcrit_cor.csv 0 "vcrit_cor.csv blocked"
if [ -z "$why" ]; then pass vcrit_failed_write_leaves_nothing_stale; else fail vcrit_failed_write_leaves_nothing_stale "$why"; fi

# ---- 4b. an outcome that is not monotone in the speed is reported: a CoR run below v_crit (cor_below) recorded as
# bonded, and a rebound above v_crit recorded by an earlier search, make the replayed search say "not monotone" in
# its log, vcrit.h5 and `spraycoat info` ------------------------------------------------------------------------------
RUN6=$T/mono
cp -r "$RUN" "$RUN6"
{ cat "$T/one.ini"; echo "cor_below = 100"; } >"$T/mono.ini"
why=""
if "$BIN" vcrit "$T/mono.ini" -o "$RUN6" >"$T/mono1.log" 2>&1; then
    grep -q "not monotone" "$T/mono1.log" && why="$why a monotone search was reported not monotone: $(grep "not monotone" "$T/mono1.log"; grep -h "^1e-05" "$RUN6/vcrit_runs.csv" | cut -d, -f1-7 | tr "\n" " ");"
    v_cor=$(awk -F, '/^1e-05,/ { print $2 - 100 }' "$RUN6/vcrit.csv")
    # the CoR run's record: verdict (column 5) 1 = bonded
    # and a rebound at 900 m/s that an earlier search recorded (the bisection never visits it)
    awk -F, -v OFS=, -v v="$v_cor" '$1 + 0 == 1e-5 && $2 + 0 == v + 0 { $5 = 1 } { print }
        $1 + 0 == 1e-5 && $2 + 0 == v + 0 { $2 = 900; $5 = 0; $7 = 20; print }' \
        "$RUN6/vcrit_runs.csv" >"$T/runs.csv" && mv "$T/runs.csv" "$RUN6/vcrit_runs.csv"
    rm -f "$RUN6/vcrit.h5" # else the stage is up to date with the case and replays nothing
    if "$BIN" vcrit "$T/mono.ini" -o "$RUN6" >"$T/mono2.log" 2>&1; then
        grep -q '(0 runs in this process' "$T/mono2.log" || why="$why the replay ran again;"
        grep -q "not monotone in the speed: bonds at $v_cor m/s, not bonded at 900 m/s" "$T/mono2.log" ||
            why="$why no warning in the log;"
        "$BIN" info "$RUN6" 2>&1 | grep -q "not monotone in speed: bonds at $v_cor m/s, not bonded at 900 m/s" ||
            why="$why not in spraycoat info;"
    else
        why="$why the replay failed: $(tail -n 2 "$T/mono2.log" | tr '\n' ' ');"
    fi
else
    why="$why the search with cor_below failed: $(tail -n 2 "$T/mono1.log" | tr '\n' ' ');"
fi
if [ -z "$why" ]; then pass vcrit_not_monotone_reported; else fail vcrit_not_monotone_reported "$why"; fi

# ---- 4c. outcome = adhered counts a held particle (at rest on the substrate, too few bonds) as a success: the
# recorded run at 700 m/s (rebounded in the tiny case) rewritten as held (v_rest 0.1 m/s) gives v_crit = 700 with
# outcome = adhered, while outcome = bonded replays the recorded search unchanged (the 10 um row as before) --------
RUN7=$T/adhered
cp -r "$RUN" "$RUN7"
rm -f "$RUN7/vcrit.h5"
# (the tiny case's 10 ns runs end with the particle still moving in, v_rest < 0: every rebound is made to leave at
# 20 m/s, but the one at 700 m/s)
awk -F, -v OFS=, '$1 + 0 == 1e-5 && $5 == 0 { $7 = $2 + 0 == 700 ? 0.1 : 20 } { print }' "$RUN/vcrit_runs.csv" \
    >"$RUN7/vcrit_runs.csv"
why=""
if grep -q '^1e-05,700,' "$RUN7/vcrit_runs.csv" && "$BIN" vcrit "$T/one.ini" -o "$RUN7" >"$T/bonded.log" 2>&1; then
    [ "$(grep '^1e-05,' "$RUN7/vcrit.csv")" = "$(grep '^1e-05,' "$RUN/vcrit.csv")" ] ||
        why="$why outcome = bonded moved the row: $(grep '^1e-05,' "$RUN7/vcrit.csv");"
    # tolerance 500: the bisection stops once 700 m/s counts ([200, 700]), so v_crit is exactly 700 (the tiny case's
    # own runs below it would count as held too)
    { sed 's/^tolerance = .*/tolerance = 500/' "$T/one.ini"; echo "outcome = adhered"; } >"$T/adhered.ini"
    if "$BIN" vcrit "$T/adhered.ini" -o "$RUN7" >"$T/adhered.log" 2>&1; then
        v=$(awk -F, '/^1e-05,/ { print $2 }' "$RUN7/vcrit.csv")
        [ "$v" = 700 ] || why="$why outcome = adhered gives v_crit '$v', expected 700;"
        h5dump -a /search/000/outcome "$RUN7/vcrit.h5" 2>/dev/null | grep -q '"adhered"' || why="$why vcrit.h5 does not say adhered;"
    else
        why="$why outcome = adhered failed: $(tail -n 2 "$T/adhered.log" | tr '\n' ' ');"
    fi
else
    why="$why no 700 m/s record or the replay failed: $(tail -n 2 "$T/bonded.log" | tr '\n' ' ');"
fi
if [ -z "$why" ]; then pass vcrit_outcome_adhered; else fail vcrit_outcome_adhered "$why"; fi

# ---- 4d. method = logistic: the bisection's runs (reused from the record), sweep_count runs on each side of its
# v_crit sweep_step apart, and v_crit = the 50 % point of a first-order logistic fit to every settled run of the
# search, checked against an independent fit (python3, Newton on the unscaled speed) of the runs in vcrit_cor.csv:
# once as the search ran, once after a sweep run above v_crit is rewritten as rebounded (outcomes that overlap:
# the maximum-likelihood fit rather than the middle of the gap).  The table with its extra columns is readable -----
RUN8=$T/logistic
cp -r "$RUN" "$RUN8"
rm -f "$RUN8/vcrit.h5"
{ cat "$CASE"; printf 'method = logistic\nsweep_step = 25\nsweep_count = 3\n'; } >"$T/logistic.ini"
# refit D: the settled runs of diameter D in vcrit_cor.csv (bonded = 1); prints the fitted v_crit and its kind
refit() {
    python3 - "$1" "$2" <<'PY'
import csv, math, sys
rows = [r for r in csv.DictReader(open(sys.argv[1])) if float(r["diameter"]) == float(sys.argv[2])]
v = [float(r["velocity"]) for r in rows if r["verdict"] != "unsettled"]
y = [1 if r["verdict"] == "bonded" else 0 for r in rows if r["verdict"] != "unsettled"]
fail, succ = max(x for x, o in zip(v, y) if not o), min(x for x, o in zip(v, y) if o)
if fail <= succ:
    print("%.12g separable" % (0.5 * (fail + succ)))
    sys.exit(0)
a = b = 0.0
for _ in range(200):
    g0 = g1 = h00 = h01 = h11 = 0.0
    for x, o in zip(v, y):
        p = 1 / (1 + math.exp(-(a + b * x)))
        w = p * (1 - p)
        g0, g1 = g0 + p - o, g1 + (p - o) * x
        h00, h01, h11 = h00 + w, h01 + w * x, h11 + w * x * x
    det = h00 * h11 - h01 * h01
    a, b = a - (h11 * g0 - h01 * g1) / det, b - (h00 * g1 - h01 * g0) / det
print("%.12g overlapping" % (-a / b))
PY
}
# compare D: vcrit.csv's v_crit of diameter D against refit; prints what differs
compare() {
    got=$(awk -F, -v d="$1" 'NR > 1 && $1 + 0 == d + 0 { print $2 }' "$RUN8/vcrit.csv")
    want=$(refit "$RUN8/vcrit_cor.csv" "$1")
    awk -v g="$got" -v w="${want% *}" 'BEGIN { exit !(g != "" && (g - w) ^ 2 <= (1e-6 * w) ^ 2) }' ||
        echo "d = $1: v_crit $got, refit $want;"
}
# separable RUN: what vcrit.csv, vcrit.h5 and report.html of RUN (rendered) say wrongly of the rows whose outcomes are
# separable (v_crit_se nan): such a row has the comment line "# d = D m: outcomes separable: v_crit is the middle of
# the gap A-B m/s (no fit, no standard error)" beneath it, with (A + B) / 2 its v_crit, its /search/NNN result says
# the same, and the report's sentence on v_crit names it among the separable rows (or says "every row"); a fitted
# row has none of these and is named among the fits.  (Each separable row was a "logistic 50 % point" in the report,
# "bracketed" in vcrit.h5, and vcrit.csv said nothing.)
separable() {
    i=0
    while h5dump -a "/search/$(printf %03d $i)/result" "$1/vcrit.h5" >"$T/search.txt" 2>/dev/null; do
        printf '%s\t%s\n' "$(h5dump -a "/search/$(printf %03d $i)/diameter" "$1/vcrit.h5" | sed -n 's/.*(0): //p')" \
            "$(sed -n 's/.*(0): "\(.*\)"$/\1/p' "$T/search.txt")"
        i=$((i + 1))
    done >"$T/results.txt"
    python3 - "$1/vcrit.csv" "$T/results.txt" "$1/report.html" <<'PY'
import math, re, sys
lines = open(sys.argv[1]).read().splitlines()
col = {name: k for k, name in enumerate(lines[0].split(","))}
rows = [l.split(",") for l in lines[1:] if not l.startswith("#")]
notes = {float(m.group(1)): m.group(2) for m in (re.match(r"# d = (\S+) m: (.*)", l) for l in lines) if m}
results = {float(d): r for d, r in (l.split("\t", 1) for l in open(sys.argv[2]).read().splitlines())}
sentence = [l for l in open(sys.argv[3]) if l.startswith("<p>v_crit")]
parts = re.sub(r"<[^>]*>", "", sentence[0]).strip().rstrip(".").split("; ") if sentence else []
gap = re.compile(r"outcomes separable: v_crit is the middle of the gap (\S+)-(\S+) m/s \(no fit, no standard error\)")
for row in rows:
    d, v = float(row[col["diameter"]]), float(row[col["v_crit"]])
    x = d * 1e6
    label = "%.*f" % (max(0, 2 - math.floor(math.log10(x))), x)
    fitted = row[col["v_crit_se"]] != "nan"
    note, result = notes.get(d), results.get(d, "no /search")
    if fitted and (note or "separable" in result):
        print("d = %g: fitted (v_crit_se %s), but noted '%s', result '%s';" % (d, row[col["v_crit_se"]], note, result))
    m = gap.search(note or "")
    if not fitted and not (m and abs(0.5 * (float(m.group(1)) + float(m.group(2))) - v) <= 1e-9 * v):
        print("d = %g: v_crit %g, v_crit_se nan, note beneath its row '%s';" % (d, v, note))
    if not fitted and not gap.search(result):
        print("d = %g: v_crit_se nan, /search result '%s';" % (d, result))
    kind = "logistic fit's 50 % bonding probability" if fitted else "the outcomes are separable"
    part = [p for p in parts if kind in p]
    if not (part and (part[0].endswith("for every row") or re.search(r"for d = (.*, )?%s µm" % re.escape(label), part[0]))):
        print("d = %g (%s): the report says '%s';" % (d, "fitted" if fitted else "separable", "; ".join(parts)))
PY
}
why=""
if "$BIN" vcrit "$T/logistic.ini" -o "$RUN8" >"$T/logistic1.log" 2>&1; then
    head -n 1 "$RUN8/vcrit.csv" | grep -q ',v_crit_se,width,v_bisection$' || why="$why header $(head -n 1 "$RUN8/vcrit.csv");"
    "$BIN" render "$T/logistic.ini" -o "$RUN8" >"$T/logistic1_render.log" 2>&1 || why="$why render failed;"
    why="$why$(separable "$RUN8")"
    [ "$(grep -c '^[0-9].*,nan,nan,' "$RUN8/vcrit.csv")" -ge 1 ] || why="$why no separable row to check;"
    grep -q "runs recorded in $RUN8 are reused" "$T/logistic1.log" || why="$why the bisection's runs were not reused;"
    for d in 8e-06 1e-05; do
        vb=$(awk -F, -v d="$d" 'NR > 1 && $1 + 0 == d + 0 { print $8 }' "$RUN8/vcrit.csv")
        for k in -3 -2 -1 1 2 3; do
            awk -F, -v d="$d" -v v="$vb" -v k="$k" '$1 + 0 == d + 0 && $2 + 0 == v + 25 * k { found = 1 }
                END { exit !found }' "$RUN8/vcrit_cor.csv" || why="$why d = $d: no sweep run at $vb + $k x 25 m/s;"
        done
        why="$why$(compare "$d")"
    done
    sed -e 's/^rule = adhesion$/rule = table/' -e "s|^alpha_adh = .*|table = $RUN8/vcrit.csv|" "$BASE" >"$T/spray8.ini"
    "$BIN" check "$T/spray8.ini" >"$T/check8.log" 2>&1 || why="$why table unreadable: $(head -n 1 "$T/check8.log");"
    # the highest bonded sweep run of 8 um recorded as rebounded instead, then the same search replayed
    vb=$(awk -F, 'NR > 1 && $1 + 0 == 8e-6 { print $8 }' "$RUN8/vcrit.csv")
    awk -F, -v OFS=, -v v="$vb" '$1 + 0 == 8e-6 && $2 + 0 == v + 75 { $5 = 0 } { print }' "$RUN8/vcrit_runs.csv" \
        >"$T/runs8.csv" && mv "$T/runs8.csv" "$RUN8/vcrit_runs.csv"
    rm -f "$RUN8/vcrit.h5"
    if "$BIN" vcrit "$T/logistic.ini" -o "$RUN8" >"$T/logistic2.log" 2>&1; then
        grep -q '(0 runs in this process' "$T/logistic2.log" || why="$why the replay ran again;"
        why="$why$(compare 8e-06)"
        [ "$(refit "$RUN8/vcrit_cor.csv" 8e-06 | cut -d' ' -f2)" = overlapping ] ||
            why="$why the rewritten outcomes do not overlap: $(refit "$RUN8/vcrit_cor.csv" 8e-06);"
        grep -q 'not monotone in speed: logistic 10-90 % width' "$T/logistic2.log" || why="$why no width in the log;"
        # 8 um now fitted, 10 um still separable: the report tells them apart
        "$BIN" render "$T/logistic.ini" -o "$RUN8" >"$T/logistic2_render.log" 2>&1 || why="$why render failed;"
        why="$why$(separable "$RUN8")"
        [ "$(grep -c '^[0-9].*,nan,nan,' "$RUN8/vcrit.csv")" -eq 1 ] || why="$why not one row separable, one fitted;"
    else
        why="$why the replay failed: $(tail -n 2 "$T/logistic2.log" | tr '\n' ' ');"
    fi
else
    why="$why the search failed: $(tail -n 2 "$T/logistic1.log" | tr '\n' ' ');"
fi
if [ -z "$why" ]; then pass vcrit_logistic_fit; else fail vcrit_logistic_fit "$why"; fi

# ---- 4e. method = logistic whose fit puts its 50 % point beyond every speed run (outcomes that barely rise: every
# run bonded but v_low's): an extrapolation the table must not take.  The records of a search (a first search of
# 2 bisection runs gives the file its header) are rewritten with outcomes for every speed the bisection and the
# sweep will ask for, so the search replays them without a run; v_crit must be the bisection's, with the note -----
# crafted_records FROM OUT SPEED:VERDICT...: a record of 10 um runs at those speeds with those verdicts (0 rebounded,
# 1 bonded, 2 unsettled) under the header lines of the records file FROM (its case hash and build)
crafted_records() {
    from=$1 out=$2
    shift 2
    { head -n 2 "$from"
      for run in "$@"; do
          echo "1e-05,${run%:*},720,200000000000,${run#*:},0.3,0.1,0.0001,100,0"
      done; } >"$out"
}
RUN9=$T/beyond
{ cat tests/fixtures/vcrit_tiny.ini; printf '\n[vcrit]\ndiameters = 10e-6\nv_low = 200\nv_high = 1200\ntolerance = 25\n'
  printf 'method = logistic\nsweep_step = 25\nsweep_count = 3\n'; } >"$T/beyond.ini"
why=""
if { cat "$T/beyond.ini"; echo "max_runs = 2"; } >"$T/beyond2.ini" && "$BIN" vcrit "$T/beyond2.ini" -o "$RUN9" >"$T/beyond1.log" 2>&1; then
    # the bisection from 200 (rebounded) and 1200 (bonded), every midpoint bonded: 700, 450, 325, 262.5, 231.25,
    # 215.625 (then within 25 m/s of 200); the sweep 215.625 +- 25, 50, 75
    crafted_records "$RUN9/vcrit_runs.csv" "$T/beyond_runs.csv" 200:0 1200:1 700:1 450:1 325:1 262.5:1 231.25:1 \
        215.625:1 140.625:1 165.625:1 190.625:1 240.625:1 265.625:1 290.625:1
    mv "$T/beyond_runs.csv" "$RUN9/vcrit_runs.csv"
    rm -f "$RUN9/vcrit.h5"
    if "$BIN" vcrit "$T/beyond.ini" -o "$RUN9" >"$T/beyond2.log" 2>&1; then
        grep -q '(0 runs in this process' "$T/beyond2.log" || why="$why the crafted records were not all reused;"
        got=$(awk -F, 'NR == 2 { print $2 "," $6 "," $8 }' "$RUN9/vcrit.csv")
        [ "$got" = "215.625,nan,215.625" ] || why="$why v_crit, v_crit_se, v_bisection: $got, not 215.625,nan,215.625;"
        grep -q 'logistic 50 % point .* beyond the speeds run (140.625-1200 m/s): v_crit is the bisection' "$T/beyond2.log" ||
            why="$why no note of the 50 % point beyond the runs;"
    else
        why="$why the replay failed: $(tail -n 2 "$T/beyond2.log" | tr '\n' ' ');"
    fi
else
    why="$why the first search failed: $(tail -n 2 "$T/beyond1.log" | tr '\n' ' ');"
fi
if [ -z "$why" ]; then pass vcrit_logistic_beyond_runs; else fail vcrit_logistic_beyond_runs "$why"; fi

# the same set-up with every failure unsettled (verdict 2: left out of the fit, which then has no failure): the
# bisection's v_crit (it counts them as failures), with a note that names the cause.  Bisection: 700 bonded, 450
# unsettled, 575 bonded, 512.5 unsettled, 543.75 bonded, 528.125 unsettled; sweep 543.75 +- 25, 50, 75
why=""
if [ -s "$RUN9/vcrit_runs.csv" ]; then
    crafted_records "$RUN9/vcrit_runs.csv" "$T/one_sided_runs.csv" 200:2 1200:1 700:1 450:2 575:1 512.5:2 543.75:1 \
        528.125:2 468.75:2 493.75:2 518.75:2 568.75:1 593.75:1 618.75:1
    mkdir -p "$T/one_sided" && mv "$T/one_sided_runs.csv" "$T/one_sided/vcrit_runs.csv"
    if "$BIN" vcrit "$T/beyond.ini" -o "$T/one_sided" >"$T/one_sided.log" 2>&1; then
        grep -q '(0 runs in this process' "$T/one_sided.log" || why="$why the crafted records were not all reused;"
        got=$(awk -F, 'NR == 2 { print $1 "," $2 "," $8 }' "$T/one_sided/vcrit.csv")
        [ "$got" = "1e-05,543.75,543.75" ] || why="$why diameter, v_crit, v_bisection: $got, not 1e-05,543.75,543.75;"
        grep -q 'no logistic fit: no settled run failed' "$T/one_sided.log" || why="$why no note naming the cause;"
    else
        why="$why the search failed: $(tail -n 2 "$T/one_sided.log" | tr '\n' ' ');"
    fi
else
    why="$why no records from the first search;"
fi
if [ -z "$why" ]; then pass vcrit_logistic_no_settled_failure; else fail vcrit_logistic_no_settled_failure "$why"; fi

# ---- 5. no bracket: v_high too low to bond -----------------------------------------------------------------------
write_case "$T/nobracket.ini" 300
if "$BIN" vcrit "$T/nobracket.ini" -o "$T/nob" >"$T/nob.log" 2>&1 &&
    [ "$(grep -c '^# .*,nan,.*not bracketed: rebounds still at v_high' "$T/nob/vcrit.csv")" -eq 2 ] &&
    "$BIN" info "$T/nob" 2>&1 | grep -q 'not bracketed' &&
    "$BIN" render "$T/nobracket.ini" -o "$T/nob" >"$T/nob_render.log" 2>&1 &&
    grep -q '<b>Critical velocity: 0 of 2 searches bracketed a v_crit</b>' "$T/nob/report.html" &&
    [ "$(grep -c '<li>d = [0-9.]* µm: not bracketed: rebounds still at v_high' "$T/nob/report.html")" -eq 2 ]; then
    pass vcrit_not_bracketed
else
    fail vcrit_not_bracketed "$(tr '\n' ' ' <"$T/nob/vcrit.csv" 2>/dev/null) $(tail -n 2 "$T/nob.log" | tr '\n' ' ')"
fi
# ---- 5b. a table with a diameter that was not bracketed: the spray reads the rest and says what it does for that
# size (it interpolates or clamps the others' v_crit, silently before): 5 um does not bond up to 850 m/s here, 8 um does
write_case "$T/gap.ini" 850
sed -i 's/^diameters = .*/diameters = 5e-6,8e-6/' "$T/gap.ini"
why=""
if "$BIN" vcrit "$T/gap.ini" -o "$T/gap" >"$T/gap.log" 2>&1 &&
    grep -q '^# 5e-06,nan,.*not bracketed' "$T/gap/vcrit.csv" && grep -q '^8e-06,' "$T/gap/vcrit.csv"; then
    for file in vcrit.csv vcrit.h5; do
        sed -e 's/^rule = adhesion$/rule = table/' -e "s|^alpha_adh = .*|table = $T/gap/$file|" "$BASE" >"$T/gap_spray.ini"
        "$BIN" check "$T/gap_spray.ini" >"$T/gap_check.log" 2>&1 || why="$why check of $file failed;"
        grep -q "table = $T/gap/$file: 1 diameter without a v_crit (first d = 5e-06 m: not bracketed: rebounds still at v_high" \
            "$T/gap_check.log" || why="$why $file: no warning of the diameter without a v_crit;"
    done
else
    why="the search did not give one bracketed and one unbracketed diameter: $(tr '\n' ' ' <"$T/gap/vcrit.csv" 2>/dev/null)"
fi
if [ -z "$why" ]; then pass vcrit_table_gap_warned; else fail vcrit_table_gap_warned "$why"; fi

# ---- 6. reference_diameter: every run is [impact] scaled to its diameter.  With PTW's rate dependence removed and
# a rate-free strain bonding law, a particle twice the size on a grid twice as coarse is the same impact (geometric
# similarity, tests/test_similarity.c): the two diameters' searches must make the same runs with the same outcomes
sed -e '/^bonding = /d' -e 's/^diameters = .*/diameters = 8e-6,16e-6\nreference_diameter = 8e-6/' \
    -e 's/^t_end = .*/t_end = 10e-9\nbonding = strain\neps_c = 0.4\neps_rate_c = 1e5/' \
    -e 's/^\[material.aluminium\]$/[material.aluminium]\nptw_kappa = 0\nptw_y2 = 0\nptw_beta = 0/' "$CASE" >"$T/similar.ini"
why=""
if "$BIN" vcrit "$T/similar.ini" -o "$T/similar" >"$T/similar.log" 2>&1; then
    # the records without their first column (diameter), per diameter, in the order of the search
    small=$(grep '^8e-06,' "$T/similar/vcrit_runs.csv" | cut -d, -f2-)
    large=$(grep '^1.6e-05,' "$T/similar/vcrit_runs.csv" | cut -d, -f2-)
    [ -n "$small" ] || why="$why no runs of 8 um recorded;"
    [ "$small" = "$large" ] || why="$why the runs differ: 8 um [$(echo $small)] 16 um [$(echo $large)];"
    [ "$(grep '^8e-06,' "$T/similar/vcrit.csv" | cut -d, -f2-)" = "$(grep '^1.6e-05,' "$T/similar/vcrit.csv" | cut -d, -f2-)" ] ||
        why="$why the rows differ: $(sed 1d "$T/similar/vcrit.csv" | tr '\n' ' ');"
else
    why="$why the search failed: $(tail -n 2 "$T/similar.log" | tr '\n' ' ');"
fi
if [ -z "$why" ]; then pass vcrit_reference_diameter_similar; else fail vcrit_reference_diameter_similar "$why"; fi
sed 's/^reference_diameter = .*/reference_diameter = 0/' "$T/similar.ini" >"$T/unscaled.ini"
if "$BIN" vcrit "$T/unscaled.ini" -o "$T/unscaled" >"$T/unscaled.log" 2>&1 &&
    [ "$(grep '^8e-06,' "$T/unscaled/vcrit_runs.csv" | cut -d, -f2-)" = "$(grep '^1.6e-05,' "$T/unscaled/vcrit_runs.csv" | cut -d, -f2-)" ]; then
    fail vcrit_reference_diameter_matters "without reference_diameter the two sizes gave the same runs too: the check above cannot fail"
else
    pass vcrit_reference_diameter_matters
fi
# ---- 7. a rigid substrate (no substrate body, substrate_scale 0 as allowed): `check` passes and the search runs
# (the substrate's size, infinite without a body, was checked against 1 m and every rigid case refused)
sed -e '/^substrate_diameter = /d' -e '/^substrate_height = /d' -e 's/^grid = 2e-6$/grid = 2e-6\nsubstrate = rigid/' \
    -e 's/^diameters = .*/diameters = 8e-6/' "$CASE" >"$T/rigid.ini"
"$BIN" check "$T/rigid.ini" >"$T/rigid_check.log" 2>&1
checked=$?
"$BIN" vcrit "$T/rigid.ini" -o "$T/rigid" >"$T/rigid.log" 2>&1
searched=$?
if [ $checked -eq 0 ] && [ $searched -eq 0 ] && [ -r "$T/rigid/vcrit.h5" ] && grep -q '^#* *8e-06,' "$T/rigid/vcrit.csv"; then
    pass vcrit_rigid_substrate
else
    fail vcrit_rigid_substrate "check exit $checked, vcrit exit $searched: $(tail -n 1 "$T/rigid_check.log") $(tail -n 1 "$T/rigid.log")"
fi

# ---- 7b. at an angle: the spray's table rule compares the normal component of a particle's velocity with v_crit,
# so a search whose runs fly at 45 degrees from the normal writes v_crit as cos 45 times the lowest bonding speed of
# its bisection (from vcrit_runs.csv, which keeps the speeds), and vcrit_cor.csv the runs' normal components; the
# speed itself in the table needed a particle sqrt(2) times faster in the spray ----------------------------------
cat tests/fixtures/vcrit_tiny.ini - >"$T/angle.ini" <<EOF

[vcrit]
diameters = 10e-6
v_low = 200
v_high = 1600
tolerance = 200
EOF
sed -i 's/^bonding = energy$/bonding = energy\nangle = 45/' "$T/angle.ini"
if "$BIN" vcrit "$T/angle.ini" -o "$T/angle" >"$T/angle.log" 2>&1; then
    why=$(awk -F, 'BEGIN { c = cos(atan2(1, 1)) }
        FILENAME ~ /vcrit_runs/ && /^[0-9]/ { speed[++n] = $2; if ($5 == 1 && (low == "" || $2 < low)) low = $2 }
        FILENAME ~ /vcrit_cor/ && FNR > 1 { cor[++m] = $2 }
        FILENAME ~ /vcrit.csv/ && FNR == 2 { table = $2 }
        END {
            if (low == "" || (table - c * low) ^ 2 > 1e-18 * table * table)
                printf "v_crit %s, cos 45 x the lowest bonding speed %s = %.17g; ", table, low, c * low
            for (i = 1; i <= n; i++) { found = 0
                for (j = 1; j <= m; j++) found += (cor[j] - c * speed[i]) ^ 2 <= 1e-18 * speed[i] * speed[i]
                if (found != 1) printf "run at %s m/s: not once at %.17g in vcrit_cor.csv; ", speed[i], c * speed[i] }
            if (n < 3 || n != m) printf "%d runs, %d rows of vcrit_cor.csv; ", n, m
        }' "$T/angle/vcrit_runs.csv" "$T/angle/vcrit_cor.csv" "$T/angle/vcrit.csv")
    angle=$(h5dump -a /impact_angle "$T/angle/vcrit.h5" 2>/dev/null | sed -n 's/^ *(0): *//p')
    [ "$angle" = 45 ] || why="$why vcrit.h5 impact_angle '$angle';"
    if [ -z "$why" ]; then pass vcrit_angle_normal_component; else fail vcrit_angle_normal_component "$why"; fi
else
    fail vcrit_angle_normal_component "exit $?: $(tail -n 1 "$T/angle.log")"
fi

# ---- 7c. a table v_crit(d, T) with a temperature none of whose pairs was bracketed (hot particles that bond
# already at v_low): its rows alone fill the smaller grid of the other temperature, and the spray read it as if
# 850 K had not been asked for (its particles took the 298 K v_crit).  Both formats are refused, naming the pair ----
cat tests/fixtures/vcrit_tiny.ini - >"$T/hot.ini" <<EOF

[vcrit]
diameters = 8 um,10e-6
temperatures = 298,850
v_low = 750
v_high = 1200
tolerance = 200
EOF
# the report's table has the temperature of each row, and names the pairs not bracketed (it showed two rows of the
# same diameter with nothing to tell them apart, and left the others out without a word)
why=""
if "$BIN" vcrit "$T/hot.ini" -o "$T/hot" >"$T/hot.log" 2>&1 && "$BIN" render "$T/hot.ini" -o "$T/hot" >"$T/hot_render.log" 2>&1; then
    grep -q '<th>temperature (K)</th>' "$T/hot/report.html" || why="no temperature column;"
    [ "$(grep -c '<li>d = [0-9.]* µm, T = 850 K: not bracketed' "$T/hot/report.html")" -eq 2 ] ||
        why="$why the pairs at 850 K not named as not bracketed;"
    grep -q '<b>Critical velocity: 2 of 4 searches bracketed a v_crit</b>' "$T/hot/report.html" || why="$why no headline;"
    grep -q 'v_crit: the upper end of a bracket at most 200 m/s wide' "$T/hot/report.html" || why="$why no resolution of v_crit;"
else
    why="the search or its render failed: $(tail -n 2 "$T/hot.log" "$T/hot_render.log" | tr '\n' ' ')"
fi
if [ -z "$why" ]; then pass vcrit_report_temperatures; else fail vcrit_report_temperatures "$why"; fi
if [ -s "$T/hot/vcrit.csv" ] && [ "$(grep -c '^# .*,850,nan,.*not bracketed' "$T/hot/vcrit.csv")" -eq 2 ]; then
    for file in vcrit.csv vcrit.h5; do
        sed -e 's/^rule = adhesion$/rule = table/' -e "s|^alpha_adh = .*|table = $T/hot/$file|" "$BASE" >"$T/hot_spray.ini"
        "$BIN" check "$T/hot_spray.ini" >"$T/hot_check.log" 2>&1
        status=$?
        if [ $status -eq 2 ] && grep -q "table = .*$file.*: d = 8e-06 m, T = 850 K has no v_crit" "$T/hot_check.log"; then
            pass "vcrit_table_unbracketed_temperature_${file#vcrit.}"
        else
            fail "vcrit_table_unbracketed_temperature_${file#vcrit.}" "check exit $status: $(tail -n 1 "$T/hot_check.log")"
        fi
    done
else
    fail vcrit_table_unbracketed_temperature "the search did not leave both 850 K pairs unbracketed: $(tail -n 1 "$T/hot.log")"
fi
# (its diameters carry a unit, "8 um", as a case key's value may; one of another dimension is refused, exit 2,
# naming the value and the unit expected)
sed 's/^diameters = 8 um,10e-6$/diameters = 8 s,10e-6/' "$T/hot.ini" >"$T/hot_s.ini"
"$BIN" check "$T/hot_s.ini" >"$T/hot_s.log" 2>&1
status=$?
if [ $status -eq 2 ] && grep -q "\[vcrit\] diameters = 8 s,10e-6: '8 s' is not allowed: .*\"s\".*\"m\"" "$T/hot_s.log"; then
    pass vcrit_list_units
else
    fail vcrit_list_units "exit $status: $(tail -n 1 "$T/hot_s.log")"
fi

# ---- 8. a record of the runs that cannot be read is an I/O error before any run (exit 3, naming it), never taken
# for a file without runs (then the next save replaced it with the new runs only): a folder in its place (a read
# error, EISDIR) and a link to itself (fopen fails, ELOOP) ----------------------------------------------------------
unreadable() { # unreadable NAME MAKE_COMMAND EXPECTED_REASON
    dir=$T/unreadable_$1
    cp -r "$RUN" "$dir"
    rm -f "$dir/vcrit.h5" "$dir/vcrit_runs.csv"
    (cd "$dir" && eval "$2")
    "$BIN" vcrit "$CASE" -o "$dir" >"$T/unreadable_$1.log" 2>&1
    status=$?
    if [ $status -eq 3 ] && grep -q "cannot read .*vcrit_runs.csv: $3" "$T/unreadable_$1.log" &&
        ! grep -q ": done, " "$T/unreadable_$1.log"; then
        pass "vcrit_unreadable_record_$1"
    else
        fail "vcrit_unreadable_record_$1" "exit $status: $(grep -c ': done, ' "$T/unreadable_$1.log") runs made; $(tail -n 1 "$T/unreadable_$1.log")"
    fi
}
unreadable folder "mkdir vcrit_runs.csv" "Is a directory"
unreadable link_loop "ln -s vcrit_runs.csv vcrit_runs.csv" "Too many levels of symbolic links"
exit 0
