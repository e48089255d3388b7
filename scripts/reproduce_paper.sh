#!/usr/bin/env bash
# Trains and evaluates every experiment of the paper's Tables 1 and 2, with
# several training seeds each, on the embedded default world at the
# reproduction scale (configs/vln/reproduction.yaml; one config per run
# under configs/experiments/), then writes docs/results.md (and .tex): our
# numbers, mean and 95% interval over seeds, beside the paper's, and each
# of the paper's findings judged by the paired difference over seeds.
#
#   scripts/reproduce_paper.sh                      everything, in the order below
#   scripts/reproduce_paper.sh cma seq2seq_da ...   only these experiments (every seed)
#   scripts/reproduce_paper.sh --plan [names]       print the order, run nothing
#
# Seeds: VLN_SEEDS (default 3) seeds 0..N-1 of every experiment. Seed S
# trains with --set trainer.seed=S (initialisation, episode order, DAgger's
# coins) into runs/experiments/<name>/seed<S>/, and evaluates the
# checkpoint chosen on val_unseen SPL, on all of val_seen and val_unseen,
# into results/paper/<name>/seed<S>/ with a run.json naming the seed, the
# config and the command; eval gets the same trainer.seed (encoders without
# weight files are initialised from it) and eval.seed=S. A DA* run
# fine-tunes the same seed's run (its config's init_checkpoint, a run
# directory of this script, gets /seed<S>). Both no-learning baselines draw
# from eval.seed (the random agent its actions, the hand-crafted one its
# heading), so they are evaluated per seed too; they take seconds.
#
# Order: seed-major. Seed 0 of every experiment finishes before seed 1 of
# any, so a partial run first yields a complete single-seed table, and
# every further seed narrows every row's interval at once rather than one
# row's. Within a seed the experiments go by importance (the baselines,
# which take seconds, then Seq2Seq and CMA, the ablations, DAgger, PM,
# Aug in its two stages, the combinations), and a run that fine-tunes
# another (*_aug_tune, DA*) after it.
#
# Finished runs and evaluations are skipped and interrupted ones resume, so
# the script can be stopped and restarted at any time; the tables and the
# findings are rebuilt from whatever has finished (missing rows say so,
# rows with fewer seeds show their n). Every run is also scored on the
# nav-graph (paper Table 3). About 1-8 minutes per run on 2 cores
# (docs/results.md gives the measured times), so about N times the
# single-seed time in all.
# Environment: VLN_BUILD_DIR (build), VLN_EVAL_EPISODES (-1: all),
# VLN_SEEDS (3).
set -euo pipefail
cd "$(dirname "$0")/.."
vln_bin=${VLN_BUILD_DIR:-build}/bin
source scripts/common.sh
# Two of these scripts may run side by side (docs/results.md, "How it was
# run and how long it took"); OpenMP threads that spin then take the cores
# from the other process's, so here they sleep at once (docs/performance.md,
# "OpenMP wait policy").
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-PASSIVE}

episodes=${VLN_EVAL_EPISODES:--1}
seeds=${VLN_SEEDS:-3}
[[ $seeds =~ ^[1-9][0-9]*$ ]] ||
  { echo "reproduce_paper.sh: VLN_SEEDS must be a positive integer, got '$seeds'" >&2; exit 2; }
results=results/paper
s2s='"model": "Seq2Seq"'
cma='"model": "Cross-Modal Attention"'
full='"vision": "RGBD", "instruction": true, "history": true'

# name -> run.json fields (without the seed and the checkpoint); the
# order is the order of importance, DA* runs after the runs they fine-tune
declare -A fields=(
  [random]='"model": "Random", "rows": [{"table": 1, "row": "Random"}], "vision": "-", "instruction": false, "history": false'
  [handcrafted]='"model": "Hand-Crafted", "rows": [{"table": 1, "row": "Hand-Crafted"}], "vision": "-", "instruction": false, "history": false'
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
  [cma_aug]=""
  [cma_aug_tune]="$cma, \"rows\": [{\"table\": 2, \"row\": \"9\"}], $full, \"pm\": false, \"da\": \"none\", \"aug\": true"
  [seq2seq_aug]=""
  [seq2seq_aug_tune]="$s2s, \"rows\": [{\"table\": 2, \"row\": \"4\"}], $full, \"pm\": false, \"da\": \"none\", \"aug\": true"
  [cma_pm_aug]=""
  [cma_pm_aug_tune]="$cma, \"rows\": [{\"table\": 2, \"row\": \"11\"}], $full, \"pm\": true, \"da\": \"none\", \"aug\": true"
  [cma_pm_da_aug]="$cma, \"rows\": [{\"table\": 2, \"row\": \"10\"}], $full, \"pm\": true, \"da\": \"dagger_finetune\", \"aug\": true"
  [cma_da_aug]="$cma, \"rows\": [{\"table\": 2, \"row\": \"12\"}], $full, \"pm\": false, \"da\": \"dagger_finetune\", \"aug\": true"
  [seq2seq_pm_aug]=""
  [seq2seq_pm_da_aug]="$s2s, \"rows\": [{\"table\": 2, \"row\": \"5\"}], $full, \"pm\": true, \"da\": \"dagger_finetune\", \"aug\": true"
)
order=(random handcrafted seq2seq cma seq2seq_no_vision seq2seq_no_instruction seq2seq_no_depth
       seq2seq_no_image seq2seq_da cma_da seq2seq_pm cma_pm cma_aug cma_aug_tune
       seq2seq_aug seq2seq_aug_tune cma_pm_aug cma_pm_aug_tune cma_pm_da_aug cma_da_aug
       seq2seq_pm_aug seq2seq_pm_da_aug)
plan=0
if [[ ${1:-} == --plan ]]; then plan=1; shift; fi
if (($#)); then order=("$@"); fi
for name in "${order[@]}"; do
  [[ -v "fields[$name]" ]] || { echo "reproduce_paper.sh: unknown run '$name'" >&2; exit 2; }
done

# --plan: the (seed, experiment) steps in the order they run, each with its
# run directory and its results folder ("-" for none: the baselines train
# nothing; the first stages of Aug, *_aug, are evaluated as no row)
if ((plan)); then
  for ((seed = 0; seed < seeds; ++seed)); do
    for name in "${order[@]}"; do
      run=runs/experiments/$name/seed$seed out=$results/$name/seed$seed
      case $name in random | handcrafted) run=- ;; esac
      [[ -n "${fields[$name]}" ]] || out=-
      echo "seed $seed $name $run $out"
    done
  done
  exit 0
fi

# results of the single-seed layout (<name>/run.json, before seeds) would
# claim their rows a second time: stop before hours of training, not after
for name in "${order[@]}"; do
  if [[ -f $results/$name/run.json ]]; then
    echo "reproduce_paper.sh: $results/$name/run.json is a single-seed result of" \
      "an earlier version of this script (now $results/$name/seed<S>/); remove" \
      "$results/$name and runs/experiments/$name to rerun it with seeds" >&2
    exit 2
  fi
done

vln_stamp "setup"
scripts/setup.sh
vln_ensure_world
vln_ensure_encoders

# run_baseline NAME SEED: the no-learning agent NAME evaluated with
# eval.seed=SEED (nothing to train)
run_baseline() {
  local name=$1 seed=$2
  vln_evaluate "$results/$name/seed$seed" configs/vln/reproduction.yaml \
    "{${fields[$name]}, \"seed\": $seed, \"checkpoint\": 0}" \
    --set "eval.seed=$seed" --agent "$name" --episodes "$episodes"
}

# run_experiment NAME SEED: trains configs/experiments/NAME.yaml with
# trainer.seed=SEED (a DA* run from the same seed's run) and evaluates its
# chosen checkpoint
run_experiment() {
  local name=$1 seed=$2 config=configs/experiments/$1.yaml
  local run=runs/experiments/$name/seed$seed init best
  local sets=(--set "trainer.seed=$seed" --set "output.dir=$run")
  init=$(vln_config_value "$config" trainer init_checkpoint)
  if [[ $init == runs/experiments/* ]]; then
    sets+=(--set "trainer.init_checkpoint=$init/seed$seed")
  fi
  vln_train "$config" "${sets[@]}"
  # the first stages of Aug (*_aug) are no table row: their second stage
  # (*_aug_tune) or a DA* run fine-tunes them
  [[ -n "${fields[$name]}" ]] || return 0
  best=$(vln_best "$run")
  vln_evaluate "$results/$name/seed$seed" "$config" \
    "{${fields[$name]}, \"seed\": $seed, \"checkpoint\": $best}" \
    --set "trainer.seed=$seed" --set "eval.seed=$seed" \
    --checkpoint "$run/checkpoints/ckpt.$best.pth" --episodes "$episodes" \
    --navgraph data/datasets/procedural/connectivity
}

for ((seed = 0; seed < seeds; ++seed)); do
  for name in "${order[@]}"; do
    case $name in
      random | handcrafted) run_baseline "$name" "$seed" ;;
      *) run_experiment "$name" "$seed" ;;
    esac
  done
done

vln_stamp "tables and findings"
"$vln_bin/eval" tables --runs "$results" --out "$results/tables.md"
"$vln_bin/eval" compare --runs "$results" --out "$results/findings.md"
# docs/results.md keeps its prose; the generated parts go between its
# markers, the tables headed by how they were made
{
  echo "Generated by \`scripts/reproduce_paper.sh\` with VLN_SEEDS=$seeds at commit" \
    "$(git rev-parse --short HEAD 2>/dev/null || echo unknown) on $(date -u +%Y-%m-%d)" \
    "($(nproc) cores); this invocation took $(( ($(date +%s) - vln_started) / 60 )) min" \
    "(one that resumed counts only its own time)."
  echo
  cat "$results/tables.md"
} > "$results/tables_doc.md"
vln_splice tables "$results/tables_doc.md" docs/results.md
vln_splice findings "$results/findings.md" docs/results.md
vln_stamp "done: $results/tables.md, $results/findings.md, both in docs/results.md"
