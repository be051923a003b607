#!/usr/bin/env bash
# tools/score_sample_configs.sh OUTDIR [DYNAEVAL_CHECKOUT]
#
# Scores the bundled sample in nine configurations through the CLI (plus the demo and the library
# default) and writes OUTDIR/<config>.json and .txt (the printed table). Run it with two
# checkouts (e.g. a `git worktree` of an older commit as DYNAEVAL_CHECKOUT) and compare with
# `python tools/compare_results.py BEFORE AFTER`: the before/after check of a refactor
# (docs/architecture.md). LPIPS needs backbone weights: set TORCH_HOME to a cache holding them
# (random-weight files made by torchvision.models.alexnet(weights=None) are enough to compare
# two versions), else LPIPS is reported unavailable in both. Every run starts in OUTDIR, so
# `python -m` (which puts the working folder first on the import path) imports DYNAEVAL_CHECKOUT
# wherever the script is started from.
set -u
out=$1; mkdir -p "$out"; out=$(cd "$out" && pwd)
repo=$(cd "$(dirname "$0")/.." && pwd)
code=${2:-$repo}
py=${PYTHON:-python}
S=$repo/dynaeval/data/sample
run() { name=$1; shift
  (cd "$out" && PYTHONPATH=$code $py -m dynaeval "$@" -q -o "$out/$name.json" --overwrite > "$out/$name.txt" 2> "$out/$name.err")
  echo "$name rc=$?"; }
run boxes score $S/pred $S/gt --focus boxes:$S/boxes.json
run detector score $S/pred $S/gt
run motion score $S/pred $S/gt --focus motion --workers 2
run none score $S/pred $S/gt --focus none --no-masked
run nb score $S/pred $S/gt --focus boxes:$S/boxes.json --protocol nerfbaselines --no-temporal
run ns score $S/pred $S/gt --focus motion --protocol nerfstudio --no-temporal
run ort score $S/pred $S/gt --focus boxes:$S/boxes.json --lpips-backend onnxruntime --quantize round --flow farneback
run nolp score $S/pred $S/gt --no-lpips --no-presence
run vgg score $S/pred $S/gt --focus none --lpips-net vgg --no-temporal
(cd "$out" && PYTHONPATH=$code $py -m dynaeval demo -q -o "$out/demo.json" > "$out/demo.txt" 2> "$out/demo.err"; echo "demo rc=$?")
