#!/bin/bash
# sha256 of recordings of the five shipped scenes (seed 7; 60 s, the stress scene 30 s): run it
# before and after a change that must keep the stream byte-identical, and compare the outputs.
# Usage: benchmarks/recording_hashes.sh OUTDIR   (tables cached under $SHIPRADAR_TABLES)
set -u
out=${1:?give an output directory}
mkdir -p "$out"
cd "$(dirname "$0")/.."
for s in single_missile raid stress manoeuvres jammed_squall; do
  d=60; [ "$s" = stress ] && d=30
  .venv/bin/shipradar run "scenarios/$s.yaml" --seed 7 --duration $d --record "$out/$s.rec" \
    --overwrite --quiet >/dev/null 2>"$out/$s.err" || { echo "$s FAILED"; tail -3 "$out/$s.err"; }
  echo "$s $(sha256sum "$out/$s.rec" | cut -c1-16)"
done
