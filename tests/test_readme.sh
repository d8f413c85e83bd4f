#!/bin/sh
# The README is the user's manual: a short one (under 400 lines, no dated history), documenting every command
# the program offers, and pointing at the pages of docs/ that exist.  The keys are documented in docs/keys.md,
# which tests/test_keys_doc.sh checks is exactly `spraycoat keys`.
set -u
bin=${SPRAYCOAT_BIN:-build/spraycoat}

missing=0
for command in $("$bin" --help | sed -n 's/^  spraycoat \([a-z]*\) .*/\1/p'); do
    if ! grep -q "spraycoat $command" README.md; then
        echo "  README lacks command $command"
        missing=$((missing + 1))
    fi
done
if [ "$missing" -eq 0 ]; then echo "PASS readme_commands"; else echo "FAIL readme_commands"; fi

lines=$(wc -l < README.md)
if [ "$lines" -lt 400 ]; then echo "PASS readme_short ($lines lines)"; else echo "FAIL readme_short ($lines lines, at most 399)"; fi

# no dated history in the manual, the docs or BENCHMARKS.md (the history is in git)
if grep -nE '20[0-9]{2}-[0-9]{2}-[0-9]{2}' README.md BENCHMARKS.md docs/*.md; then
    echo "FAIL docs_undated (the lines above carry dates: keep the conclusion, drop the date)"
else
    echo "PASS docs_undated"
fi

# every docs/ page the README names exists, and the README names every page of docs/
missing=0
for page in $(grep -o 'docs/[a-z_]*\.md' README.md | sort -u); do
    if [ ! -f "$page" ]; then echo "  README names $page, which does not exist"; missing=$((missing + 1)); fi
done
for page in docs/*.md; do
    if ! grep -q "$page" README.md; then echo "  README does not name $page"; missing=$((missing + 1)); fi
done
if [ "$missing" -eq 0 ]; then echo "PASS readme_docs_pages"; else echo "FAIL readme_docs_pages"; fi

# every key of `spraycoat keys` is in docs/keys.md (tests/test_keys_doc.sh checks the whole text)
missing=0
for key in $("$bin" keys | sed -n 's/^| `\([a-zA-Z0-9_]*\)` |.*/\1/p'); do
    if ! grep -q "| \`$key\` |" docs/keys.md; then
        echo "  docs/keys.md lacks key $key"
        missing=$((missing + 1))
    fi
done
if [ "$missing" -eq 0 ]; then echo "PASS keys_documented"; else echo "FAIL keys_documented"; fi

# README steps 2 and 3 say what the program does: one empty section is a valid case, an empty file is refused
# (exit 2); a case with [impact] keys needs a [material.NAME] section for the default Al too, an empty
# [material.aluminium] being enough (the README said an empty file is a valid case, and [material.NAME] only for
# other materials than the default Al)
tmp=$(mktemp -d) || exit 1
trap 'rm -rf "$tmp"' EXIT
why=""
printf '[run]\n' >"$tmp/run.ini"
: >"$tmp/empty.ini"
printf '[impact]\nvelocity = 700\n' >"$tmp/impact.ini"
printf '[impact]\nvelocity = 700\n\n[material.aluminium]\n' >"$tmp/impact_al.ini"
"$bin" check "$tmp/run.ini" >/dev/null 2>&1 || why="$why a case of [run] alone is refused;"
"$bin" check "$tmp/empty.ini" >/dev/null 2>&1
[ $? -eq 2 ] || why="$why an empty file is not refused with exit status 2;"
"$bin" check "$tmp/impact.ini" >/dev/null 2>"$tmp/impact.err"
[ $? -eq 2 ] && grep -qF '[material.aluminium]' "$tmp/impact.err" ||
    why="$why [impact] without [material.aluminium] is not refused naming it;"
"$bin" check "$tmp/impact_al.ini" >/dev/null 2>&1 || why="$why [impact] with an empty [material.aluminium] is refused;"
tr '\n' ' ' <README.md | tr -s ' ' >"$tmp/readme.txt"
for said in 'one empty section (`[run]`) is a valid case' 'an empty file is refused' \
    'a `[material.NAME]` section for each material they name, the default Al'"'"'s too'; do
    grep -qF -- "$said" "$tmp/readme.txt" || why="$why README does not say \"$said\";"
done
grep -q 'empty file is a valid' "$tmp/readme.txt" && why="$why README calls an empty file a valid case;"
if [ -z "$why" ]; then echo "PASS readme_case_minimum"; else echo "FAIL readme_case_minimum ($why)"; fi
