#!/bin/sh
# The generated documents are current: docs/keys.md is exactly `spraycoat keys`, and the man page spraycoat.1
# is exactly what scripts/make_man.sh makes from the program's help text (and renders without warnings).
# Regenerate both with `make docs`.
set -u
bin=${SPRAYCOAT_BIN:-build/spraycoat}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

"$bin" keys > "$tmp/keys.md"
if cmp -s "$tmp/keys.md" docs/keys.md; then
    echo "PASS keys_doc_current"
else
    diff docs/keys.md "$tmp/keys.md" | head -n 10 | sed 's/^/  /'
    echo "FAIL keys_doc_current (docs/keys.md is stale: regenerate it with \`make docs\`)"
fi

scripts/make_man.sh "$bin" > "$tmp/spraycoat.1"
if cmp -s "$tmp/spraycoat.1" spraycoat.1; then
    echo "PASS man_page_current"
else
    diff spraycoat.1 "$tmp/spraycoat.1" | head -n 10 | sed 's/^/  /'
    echo "FAIL man_page_current (spraycoat.1 is stale: regenerate it with \`make docs\`)"
fi

if command -v groff > /dev/null 2>&1; then
    if groff -man -Tascii -ww -z spraycoat.1 > "$tmp/groff.log" 2>&1 && [ ! -s "$tmp/groff.log" ]; then
        echo "PASS man_page_renders"
    else
        sed 's/^/  /' "$tmp/groff.log"
        echo "FAIL man_page_renders (groff -man -ww warns)"
    fi
else
    echo "SKIP man_page_renders (no groff)"
fi
