#!/usr/bin/env bash
# Builds the libFuzzer targets (fuzz/, clang, ASan+UBSan) into build-fuzz/
# and runs each one for SECONDS (default 60), one after the other.
#
#   scripts/fuzz.sh [SECONDS] [TARGET...]
#
# Corpora live in fuzz-out/corpus/<target> (gitignored) and grow from run to
# run; the seeds (fuzz-out/seeds/<target>) are rebuilt from the committed
# fuzz/corpus/, the fixtures under tests/data_files/, fuzz-seeds' generated
# files and a generated tiny world. Findings (crash inputs) are written to
# fuzz-out/artifacts/<target>/. Prints executions per target and exits
# non-zero when any target found something. A crash input that is fixed
# becomes a regression case: copy it to tests/data_files/crashers/<target>/
# (tests/reliability/FuzzCrashersTest.cpp replays every file there).
#
# Environment: VLN_JOBS (build jobs, default 2), VLN_FUZZ_BUILD_DIR (default
# build-fuzz), VLN_FUZZ_RSS_MB (default 2048).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
seconds=${1:-60}
shift || true
build=${VLN_FUZZ_BUILD_DIR:-build-fuzz}
jobs=${VLN_JOBS:-2}
rss_mb=${VLN_FUZZ_RSS_MB:-2048}
out=$root/fuzz-out

all_targets=(fuzz_experiment_config fuzz_episodes fuzz_ground_truth
  fuzz_glove_text fuzz_embeddings_json fuzz_mesh_obj fuzz_mesh_ply
  fuzz_navgraph fuzz_navmesh fuzz_checkpoint)
if (($#)); then targets=("$@"); else targets=("${all_targets[@]}"); fi

# largest input per target: a little above the biggest seed worth mutating
max_len() {
  case $1 in
    fuzz_navmesh) echo 262144 ;;
    fuzz_episodes | fuzz_ground_truth | fuzz_embeddings_json | fuzz_checkpoint) echo 65536 ;;
    fuzz_navgraph | fuzz_experiment_config) echo 32768 ;;
    *) echo 16384 ;;
  esac
}

# --- toolchain: clang, its libFuzzer/sanitizer runtimes, lld ---------------
missing=()
for p in clang libclang-rt-14-dev lld; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" ||
    missing+=("$p")
done
if ((${#missing[@]})); then
  echo "fuzz: installing ${missing[*]}"
  SUDO=""
  if [[ $(id -u) -ne 0 ]]; then SUDO="sudo"; fi
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

# --- build -------------------------------------------------------------------
if [[ ! -f $build/CMakeCache.txt ]]; then
  CC=clang CXX=clang++ cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release \
    -DCMAKE_CXX_FLAGS=-gline-tables-only -DCMAKE_C_FLAGS=-gline-tables-only \
    -DVLN_SANITIZE=ON -DVLN_FUZZ=ON -DVLN_WERROR=ON \
    -DVLN_BUILD_TESTS=OFF -DVLN_BUILD_BENCH=OFF
fi
# fuzz-seeds links LibTorch: built only when a LibTorch target is asked for
need_seeds=(vlnce-data)
with_torch=0
for t in "${targets[@]}"; do
  [[ $t == fuzz_experiment_config || $t == fuzz_checkpoint ]] && with_torch=1
done
((with_torch)) && need_seeds+=(fuzz-seeds)
cmake --build "$build" -j "$jobs" --target "${targets[@]}" "${need_seeds[@]}"

# --- seeds -------------------------------------------------------------------
# the sanitizers must not stop the seed generators on LibTorch's own leaks
export ASAN_OPTIONS=detect_leaks=0
seeds=$out/seeds
rm -rf "$seeds"
mkdir -p "$seeds"
for t in "${all_targets[@]}"; do
  mkdir -p "$seeds/$t"
  if [[ -d fuzz/corpus/$t ]]; then cp fuzz/corpus/$t/* "$seeds/$t/"; fi
done
if ((with_torch)); then "$build/fuzz/fuzz-seeds" "$seeds"; fi
data=tests/data_files/r2r
cp $data/tiny_split.json $data/test_split.json "$seeds/fuzz_episodes/"
cp $data/tiny_split_gt.json "$seeds/fuzz_ground_truth/"
# the GloVe target reads its first byte as options (0: defaults)
{ printf '\000'; cat $data/tiny_glove.txt; } >"$seeds/fuzz_glove_text/tiny_glove.txt"
cp tests/data_files/meshes/house_small.glb.semantics.json "$seeds/fuzz_navgraph/" # JSON shape only

world=$out/world
if [[ ! -f $world/done ]]; then
  rm -rf "$world"
  echo "fuzz: generating the tiny world for seeds"
  "$build/bin/vlnce-data" generate --config configs/world/tiny.yaml --houses 1 \
    --out "$world/data" --scenes-dir "$world/scenes" --threads 1 >/dev/null
  touch "$world/done"
fi
# generated files, uncompressed (mutating gzip bytes rarely reaches the
# parser; one compressed seed each keeps the gzip path covered)
seed_from() {  # <target> <file> <name>
  local target=$1 file=$2 name=$3
  if [[ $file == *.gz ]]; then
    gzip -dc "$file" >"$seeds/$target/$name"
    cp "$file" "$seeds/$target/$name.gz"
  else
    cp "$file" "$seeds/$target/$name"
  fi
}
first() { find "$world" -name "$1" -type f | sort | head -n 1; }
f=$(first 'val_seen.json.gz') && [[ -n $f ]] && seed_from fuzz_episodes "$f" world_episodes.json
f=$(first 'val_seen_gt.json.gz') && [[ -n $f ]] && seed_from fuzz_ground_truth "$f" world_gt.json
f=$(first 'embeddings.json.gz') && [[ -n $f ]] && seed_from fuzz_embeddings_json "$f" world_embeddings.json
f=$(first '*.navmesh') && [[ -n $f ]] && seed_from fuzz_navmesh "$f" world.navmesh
f=$(first '*_connectivity.json') && [[ -n $f ]] && seed_from fuzz_navgraph "$f" world_graph.json
f=$(first '*glove*.txt*') && [[ -n $f ]] &&
  { printf '\000'; gzip -dcf "$f"; } >"$seeds/fuzz_glove_text/world_glove.txt"

# --- run ---------------------------------------------------------------------
export ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=0
# narrow, documented: leaks inside Debian's assimp on malformed meshes
export LSAN_OPTIONS=suppressions=$root/fuzz/lsan.supp:print_suppressions=0
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
summary=()
failed=0
for t in "${targets[@]}"; do
  corpus=$out/corpus/$t
  artifacts=$out/artifacts/$t
  mkdir -p "$corpus" "$artifacts"
  log=$out/logs/$t.log
  mkdir -p "$out/logs"
  echo "fuzz: $t for ${seconds}s"
  set +e
  "$build/fuzz/$t" "$corpus" "$seeds/$t" -max_total_time="$seconds" \
    -max_len="$(max_len "$t")" -timeout=25 -rss_limit_mb="$rss_mb" \
    -artifact_prefix="$artifacts/" -print_final_stats=1 >"$log" 2>&1
  rc=$?
  set -e
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -n 1)
  corpus_size=$(find "$corpus" -type f | wc -l)
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -n 1 | grep -o '[0-9]*')
  if ((rc == 0)); then
    outcome=ok
  else
    outcome="FINDING (exit $rc, see $log and $artifacts)"
    failed=1
    grep -m 3 -E 'ERROR|runtime error|vln fuzz|deadly signal|leak' "$log" || true
  fi
  summary+=("$(printf '%-24s %12s execs  cov %6s  corpus %5s  %s' "$t" "${execs:-?}" "${cov:-?}" "$corpus_size" "$outcome")")
done

echo
echo "fuzz: ${seconds}s per target"
printf '%s\n' "${summary[@]}"
exit $failed
