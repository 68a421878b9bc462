#!/bin/sh
# benches/milk10/some.sh: benches/defaults_table.sh for the scenes named in ONLY (kept for the commands the RESULTS
# sections cite; the table script itself filters on ONLY), e.g.
#   ONLY="milk-sphere marble-back" DEFAULTS_EXTRA="--upstream-beam curved" DEFAULTS_OUT=target/x sh benches/milk10/some.sh
DEFAULTS_OUT=${DEFAULTS_OUT:-target/milk10/some} exec sh benches/defaults_table.sh
