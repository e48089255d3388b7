# Shell functions shared by scripts/run.sh and scripts/reproduce_paper.sh
# (sourced, not run). They expect the repository root as the working
# directory and $vln_bin set to the directory of the binaries.

vln_started=$(date +%s)
vln_stamp() { echo "[$(basename "$0") $(date +%H:%M:%S), $(( $(date +%s) - vln_started )) s] $*"; }

# How OpenMP threads wait between LibTorch ops is the binaries' choice (a
# short spin, common::OmpWait) unless OMP_WAIT_POLICY or GOMP_SPINCOUNT is
# set (docs/performance.md, "OpenMP wait policy").

# The default world (configs/world/default.yaml) into data/, unless there.
vln_ensure_world() {
  local world=data/datasets/procedural
  if [[ ! -f $world/generation_stats.json ]]; then
    vln_stamp "generating the default world into $world"
    rm -rf "$world" data/scene_datasets/procedural
  elif [[ ! -f $world/train_extra/train_extra.json.gz ]]; then
    # a world from before the 112 extra train houses: the same frozen files
    # plus train_extra (the generator replaces what it writes, and keeps
    # other worlds' scenes)
    vln_stamp "adding the 112 extra train houses to $world"
  else
    return 0
  fi
  "$vln_bin/vlnce-data" generate --config configs/world/default.yaml --out "$world" \
    --threads "$(nproc)"
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

# vln_config_value CONFIG SECTION KEY [--set k=v ...]: the value of
# SECTION.KEY in the resolved config (`train --dry-run`, bases and
# overrides applied), without YAML quotes.
vln_config_value() {
  local config=$1 section=$2 key=$3
  shift 3
  "$vln_bin/train" --config "$config" --dry-run "$@" |
    awk -v section="$section:" -v key="$key:" '
      $0 == section { inside = 1; next }
      /^[^ #]/ { inside = 0 }
      inside && index($0, "  " key " ") == 1 {
        value = substr($0, length(key) + 4); gsub(/^"|"$/, "", value)
        print value; exit
      }'
}

# vln_train CONFIG [--set k=v ...]: trains the run of CONFIG with the
# overrides (output.dir), resumes it when interrupted, skips it when
# finished. Prints nothing else on stdout.
vln_train() {
  local config=$1 run
  shift
  run=$(vln_config_value "$config" output dir "$@")
  if [[ -f $run/finished.json ]]; then
    # a finished run of an older recipe must not pass for this one
    local changes
    changes=$(diff <("$vln_bin/train" --config "$run/config.yaml" --dry-run) \
                   <("$vln_bin/train" --config "$config" --dry-run "$@")) || {
      echo "$run was trained with another config than $config $* now gives" \
           "(< the run, > now):" >&2
      echo "$changes" | grep '^[<>]' >&2
      echo "Start over with VLN_FRESH=1 $0, or move $run away." >&2
      exit 1
    }
    vln_stamp "training: $run already finished"
  elif [[ -f $run/config.yaml ]]; then
    vln_stamp "training: resuming $run ($config $*)"
    "$vln_bin/train" --config "$config" "$@" --resume
  else
    vln_stamp "training $run ($config $*)"
    "$vln_bin/train" --config "$config" "$@"
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

# vln_splice NAME GENERATED DOC: replaces what DOC holds between the lines
# <!-- NAME:begin --> and <!-- NAME:end --> by the file GENERATED, keeping
# the rest of DOC (its prose); appends a marked block when DOC has no such
# markers. Written atomically.
vln_splice() {
  python3 - "$@" <<'PY'
import os, sys
name, generated, doc = sys.argv[1:]
body = open(generated).read()
begin, end = f"<!-- {name}:begin -->", f"<!-- {name}:end -->"
text = open(doc).read() if os.path.exists(doc) else ""
block = begin + "\n" + body + ("" if body.endswith("\n") else "\n") + end
if begin in text and end in text.split(begin, 1)[1]:
    head, rest = text.split(begin, 1)
    text = head + block + rest.split(end, 1)[1]
else:
    text += ("\n" if text and not text.endswith("\n") else "") + block + "\n"
with open(doc + ".tmp", "w") as f:
    f.write(text)
os.replace(doc + ".tmp", doc)
PY
}
