#!/bin/bash
# sha256 of recordings of the five shipped scenes (seed 7; 60 s, the stress scene 30 s): run it
# before and after a change that must keep the stream byte-identical, and compare the outputs
# (hashes hold for one install and CPU, printed first; across them compare recordings by value:
# shipradar recording compare).
# Usage: benchmarks/recording_hashes.sh OUTDIR   (tables cached under $SHIPRADAR_TABLES)
set -u
out=${1:?give an output directory}
mkdir -p "$out"
cd "$(dirname "$0")/.."
# the install and CPU the hashes hold for (README, "Reproducibility"): publish it with them
.venv/bin/python -c 'from tests.golden.cases import environment as e, installed_differences as d
print("#", "; ".join(f"{k} {v}" for k, v in e().items() if k != "lock_sha256"))
print("# lock", "as installed" if not d() else "NOT as installed: " + "; ".join(d()))'
for s in single_missile raid stress manoeuvres jammed_squall; do
  d=60; [ "$s" = stress ] && d=30
  .venv/bin/shipradar run "scenarios/$s.yaml" --seed 7 --duration $d --record "$out/$s.rec" \
    --overwrite --quiet >/dev/null 2>"$out/$s.err" || { echo "$s FAILED"; tail -3 "$out/$s.err"; }
  echo "$s $(sha256sum "$out/$s.rec" | cut -c1-16)"
done
