#!/bin/sh
# The README is the user's manual: every case key the program accepts and every command it offers must be
# documented there.
set -u
bin=${SPRAYCOAT_BIN:-build/spraycoat}
missing=0
for key in $("$bin" keys | sed -n 's/^| `\([a-zA-Z0-9_]*\)` |.*/\1/p'); do
    if ! grep -q "| \`$key\` |" README.md; then
        echo "  README lacks key $key"
        missing=$((missing + 1))
    fi
done
if [ "$missing" -eq 0 ]; then echo "PASS readme_keys"; else echo "FAIL readme_keys"; fi

missing=0
for command in $("$bin" --help | sed -n 's/^  spraycoat \([a-z]*\) .*/\1/p'); do
    if ! grep -q "spraycoat $command" README.md; then
        echo "  README lacks command $command"
        missing=$((missing + 1))
    fi
done
if [ "$missing" -eq 0 ]; then echo "PASS readme_commands"; else echo "FAIL readme_commands"; fi

# the generated tables must match the program exactly (defaults, ranges, units)
"$bin" keys | sed 's/^### \[/#### [/' > /tmp/spraycoat-keys.$$
if grep -qxFf /tmp/spraycoat-keys.$$ README.md && [ "$(grep -cxFf /tmp/spraycoat-keys.$$ README.md)" -ge "$(grep -c '^| `' /tmp/spraycoat-keys.$$)" ]; then
    echo "PASS readme_key_tables_current"
else
    echo "FAIL readme_key_tables_current (regenerate the tables with: spraycoat keys)"
fi
rm -f /tmp/spraycoat-keys.$$
