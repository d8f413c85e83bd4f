#!/bin/sh
# report.html of a pipeline run states the result (issue 23): a small pipeline of two impact runs of two particle
# bodies each; the page is parsed (python3, html.parser) and must have a headline naming the deposit fraction, the
# bonded fraction with its criterion, the coating thickness, the couple stage and the resolution; one results row
# per particle body of impact.h5 (bodies of every run), none "rebounded" without a v_rest; every <img src> a file that exists; and, in headless
# Chromium, every image loads.  Prints "PASS name" / "FAIL name: why".  Run from the repo root.
set -u
bin=${SPRAYCOAT_BIN:-build/spraycoat}
T=$(mktemp -d) || { echo "FAIL report_setup: mktemp -d failed"; exit 1; }
trap 'rm -rf "$T"' EXIT
trap 'exit 130' INT
trap 'exit 143' TERM
. tests/pipeline_lib.sh

if [ ! -x "$bin" ]; then
    echo "FAIL report_setup: no executable $bin (SPRAYCOAT_BIN)"
    exit 1
fi
if ! command -v python3 >/dev/null 2>&1; then
    echo "FAIL report_setup: python3 is not installed"
    exit 1
fi

# tests/fixtures/pipeline_small.ini with two runs of two bodies (spread over a 6 um patch: the fixture's 20 um
# substrate holds sqrt(2) 6 + 10 um) and a shorter spray
sed -e 's/^runs = 4$/runs = 2/' -e 's/^bodies_per_run = 1$/bodies_per_run = 2\npatch_size = 6e-6/' \
    -e 's/^t_end = 4e-9$/t_end = 3e-9/' tests/fixtures/pipeline_small.ini >"$T/case.ini"
if ! "$bin" run "$T/case.ini" -o "$T/run" -q >"$T/out" 2>&1; then
    echo "FAIL report_pipeline: the pipeline failed: $(tail -c 400 "$T/out")"
    exit 1
fi
page="$T/run/report.html"

# particle bodies of impact.h5: substrate == 0 in every /run_NNNN/summary (or the single run's /summary)
bodies=0
groups=$(h5ls "$T/run/impact.h5" | awk '/^run_[0-9]+ / { print "/" $1 }')
[ -n "$groups" ] || groups=""
for g in ${groups:-""}; do
    n=$(values "$T/run/impact.h5" "$g/summary/substrate" | grep -c '^0$')
    bodies=$((bodies + n))
done

# the stage's /summary means over all particle bodies: mean_pbcp and mean_bonded_interface against the runs' rows,
# on the impact stage run again with eps_c 0.05 (bonds in 3 ns: PBCP and bonded interface between 0 and 1)
cp -r "$T/run" "$T/means"
sed 's/^\[impact\]$/[impact]\neps_c = 0.05/' "$T/case.ini" >"$T/means.ini"
if ! "$bin" run "$T/means.ini" -o "$T/means" --stages impact -q >"$T/means_out" 2>&1; then
    echo "FAIL impact_summary_means: the impact stage with eps_c 0.05 failed: $(tail -c 300 "$T/means_out")"
else
    for field in pbcp bonded_interface; do
        for g in $groups; do
            values "$T/means/impact.h5" "$g/summary/substrate" >"$T/sub"
            values "$T/means/impact.h5" "$g/summary/$field" >"$T/col"
            paste "$T/sub" "$T/col"
        done >"$T/rows_$field"
        mean=$(h5dump -m '%.17g' -a "/summary/mean_$field" "$T/means/impact.h5" 2>/dev/null | sed -n 's/^ *(0): *//p')
        if awk -v m="$mean" '$1 == 0 { s += $2; n++; some += $2 > 0 }
            END { exit !(n == 4 && some > 0 && m != "" && (s / n - m) ^ 2 <= 1e-24) }' "$T/rows_$field"; then
            echo "PASS impact_summary_mean_$field"
        else
            echo "FAIL impact_summary_mean_$field: /summary mean_$field '$mean' is not the mean of the 4 particles' rows, not all 0 ($(tr '\n\t' '; ' <"$T/rows_$field"))"
        fi
    done
fi

# the means of v_rest and CoR are over the settled particles only (an unsettled one's are still changing), per run
# (run_v_rest, run_cor: NaN for a run with none settled) and overall (mean_v_rest, mean_cor), recomputed here from
# the runs' rows.  settle_vcom 1e4 and a 2 ns window let verdicts settle within 5 ns (a particle still in flight
# among them: the check is of the arithmetic, not the physics); the run must mix settled and unsettled particles
# with finite v_rest, or the check could not tell the two means apart.
cp -r "$T/run" "$T/settled"
sed -e 's/^\[impact\]$/[impact]\neps_c = 0.05\nsettle_window = 2e-9\nsettle_vcom = 1e4\nsettle_pbcp = 1/' \
    -e 's/^t_end = 3e-9$/t_end = 5e-9/' "$T/case.ini" >"$T/settled.ini"
if ! "$bin" run "$T/settled.ini" -o "$T/settled" --stages impact -q >"$T/settled_out" 2>&1; then
    echo "FAIL impact_summary_settled_means: the impact stage failed: $(tail -c 300 "$T/settled_out")"
else
    r=0
    for g in $groups; do
        for field in substrate verdict v_rest cor; do
            values "$T/settled/impact.h5" "$g/summary/$field" >"$T/col_$field"
        done
        paste "$T/col_substrate" "$T/col_verdict" "$T/col_v_rest" "$T/col_cor" | sed "s/^/$r\t/"
        r=$((r + 1))
    done >"$T/settled_rows"
    values "$T/settled/impact.h5" /summary/run_v_rest >"$T/run_v_rest"
    values "$T/settled/impact.h5" /summary/run_cor >"$T/run_cor"
    for name in mean_v_rest mean_cor; do
        h5dump -m '%.17g' -a "/summary/$name" "$T/settled/impact.h5" 2>/dev/null | sed -n 's/^ *(0): *//p' >"$T/$name"
    done
    # rows: run, substrate, verdict (2 unsettled), v_rest, cor; then the stored run means and overall means
    why=$(awk -v runs="$r" -v vfile="$T/run_v_rest" -v cfile="$T/run_cor" -v mv="$(cat "$T/mean_v_rest")" \
        -v mc="$(cat "$T/mean_cor")" '
        function same(a, b) { return (a == "nan" && b == "nan") || (a != "nan" && b != "nan" && (a - b) ^ 2 <= 1e-24 * (1 + b * b)) }
        function mean(s, n) { return n ? s / n : "nan" }
        $2 == 0 { if ($3 == 2) { open_ += $4 != "nan" } else { sv[$1] += $4; sc[$1] += $5; n[$1]++; SV += $4; SC += $5; N++ } }
        END {
            for (k = 0; k < runs; k++) {
                getline v < vfile; getline c < cfile
                if (!same(v, mean(sv[k], n[k])) || !same(c, mean(sc[k], n[k])))
                    printf "run %d: run_v_rest %s, run_cor %s, its settled rows give %s, %s; ", k, v, c, mean(sv[k], n[k]), mean(sc[k], n[k])
            }
            if (!same(mv, mean(SV, N)) || !same(mc, mean(SC, N)))
                printf "mean_v_rest %s, mean_cor %s, the settled rows give %s, %s; ", mv, mc, mean(SV, N), mean(SC, N)
            if (N == 0 || open_ == 0)
                printf "%d settled and %d unsettled particles with a v_rest: not a mix; ", N, open_
        }' "$T/settled_rows")
    if [ -z "$why" ]; then
        echo "PASS impact_summary_settled_means"
    else
        echo "FAIL impact_summary_settled_means: $why($(tr '\n\t' '; ' <"$T/settled_rows"))"
    fi
fi

# particles off the resolution the shipped bonding parameters belong to (2 points per cell edge here, 3 there): the
# stage counts them, the report and the run's closing summary say their verdicts are not calibrated (`spraycoat info`
# lists the count); with the case's own
# eps_c none is judged (-1)
attr() { h5dump -a "/summary/$2" "$1" 2>/dev/null | sed -n 's/^ *(0): *//p'; }
uncalibrated=$(attr "$T/run/impact.h5" uncalibrated_bodies) own=$(attr "$T/means/impact.h5" uncalibrated_bodies)
if [ "$uncalibrated" = "$bodies" ] && [ "$own" = -1 ] &&
    grep -q "$bodies of the $bodies particles ran at another resolution: their verdicts below are not calibrated" "$page" &&
    grep -q "$bodies of the $bodies bodies ran at a resolution their bonding parameters were not calibrated at" "$T/out" &&
    "$bin" info "$T/run" | grep -q "uncalibrated_bodies  *$bodies\$"; then
    echo "PASS uncalibrated_resolution_said"
else
    echo "FAIL uncalibrated_resolution_said: /summary uncalibrated_bodies '$uncalibrated' of $bodies (own parameters: '$own'), or the report or info does not say it"
fi

python3 - "$page" "$bodies" >"$T/parsed" 2>&1 <<'PY'
import os, sys
from html.parser import HTMLParser

page, bodies = sys.argv[1], int(sys.argv[2])

class Page(HTMLParser):
    def __init__(self):
        super().__init__()
        self.stack, self.headline, self.rows, self.imgs = [], "", 0, []
        self.in_headline = 0
        self.in_results = 0
        self.cells, self.row, self.in_cell = [], None, 0
        self.row_classes = []

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "img":
            self.imgs.append(a.get("src", ""))
        if a.get("id") == "headline":
            self.in_headline = 1
            self.stack.append(("headline", tag))
        elif a.get("id") == "impact-results":
            self.in_results = 1
            self.stack.append(("results", tag))
        elif self.stack and tag == self.stack[-1][1] and tag not in ("img", "br", "meta"):
            self.stack.append(("", tag))
        if self.in_results and tag == "tr" and "body" in (a.get("class") or "").split():
            self.rows += 1
            self.row = []
            self.cells.append(self.row)
            self.row_classes.append((a.get("class") or "").split())
        if self.row is not None and tag == "td":
            self.in_cell = 1
            self.row.append("")

    def handle_endtag(self, tag):
        if tag == "td":
            self.in_cell = 0
        if tag == "tr":
            self.row = None
        if self.stack and self.stack[-1][1] == tag:
            kind, _ = self.stack.pop()
            if kind == "headline":
                self.in_headline = 0
            if kind == "results":
                self.in_results = 0

    def handle_data(self, data):
        if self.in_headline:
            self.headline += data
        if self.in_cell and self.row is not None:
            self.row[-1] += data

p = Page()
with open(page, encoding="utf-8") as f:
    p.feed(f.read())
fails = []
head = " ".join(p.headline.split()).lower()
if not head:
    fails.append("no headline (an element with id=headline)")
for word in ("deposit fraction", "bonded", "pbcp", "v_rest", "thickness", "couple", "grid", "spacing"):
    if word not in head:
        fails.append("the headline does not say '%s'" % word)
# the resolution the bonding model's shipped parameters belong to, next to the run's (issue 22, item 9)
import re
model = re.search(r"bonding = (\w+)", head)
belongs = {"strain": "10 grid cells across", "energy": "2.0 µm with points 0.667 µm"}
if not model or model.group(1) not in belongs:
    fails.append("the headline does not name the bonding model ([impact] bonding = ...)")
elif belongs[model.group(1)] not in head or "belong to" not in head:
    fails.append("the headline does not say the %s model's parameters belong to %s" % (model.group(1),
                 belongs[model.group(1)]))
if p.rows == 0:
    fails.append("the results table (id=impact-results) has no body rows")
elif p.rows != bodies:
    fails.append("the results table has %d body rows, impact.h5 %d particle bodies" % (p.rows, bodies))
# columns: run, body, diameter, points across d, speed, verdict, spray said, PBCP, bonded interface, v_rest, CoR
def percent(text):
    try:
        value = float(text)
    except ValueError:
        return None
    return value if 0.0 <= value <= 100.0 else None
for row in p.cells:
    if len(row) != 11:
        fails.append("a body row has %d cells, not 11: %s" % (len(row), row))
    elif percent(row[7].strip()) is None or percent(row[8].strip()) is None:
        fails.append("a body row's PBCP or bonded interface is not a percentage: %s" % row)
    elif row[9].strip() == "n/a" and row[5].strip() == "rebounded":
        fails.append("a body without v_rest is called rebounded: %s" % row)
    elif row[1].strip() == "0":
        fails.append("the substrate (body 0) has a row: %s" % row)
# an unsettled particle's numbers are the last values, not a result: its row, and only its, is marked so
for row, classes in zip(p.cells, p.row_classes):
    if len(row) == 11 and (row[5].strip() == "unsettled") != ("unsettled" in classes):
        fails.append("a row's verdict is '%s' but its classes are %s" % (row[5].strip(), classes))
base = os.path.dirname(page)
missing = [s for s in p.imgs if not os.path.isfile(os.path.join(base, s))]
if not p.imgs:
    fails.append("no images")
if missing:
    fails.append("missing image files: %s" % " ".join(missing[:5]))
print("; ".join(fails) if fails else "ok %d rows, %d images" % (p.rows, len(p.imgs)))
PY
if [ "$bodies" -ge 2 ] && [ "$(cat "$T/parsed")" = "ok $bodies rows, $(grep -o '<img ' "$page" | wc -l) images" ]; then
    echo "PASS report_states_result"
else
    echo "FAIL report_states_result: ($bodies particle bodies in impact.h5) $(tail -c 600 "$T/parsed")"
fi

# the bonded fraction of a few sampled particles comes with its 95 % interval (Wilson), recomputed here from the
# counts the headline gives (4 particles: a bonded fraction of 0 or 100 % alone read as a certainty), the unsettled
# taken either way: Wilson's lower end of the bonded, its upper end of the bonded and the unsettled
text=$(sed 's/<[^>]*>//g' "$page" | tr '\n' ' ')
counts=$(printf '%s' "$text" | sed -n 's/.*bonded fraction [0-9.]* % (95 % interval \([0-9.]*\)-\([0-9.]*\) %, Wilson, for \([0-9]*\) particles\{0,1\}[^)]*): \([0-9]*\) of \([0-9]*\) sampled.*/\1 \2 \3 \4 \5/p')
unsettled=$(printf '%s' "$text" | sed -n 's/.*sampled particles\{0,1\} bonded in [0-9]* runs\{0,1\} ([^)]*\([0-9][0-9]*\) unsettled: the verdict.*/\1/p')
if [ -n "$counts" ] && echo "$counts" | awk -v u="${unsettled:-0}" '
        function wilson(k, n, side,   z, p, z2, c, h) { z = 1.959964; p = k / n; z2 = z * z
            c = (p + z2 / (2 * n)) / (1 + z2 / n); h = z / (1 + z2 / n) * sqrt(p * (1 - p) / n + z2 / (4 * n * n))
            return side < 0 ? 100 * (c - h < 0 ? 0 : c - h) : 100 * (c + h > 1 ? 1 : c + h) }
        { n = $5; k = $4; lo = wilson(k, n, -1); hi = wilson(k + u, n, 1)
        exit !($3 == n && (lo < 1e-9 ? $1 == 0 : ($1 / lo > 0.995 && $1 / lo < 1.005)) && $2 / hi > 0.995 && $2 / hi < 1.005) }'; then
    echo "PASS report_bonded_fraction_interval"
else
    echo "FAIL report_bonded_fraction_interval: '$counts' (interval low, high, particles, bonded, of), ${unsettled:-0} unsettled"
fi

# ---- headless Chromium: every image of the page loads ----
chromium_bin=$(command -v chromium || command -v chromium-browser || true)
if [ -z "$chromium_bin" ]; then
    echo "FAIL report_in_chromium: chromium is not installed (scripts/bootstrap installs it)"
else
    sed 's|</body>|<script>window.addEventListener("load", function () { var all = document.images, ok = 0; for (var i = 0; i < all.length; i++) if (all[i].complete \&\& all[i].naturalWidth > 0) ok++; document.title = "images " + all.length + " loaded " + ok; });</script></body>|' \
        "$page" >"$T/run/report_check.html"
    timeout 60 "$chromium_bin" --headless --no-sandbox --disable-gpu --disable-dev-shm-usage \
        --virtual-time-budget=5000 --dump-dom "file://$T/run/report_check.html" >"$T/dom" 2>"$T/chromium_err"
    status=$?
    counts=$(sed -n 's|.*<title>images \([0-9]*\) loaded \([0-9]*\)</title>.*|\1 \2|p' "$T/dom" | head -n 1)
    total=${counts% *}
    loaded=${counts#* }
    expected=$(grep -o '<img ' "$page" | wc -l)
    if [ "$status" -eq 0 ] && [ -n "$counts" ] && [ "$total" -eq "$expected" ] && [ "$loaded" -eq "$total" ] &&
        [ "$total" -ge 1 ]; then
        echo "PASS report_in_chromium"
    else
        echo "FAIL report_in_chromium: exit status $status, images/loaded '$counts', expected $expected;" \
            "$(tail -c 300 "$T/chromium_err")"
    fi
fi

# ---- a case that sets its own bonding parameters is told so, next to the resolution the shipped ones belong to ----
# (and one that runs its impacts with heat conduction is told that the calibration was made without it)
sed 's/^\[impact\]$/[impact]\neps_c = 2.6\nconduction = on/' "$T/case.ini" >"$T/own.ini"
if ! grep -q '^eps_c = 2.6$' "$T/own.ini"; then
    echo "FAIL report_own_bonding_parameters: the fixture has no [impact] section to set eps_c in"
elif ! "$bin" run "$T/own.ini" -o "$T/own" -q >"$T/own_out" 2>&1; then
    echo "FAIL report_own_bonding_parameters: the pipeline failed: $(tail -c 400 "$T/own_out")"
else
    own=$(tr '\n' ' ' <"$T/own/report.html")
    if printf '%s' "$own" | grep -q "case sets the bonding model's parameters (<code>\[impact\] bonding = strain</code>, eps_c = 2.6, eps_rate_c = 100000); the shipped ones belong to 10 grid cells across" &&
        ! grep -q "case sets the bonding model" "$page"; then
        echo "PASS report_own_bonding_parameters"
    else
        echo "FAIL report_own_bonding_parameters: the headline of a case with eps_c = 2.6 (or of the default case) misstates whose parameters the run used: $(printf '%s' "$own" | grep -o 'Resolution: [^<]*.\{0,400\}' | head -c 500)"
    fi
    if printf '%s' "$own" | grep -q 'the impacts ran with heat conduction (<code>\[impact\] conduction = on</code>), the calibration without it' &&
        ! grep -q 'heat conduction' "$page"; then
        echo "PASS report_conduction_named"
    else
        echo "FAIL report_conduction_named: the headline of a case with conduction = on (or of the default case) misstates it: $(printf '%s' "$own" | grep -o 'Resolution: [^<]*.\{0,500\}' | head -c 600)"
    fi
fi
# ...and one with conduction = on and the shipped parameters (eps_c = auto) is told it ran the calibration made with it
sed 's/^\[impact\]$/[impact]\nconduction = on/' "$T/case.ini" >"$T/cond.ini"
if ! "$bin" run "$T/cond.ini" -o "$T/cond" -q >"$T/cond_out" 2>&1; then
    echo "FAIL report_conduction_calibration: the pipeline failed: $(tail -c 400 "$T/cond_out")"
elif tr '\n' ' ' <"$T/cond/report.html" | grep -q "with heat conduction (<code>\[impact\] conduction = on</code>) the strain model's calibration made with it, eps_c = 2.506" &&
    ! tr '\n' ' ' <"$T/cond/report.html" | grep -q 'the calibration without it'; then
    echo "PASS report_conduction_calibration"
else
    echo "FAIL report_conduction_calibration: a case with conduction = on and eps_c = auto is not told it ran eps_c 2.506: $(tr '\n' ' ' <"$T/cond/report.html" | grep -o 'Resolution: [^<]*.\{0,500\}' | head -c 600)"
fi
