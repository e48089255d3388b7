#!/usr/bin/env bash
# Builds the fuzz targets (fuzz/) and runs each one for SECONDS (default 60),
# one after the other.
#
#   scripts/fuzz.sh [SECONDS] [TARGET...]
#
# Two engines (fuzz/CMakeLists.txt): libFuzzer (clang, ASan+UBSan, build-fuzz/)
# for the readers without LibTorch, and AFL++ (afl-g++, ASan+UBSan,
# build-fuzz-afl/) for fuzz_experiment_config and fuzz_checkpoint, whose code
# includes LibTorch's headers, which clang cannot compile as C++20.
#
# libFuzzer corpora live in fuzz-out/corpus/<target>, AFL++ sessions in
# fuzz-out/afl/<target> (both gitignored, both resumed by the next run); the
# seeds (fuzz-out/seeds/<target>) are rebuilt from the committed fuzz/corpus/,
# the fixtures under tests/data_files/, fuzz-seeds' generated files and a
# generated tiny world. Findings are written to fuzz-out/artifacts/<target>/
# (libFuzzer) or fuzz-out/afl/<target>/default/{crashes,hangs}/ (AFL++).
# Prints executions per target and exits non-zero when any target found
# something. A crash input that is fixed becomes a regression case: copy it
# to tests/data_files/crashers/<target>/ (tests/reliability/FuzzCrashersTest.cpp
# replays every file there).
#
# Environment: VLN_JOBS (build jobs, default 2), VLN_FUZZ_BUILD_DIR (default
# build-fuzz), VLN_FUZZ_AFL_BUILD_DIR (default build-fuzz-afl),
# VLN_FUZZ_RSS_MB (default 2048).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
seconds=${1:-60}
shift || true
build=${VLN_FUZZ_BUILD_DIR:-build-fuzz}
afl_build=${VLN_FUZZ_AFL_BUILD_DIR:-build-fuzz-afl}
jobs=${VLN_JOBS:-2}
rss_mb=${VLN_FUZZ_RSS_MB:-2048}
out=$root/fuzz-out

all_targets=(fuzz_experiment_config fuzz_episodes fuzz_ground_truth
  fuzz_sub_instructions fuzz_glove_text fuzz_embeddings_json fuzz_mesh_obj fuzz_mesh_ply
  fuzz_navgraph fuzz_navmesh fuzz_geometry fuzz_checkpoint fuzz_zip
  fuzz_rxr_episodes fuzz_npz)
if (($#)); then targets=("$@"); else targets=("${all_targets[@]}"); fi

# the targets that include LibTorch run under AFL++, the others libFuzzer
uses_torch() { [[ $1 == fuzz_experiment_config || $1 == fuzz_checkpoint ]]; }
lf_targets=()
afl_targets=()
for t in "${targets[@]}"; do
  if uses_torch "$t"; then afl_targets+=("$t"); else lf_targets+=("$t"); fi
done

# largest input per target: a little above the biggest seed worth mutating
max_len() {
  case $1 in
    fuzz_navmesh) echo 262144 ;;
    fuzz_episodes | fuzz_ground_truth | fuzz_sub_instructions | fuzz_embeddings_json | fuzz_checkpoint | fuzz_zip | fuzz_rxr_episodes | fuzz_npz) echo 65536 ;;
    fuzz_navgraph | fuzz_experiment_config) echo 32768 ;;
    fuzz_geometry) echo 4096 ;;
    *) echo 16384 ;;
  esac
}

# --- toolchains: clang with its libFuzzer/sanitizer runtimes; AFL++ -------
wanted=()
((${#lf_targets[@]})) && wanted+=(clang libclang-rt-14-dev lld)
((${#afl_targets[@]})) && wanted+=(afl++)
source scripts/packages.sh
vln_install_missing fuzz "${wanted[@]}"

# --- builds --------------------------------------------------------------------
if ((${#lf_targets[@]})); then
  if [[ ! -f $build/CMakeCache.txt ]]; then
    CC=clang CXX=clang++ cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_CXX_FLAGS=-gline-tables-only -DCMAKE_C_FLAGS=-gline-tables-only \
      -DVLN_SANITIZE=ON -DVLN_FUZZ=ON -DVLN_FUZZ_ENGINE=libfuzzer -DVLN_WERROR=ON \
      -DVLN_BUILD_TESTS=OFF -DVLN_BUILD_BENCH=OFF
  fi
  cmake --build "$build" -j "$jobs" --target "${lf_targets[@]}" vlnce-data
fi
# afl-g++ would add -g -O3 -funroll-loops; the build type gives -O3 already
export AFL_DONT_OPTIMIZE=1 AFL_QUIET=1
if ((${#afl_targets[@]})); then
  if [[ ! -f $afl_build/CMakeCache.txt ]]; then
    CC=afl-gcc CXX=afl-g++ cmake -S . -B "$afl_build" -G Ninja -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_CXX_FLAGS=-g1 -DCMAKE_C_FLAGS=-g1 \
      -DVLN_SANITIZE=ON -DVLN_FUZZ=ON -DVLN_FUZZ_ENGINE=afl -DVLN_WERROR=ON \
      -DVLN_BUILD_TESTS=OFF -DVLN_BUILD_BENCH=OFF
  fi
  cmake --build "$afl_build" -j "$jobs" --target "${afl_targets[@]}" fuzz-seeds
fi

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
if ((${#afl_targets[@]})); then "$afl_build/fuzz/fuzz-seeds" "$seeds"; fi
data=tests/data_files/r2r
cp $data/tiny_split.json $data/test_split.json "$seeds/fuzz_episodes/"
cp $data/tiny_split_gt.json "$seeds/fuzz_ground_truth/"
# the GloVe target reads its first byte as options (0: defaults)
{ printf '\000'; cat $data/tiny_glove.txt; } >"$seeds/fuzz_glove_text/tiny_glove.txt"
cp tests/data_files/meshes/house_small.glb.semantics.json "$seeds/fuzz_navgraph/" # JSON shape only
cp tests/data_files/zip/*.zip "$seeds/fuzz_zip/"

world=$out/world
if ((${#lf_targets[@]})) && [[ ! -f $world/done ]]; then
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
if [[ -f $world/done ]]; then
  f=$(first 'val_seen.json.gz') && [[ -n $f ]] && seed_from fuzz_episodes "$f" world_episodes.json
  f=$(first 'val_seen_gt.json.gz') && [[ -n $f ]] && seed_from fuzz_ground_truth "$f" world_gt.json
  f=$(first 'train_sub_instructions.json.gz') && [[ -n $f ]] && seed_from fuzz_sub_instructions "$f" world_sub_instructions.json
  f=$(first 'embeddings.json.gz') && [[ -n $f ]] && seed_from fuzz_embeddings_json "$f" world_embeddings.json
  f=$(first '*.navmesh') && [[ -n $f ]] && seed_from fuzz_navmesh "$f" world.navmesh
  f=$(first '*_connectivity.json') && [[ -n $f ]] && seed_from fuzz_navgraph "$f" world_graph.json
  f=$(first '*glove*.txt*') && [[ -n $f ]] &&
    { printf '\000'; gzip -dcf "$f"; } >"$seeds/fuzz_glove_text/world_glove.txt"
fi

# --- run ---------------------------------------------------------------------
summary=()
failed=0
mkdir -p "$out/logs"

# libFuzzer: -max_total_time, the corpus grows in fuzz-out/corpus/<target>
run_libfuzzer() {
  local t=$1 corpus=$out/corpus/$1 artifacts=$out/artifacts/$1 log=$out/logs/$1.log
  mkdir -p "$corpus" "$artifacts"
  set +e
  ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=0 \
    LSAN_OPTIONS=suppressions=$root/fuzz/lsan.supp:print_suppressions=0 \
    UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    "$build/fuzz/$t" "$corpus" "$seeds/$t" -max_total_time="$seconds" \
    -max_len="$(max_len "$t")" -timeout=25 -rss_limit_mb="$rss_mb" \
    -artifact_prefix="$artifacts/" -print_final_stats=1 >"$log" 2>&1
  local rc=$?
  set -e
  local execs corpus_size cov outcome=ok
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -n 1)
  corpus_size=$(find "$corpus" -type f | wc -l)
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -n 1 | grep -o '[0-9]*')
  if ((rc != 0)); then
    outcome="FINDING (exit $rc, see $log and $artifacts)"
    failed=1
    grep -m 3 -E 'ERROR|runtime error|vln fuzz|deadly signal|leak' "$log" || true
  fi
  summary+=("$(printf '%-24s %-9s %12s execs  cov %6s  corpus %5s  %s' "$t" libFuzzer "${execs:-?}" "${cov:-?}" "$corpus_size" "$outcome")")
}

# AFL++: -V seconds, one fork per input (the input file is @@); a second run
# resumes the session (-i -); crashes and hangs are kept in the session.
# LeakSanitizer's pass over LibTorch's heap costs ~200 ms per input (36
# against 5 executions per second), so the fuzzing runs without it and every
# input of the final corpus is then replayed once with it.
run_afl() {
  local t=$1 session=$out/afl/$1 log=$out/logs/$1.log input
  mkdir -p "$session"
  rm -f "$log.leaks"
  input=$seeds/$t
  [[ -d $session/default/queue ]] && input=-
  set +e
  ASAN_OPTIONS=abort_on_error=1:symbolize=0:detect_leaks=0:allocator_may_return_null=1 \
    UBSAN_OPTIONS=halt_on_error=1:abort_on_error=1:symbolize=0 \
    AFL_SKIP_CPUFREQ=1 AFL_NO_UI=1 AFL_NO_AFFINITY=1 AFL_I_DONT_CARE_ABOUT_MISSING_CRASHES=1 \
    afl-fuzz -i "$input" -o "$session" -V "$seconds" -t 25000 -m none \
    -- "$afl_build/fuzz/$t" @@ >"$log" 2>&1
  local rc=$?
  set -e
  local stats=$session/default/fuzzer_stats
  field() { if [[ -f $stats ]]; then awk -v k="$1" '$1 == k { print $3 }' "$stats"; fi; }
  local execs corpus_size edges crashes hangs outcome=ok
  execs=$(field execs_done)
  corpus_size=$(field corpus_count)
  edges=$(field edges_found)
  crashes=$(field saved_crashes)
  hangs=$(field saved_hangs)
  local leaks=0 input_file
  for input_file in "$session"/default/queue/id:*; do
    [[ -f $input_file ]] || continue
    ASAN_OPTIONS=detect_leaks=1 \
      LSAN_OPTIONS=suppressions=$root/fuzz/lsan.supp:print_suppressions=0 \
      "$afl_build/fuzz/$t" "$input_file" >>"$log.leaks" 2>&1 || {
      leaks=$((leaks + 1))
      echo "fuzz: $t leaks or fails on $input_file" | tee -a "$log.leaks"
    }
  done
  if ((rc != 0)) || [[ ! -f $stats ]]; then
    outcome="ERROR (afl-fuzz exit $rc, see $log)"
    failed=1
    tail -n 5 "$log"
  elif ((${crashes:-0} + ${hangs:-0} + leaks > 0)); then
    outcome="FINDING ($crashes crashes, $hangs hangs in $session/default; $leaks corpus inputs leak, see $log.leaks)"
    failed=1
  fi
  summary+=("$(printf '%-24s %-9s %12s execs  edges %4s  corpus %5s  %s' "$t" AFL++ "${execs:-?}" "${edges:-?}" "${corpus_size:-?}" "$outcome, corpus replayed for leaks")")
}

for t in "${targets[@]}"; do
  echo "fuzz: $t for ${seconds}s"
  if uses_torch "$t"; then run_afl "$t"; else run_libfuzzer "$t"; fi
done

echo
echo "fuzz: ${seconds}s per target"
printf '%s\n' "${summary[@]}"
exit $failed
