#!/bin/sh
# Peak memory of streaming a 24 h x 2 kHz record (1.728e8 samples, one axis, angle output) of
# the example model (Q, N, B, K, R; flicker through the streaming AR(1) bank + FIR) to .npy.
# Usage: sh benchmarks/sim_stream_memory.sh [OUTDIR]   (needs /usr/bin/time: apt-get install time)
set -e
OUT=${1:-/tmp}
PY=${PYTHON:-python}
$PY -c "from allanite.examples import example_model; example_model().save('$OUT/example_model.json')"
/usr/bin/time -v allanite simulate "$OUT/example_model.json" --fs 2000 --duration 24h \
    -o "$OUT/sim24h.npy" --output angle --seed 1 --quiet 2> "$OUT/sim24h.time"
grep -E "Maximum resident|Elapsed|User time|Exit" "$OUT/sim24h.time"
ls -l "$OUT/sim24h.npy"
