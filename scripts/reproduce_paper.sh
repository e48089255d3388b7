#!/usr/bin/env bash
# Trains and evaluates every experiment of the paper's Tables 1 and 2 on the
# embedded default world at the reproduction scale (configs/vln/
# reproduction.yaml; one config per run under configs/experiments/), then
# writes docs/results.md (and .tex) with our numbers beside the paper's.
#
#   scripts/reproduce_paper.sh            # everything, in the order below
#   scripts/reproduce_paper.sh cma seq2seq_da ...   # only these runs
#
# Runs go to runs/experiments/<name>/, evaluations (the checkpoint chosen on
# val_unseen SPL, on all of val_seen and val_unseen) to
# results/paper/<name>/ with a run.json naming the config and the command;
# the tables go to results/paper/tables.md and into docs/results.md. Every
# run is also scored on the nav-graph (paper Table 3).
# Finished runs and evaluations are skipped and interrupted ones resume, so
# the script can be stopped and restarted at any time; the tables are
# rebuilt from whatever has finished (missing rows say so). About 1-8
# minutes per run on 2 cores (docs/results.md gives the measured times).
# Environment: VLN_BUILD_DIR (build), VLN_EVAL_EPISODES (-1: all).
set -euo pipefail
cd "$(dirname "$0")/.."
vln_bin=${VLN_BUILD_DIR:-build}/bin
source scripts/common.sh

vln_stamp "setup"
scripts/setup.sh
vln_ensure_world
vln_ensure_encoders

episodes=${VLN_EVAL_EPISODES:--1}
results=results/paper
s2s='"model": "Seq2Seq"'
cma='"model": "Cross-Modal Attention"'
full='"vision": "RGBD", "instruction": true, "history": true'

# name -> run.json fields (without the checkpoint); the order is the
# order of importance, DA* runs after the runs they fine-tune
declare -A fields=(
  [seq2seq]="$s2s, \"rows\": [{\"table\": 1, \"row\": \"Seq2Seq\"}, {\"table\": 2, \"row\": \"1\"}], $full, \"pm\": false, \"da\": \"none\", \"aug\": false"
  [cma]="$cma, \"rows\": [{\"table\": 2, \"row\": \"6\"}], $full, \"pm\": false, \"da\": \"none\", \"aug\": false"
  [seq2seq_no_vision]="$s2s, \"rows\": [{\"table\": 1, \"row\": \"No Vision\"}], \"vision\": \"-\", \"instruction\": true, \"history\": true"
  [seq2seq_no_instruction]="$s2s, \"rows\": [{\"table\": 1, \"row\": \"No Instruction\"}], \"vision\": \"RGBD\", \"instruction\": false, \"history\": true"
  [seq2seq_no_depth]="$s2s, \"rows\": [{\"table\": 1, \"row\": \"No Depth\"}], \"vision\": \"RGB\", \"instruction\": true, \"history\": true"
  [seq2seq_no_image]="$s2s, \"rows\": [{\"table\": 1, \"row\": \"No Image\"}], \"vision\": \"D\", \"instruction\": true, \"history\": true"
  [seq2seq_da]="$s2s, \"rows\": [{\"table\": 2, \"row\": \"3\"}], $full, \"pm\": false, \"da\": \"dagger\", \"aug\": false"
  [cma_da]="$cma, \"rows\": [{\"table\": 2, \"row\": \"8\"}], $full, \"pm\": false, \"da\": \"dagger\", \"aug\": false"
  [seq2seq_pm]="$s2s, \"rows\": [{\"table\": 2, \"row\": \"2\"}], $full, \"pm\": true, \"da\": \"none\", \"aug\": false"
  [cma_pm]="$cma, \"rows\": [{\"table\": 2, \"row\": \"7\"}], $full, \"pm\": true, \"da\": \"none\", \"aug\": false"
  [cma_aug]="$cma, \"rows\": [{\"table\": 2, \"row\": \"9\"}], $full, \"pm\": false, \"da\": \"none\", \"aug\": true"
  [seq2seq_aug]="$s2s, \"rows\": [{\"table\": 2, \"row\": \"4\"}], $full, \"pm\": false, \"da\": \"none\", \"aug\": true"
  [cma_pm_aug]="$cma, \"rows\": [{\"table\": 2, \"row\": \"11\"}], $full, \"pm\": true, \"da\": \"none\", \"aug\": true"
  [cma_pm_da_aug]="$cma, \"rows\": [{\"table\": 2, \"row\": \"10\"}], $full, \"pm\": true, \"da\": \"dagger_finetune\", \"aug\": true"
  [cma_da_aug]="$cma, \"rows\": [{\"table\": 2, \"row\": \"12\"}], $full, \"pm\": false, \"da\": \"dagger_finetune\", \"aug\": true"
  [seq2seq_pm_aug]=""
  [seq2seq_pm_da_aug]="$s2s, \"rows\": [{\"table\": 2, \"row\": \"5\"}], $full, \"pm\": true, \"da\": \"dagger_finetune\", \"aug\": true"
)
order=(seq2seq cma seq2seq_no_vision seq2seq_no_instruction seq2seq_no_depth
       seq2seq_no_image seq2seq_da cma_da seq2seq_pm cma_pm cma_aug seq2seq_aug
       cma_pm_aug cma_pm_da_aug cma_da_aug seq2seq_pm_aug seq2seq_pm_da_aug)
if (($#)); then order=("$@"); fi

for name in "${order[@]}"; do
  [[ -v "fields[$name]" ]] || { echo "reproduce_paper.sh: unknown run '$name'" >&2; exit 2; }
  config=configs/experiments/$name.yaml
  vln_train "$config"
  # seq2seq_pm_aug is no table row: only the start of seq2seq_pm_da_aug
  [[ -n "${fields[$name]}" ]] || continue
  best=$(vln_best "runs/experiments/$name")
  vln_evaluate "$results/$name" "$config" "{${fields[$name]}, \"checkpoint\": $best}" \
    --checkpoint "runs/experiments/$name/checkpoints/ckpt.$best.pth" --episodes "$episodes" \
    --navgraph data/datasets/procedural/connectivity
done

vln_evaluate "$results/random" configs/vln/reproduction.yaml \
  '{"model": "Random", "rows": [{"table": 1, "row": "Random"}], "checkpoint": 0,
    "vision": "-", "instruction": false, "history": false}' --agent random --episodes "$episodes"
vln_evaluate "$results/handcrafted" configs/vln/reproduction.yaml \
  '{"model": "Hand-Crafted", "rows": [{"table": 1, "row": "Hand-Crafted"}], "checkpoint": 0,
    "vision": "-", "instruction": false, "history": false}' --agent handcrafted \
  --episodes "$episodes"

vln_stamp "tables"
"$vln_bin/eval" tables --runs "$results" --out "$results/tables.md"
# docs/results.md keeps its prose; the generated tables go between its
# markers (the whole file when it has none)
python3 - "$results/tables.md" docs/results.md <<'PY'
import os, sys
tables, doc = sys.argv[1:]
generated = open(tables).read()
begin, end = "<!-- tables:begin -->", "<!-- tables:end -->"
text = open(doc).read() if os.path.exists(doc) else ""
if begin in text and end in text:
    head, rest = text.split(begin, 1)
    tail = rest.split(end, 1)[1]
    text = head + begin + "\n" + generated + end + tail
else:
    text = begin + "\n" + generated + end + "\n"
with open(doc + ".tmp", "w") as f:
    f.write(text)
os.replace(doc + ".tmp", doc)
PY
vln_stamp "done: $results/tables.md, tables updated in docs/results.md"
