#!/usr/bin/env bash
# The main job, on the embedded default world, from a fresh checkout:
#   1. setup (Debian packages, build of the binaries used here);
#   2. the default world (40 procedural houses -> R2R_VLNCE splits, and
#      112 more train houses for the DAgger pool);
#   3. the frozen encoders, pretrained in our own simulator (RGB: what the
#      houses contain; depth: point-goal navigation), unless present;
#   4. the default Cross-Modal Attention policy (configs/main.yaml);
#   5. evaluation of its best checkpoint and of the random and hand-crafted
#      baselines on all of val_seen and val_unseen: metrics JSON,
#      per-episode files and top-down maps under results/main/<agent>/, an
#      HTML report of the CMA's episodes (results/main/cma/report) and the
#      training run's learning curve (results/main/cma/learning_curve.png);
#   6. the results table (results/main/table.md, .tex), printed at the end:
#      the paper rows this job claims, its numbers beside the paper's (the
#      whole reproduction is scripts/reproduce_paper.sh).
# Each step reuses what an earlier run finished, and an interrupted training
# run resumes, so running it again is cheap. Environment:
#   VLN_BUILD_DIR   build directory (build)
#   VLN_FRESH=1     start over: delete runs/main, results/main and the
#                   pretrained encoders (the world and the build are kept)
set -euo pipefail
cd "$(dirname "$0")/.."
vln_bin=${VLN_BUILD_DIR:-build}/bin
source scripts/common.sh

vln_stamp "setup"
VLN_BUILD_TARGETS="train eval vlnce-data vlnce-export" scripts/setup.sh

if [[ "${VLN_FRESH:-0}" == 1 ]]; then
  rm -rf runs/main results/main runs/pretrain
fi
vln_ensure_world
vln_ensure_encoders

config=configs/main.yaml
run=runs/main/cma
vln_train $config
best=$(vln_best $run)

results=results/main
seed=$(vln_config_value $config trainer seed)
vln_evaluate $results/cma $config \
  "{\"model\": \"Cross-Modal Attention (main job: DA + Aug)\", \"rows\": [{\"table\": 2, \"row\": \"12\"}],
    \"seed\": $seed, \"checkpoint\": $best, \"vision\": \"RGBD\", \"instruction\": true, \"history\": true,
    \"pm\": false, \"da\": \"dagger\", \"aug\": true,
    \"notes\": \"one DAgger run from scratch whose iteration 0 is teacher forcing on train + train_aug; the paper's row 12 fine-tunes an Aug run with DA*\"}" \
  --checkpoint $run/checkpoints/ckpt.$best.pth --report $results/cma/report
# the learning curve of the training run (val_unseen SR and SPL of every
# validation against wall time and updates), next to the maps
vln_stamp "learning curve"
"$vln_bin/eval" curve --run $run --out $results/cma/learning_curve.png \
  --title "val_unseen learning curve: main job (configs/main.yaml, seed $seed)"
vln_evaluate $results/random $config \
  '{"model": "Random", "rows": [{"table": 1, "row": "Random"}], "checkpoint": 0,
    "vision": "-", "instruction": false, "history": false}' --agent random --maps 0
vln_evaluate $results/handcrafted $config \
  '{"model": "Hand-Crafted", "rows": [{"table": 1, "row": "Hand-Crafted"}], "checkpoint": 0,
    "vision": "-", "instruction": false, "history": false}' --agent handcrafted --maps 0

vln_stamp "tables"
"$vln_bin/eval" tables --runs $results --out $results/table.md --claimed-only
cat $results/table.md
vln_stamp "done: maps in $results/cma/pictures, learning curve $results/cma/learning_curve.png, report in $results/cma/report/index.html, metrics in $results/*/stats_ckpt_*.json"
