# Shell functions shared by scripts/run.sh and scripts/reproduce_paper.sh
# (sourced, not run). They expect the repository root as the working
# directory and $vln_bin set to the directory of the binaries.

vln_started=$(date +%s)
vln_stamp() { echo "[$(basename "$0") $(date +%H:%M:%S), $(( $(date +%s) - vln_started )) s] $*"; }

# OpenMP threads that spin between LibTorch ops take the cores from the
# rendering threads (docs/performance.md)
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-PASSIVE}

# The default world (configs/world/default.yaml) into data/, unless there.
vln_ensure_world() {
  local world=data/datasets/procedural
  if [[ ! -f $world/generation_stats.json ]]; then
    vln_stamp "generating the default world into $world"
    rm -rf "$world" data/scene_datasets/procedural
    "$vln_bin/vlnce-data" generate --config configs/world/default.yaml --out "$world" \
      --threads "$(nproc)"
  fi
}

# The frozen encoders of the VLN configs (runs/pretrain/*_encoder.pt),
# pretrained in our own simulator unless there.
vln_ensure_encoders() {
  local task encoder
  for task in rgb_semantic depth_pointnav; do
    encoder=runs/pretrain/${task%%_*}_encoder.pt
    if [[ ! -f $encoder ]]; then
      vln_stamp "pretraining the ${task%%_*} encoder ($task)"
      rm -rf "runs/pretrain/$task"
      "$vln_bin/train" --config "configs/pretrain/$task.yaml"
    fi
  done
}

# vln_train CONFIG: trains the run of CONFIG (output.dir), resumes it when
# interrupted, skips it when finished. Prints nothing else on stdout.
vln_train() {
  local config=$1 run
  run=$("$vln_bin/train" --config "$config" --dry-run |
    awk '/^output:/ { o = 1 } o && /^  dir: / { print $2; exit }')
  if [[ -f $run/finished.json ]]; then
    vln_stamp "training: $run already finished"
  elif [[ -f $run/config.yaml ]]; then
    vln_stamp "training: resuming $run ($config)"
    "$vln_bin/train" --config "$config" --resume
  else
    vln_stamp "training $run ($config)"
    "$vln_bin/train" --config "$config"
  fi
}

# vln_best RUN_DIR: index of the checkpoint the trainer chose on
# val_unseen SPL (the paper's early stopping).
vln_best() {
  python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))["index"])' \
    "$1/checkpoints/best.json"
}

# vln_evaluate OUT CONFIG RUN_JSON EVAL_ARGS...: evaluates on val_seen and
# val_unseen into OUT (metrics JSON, per-episode files, maps) and writes
# OUT/run.json for `eval tables` (src/eval/Tables.h) from the JSON object
# RUN_JSON plus the config and the command. Skipped when OUT/run.json
# exists.
vln_evaluate() {
  local out=$1 config=$2 fields=$3
  shift 3
  if [[ -f $out/run.json ]]; then
    vln_stamp "evaluation: $out already done"
    return
  fi
  vln_stamp "evaluating into $out"
  local command=("$vln_bin/eval" --config "$config" --split val_seen --split val_unseen
                 --out "$out" "$@")
  "${command[@]}"
  python3 - "$out/run.json" "$fields" "$config" "${command[*]}" <<'PY'
import json, sys
path, fields, config, command = sys.argv[1:]
info = json.loads(fields)
info["config"] = config
info["command"] = command
with open(path + ".tmp", "w") as f:
    json.dump(info, f, indent=1)
import os
os.replace(path + ".tmp", path)
PY
}
