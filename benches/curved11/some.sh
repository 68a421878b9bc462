#!/bin/sh
# benches/curved11/some.sh: benches/defaults_table.sh for the scenes named in ONLY (kept for the commands the RESULTS
# sections cite; the table script itself filters on ONLY), e.g.
#   ONLY="milk-sphere marble-back" DEFAULTS_EXTRA="--upstream-beam curved" DEFAULTS_OUT=target/x sh benches/curved11/some.sh
DEFAULTS_OUT=${DEFAULTS_OUT:-target/curved11} exec sh benches/defaults_table.sh
