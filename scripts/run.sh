#!/usr/bin/env bash
# The main job, on the embedded default world, from a fresh checkout:
#   1. setup (Debian packages, build of the binaries used here);
#   2. the default world (40 procedural houses -> R2R_VLNCE splits);
#   3. the frozen encoders, pretrained in our own simulator (RGB: what the
#      houses contain; depth: point-goal navigation), unless present;
#   4. the default Cross-Modal Attention policy (configs/main.yaml);
#   5. evaluation of its best checkpoint and of the random and hand-crafted
#      baselines on val_seen and val_unseen: metrics JSON, per-episode files
#      and top-down maps under results/main/<agent>/;
#   6. the results table (results/main/table.md, .tex), printed at the end.
# Each step reuses what an earlier run finished, and an interrupted training
# run resumes, so running it again is cheap. Environment:
#   VLN_BUILD_DIR   build directory (build)
#   VLN_FRESH=1     start over: delete runs/main, results/main and the
#                   pretrained encoders (the world and the build are kept)
set -euo pipefail
cd "$(dirname "$0")/.."

started=$(date +%s)
stamp() { echo "[run.sh $(date +%H:%M:%S), $(( $(date +%s) - started )) s] $*"; }

stamp "setup"
VLN_BUILD_TARGETS="train eval vlnce-data vlnce-export" scripts/setup.sh

bin=${VLN_BUILD_DIR:-build}/bin
threads=$(nproc)
# OpenMP threads that spin between LibTorch ops take the cores from the
# rendering threads (docs/performance.md)
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-PASSIVE}

if [[ "${VLN_FRESH:-0}" == 1 ]]; then
  rm -rf runs/main results/main runs/pretrain
fi

world=data/datasets/procedural
if [[ ! -f $world/generation_stats.json ]]; then
  stamp "generating the default world into $world"
  rm -rf "$world" data/scene_datasets/procedural
  "$bin/vlnce-data" generate --config configs/world/default.yaml --out "$world" \
    --threads "$threads"
fi

for task in rgb_semantic depth_pointnav; do
  encoder=runs/pretrain/${task%%_*}_encoder.pt
  if [[ ! -f $encoder ]]; then
    stamp "pretraining the ${task%%_*} encoder ($task)"
    rm -rf "runs/pretrain/$task"
    "$bin/train" --config "configs/pretrain/$task.yaml"
  fi
done

run=runs/main/cma
if [[ -f $run/finished.json ]]; then
  stamp "training: $run already finished"
elif [[ -f $run/config.yaml ]]; then
  stamp "training: resuming $run"
  "$bin/train" --config configs/main.yaml --resume
else
  stamp "training the CMA policy into $run"
  "$bin/train" --config configs/main.yaml
fi

# the checkpoint the trainer chose on val_unseen SPL (the paper's early stopping)
best=$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["index"])' \
  "$run/checkpoints/best.json")
results=results/main
mkdir -p "$results"

evaluate() {  # name, run.json fields, eval arguments...
  local name=$1 fields=$2
  shift 2
  local out=$results/$name
  stamp "evaluating $name on val_seen and val_unseen"
  "$bin/eval" --config configs/main.yaml --split val_seen --split val_unseen \
    --out "$out" "$@"
  local command="$bin/eval --config configs/main.yaml --split val_seen --split val_unseen --out $out $*"
  python3 - "$out/run.json" "$fields" "$command" <<'PY'
import json, sys
path, fields, command = sys.argv[1:]
info = json.loads(fields)
info["config"] = "configs/main.yaml"
info["command"] = command
json.dump(info, open(path, "w"), indent=1)
PY
}

evaluate cma "{\"model\": \"Cross-Modal Attention (main job)\", \"rows\": [{\"table\": 2, \"row\": \"6\"}],
  \"checkpoint\": $best, \"vision\": \"RGBD\", \"instruction\": true, \"history\": true,
  \"pm\": false, \"da\": \"dagger\", \"aug\": true}" \
  --checkpoint "$run/checkpoints/ckpt.$best.pth"
evaluate random '{"model": "Random", "rows": [{"table": 1, "row": "Random"}], "checkpoint": 0,
  "vision": "-", "instruction": false, "history": false}' --agent random --maps 0
evaluate handcrafted '{"model": "Hand-Crafted", "rows": [{"table": 1, "row": "Hand-Crafted"}],
  "checkpoint": 0, "vision": "-", "instruction": false, "history": false}' --agent handcrafted \
  --maps 0

stamp "tables"
"$bin/eval" tables --runs "$results" --out "$results/table.md"
cat "$results/table.md"
stamp "done: maps in $results/cma/maps, metrics in $results/*/stats_ckpt_*.json"
