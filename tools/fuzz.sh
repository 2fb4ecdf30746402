#!/usr/bin/env bash
# Runs one libFuzzer target of fuzz/ under AddressSanitizer and UndefinedBehaviorSanitizer.
#
#   tools/fuzz.sh TARGET MINUTES [JOBS]
#
# TARGET: lens_toml scene_toml scene_build zmx agf criteria ray_database mesh. Builds
# build-fuzz/ with clang (-DVEIL_FUZZ=ON -DVEIL_SANITIZE=ON) the first time, then fuzzes for
# MINUTES with a 10 s timeout per input (scene_build: 60 s, see below) and a 2 GB memory
# limit, the corpus in build-fuzz/corpus/TARGET seeded from the folders fuzz/CMakeLists.txt
# lists. A crash, timeout, leak or out-of-memory input
# lands in build-fuzz/artifacts/TARGET/; copy it to fuzz/regressions/TARGET/ once fixed, so
# the test suite replays it (ctest -R FuzzReplay). Needs clang-14 and libclang-rt-14-dev.
set -euo pipefail
if [ $# -lt 2 ]; then
  echo "usage: tools/fuzz.sh TARGET MINUTES [JOBS]" >&2
  exit 2
fi
target=$1
minutes=$2
jobs=${3:-1}
case "$target" in
  lens_toml|scene_toml|scene_build|zmx|agf|criteria|ray_database|mesh) ;;
  *) echo "tools/fuzz.sh: unknown target '$target' (lens_toml scene_toml scene_build zmx agf criteria ray_database mesh)" >&2
     exit 2 ;;
esac
if ! [[ "$minutes" =~ ^[0-9]+$ ]] || [ "$minutes" -lt 1 ]; then
  echo "tools/fuzz.sh: MINUTES must be a whole number >= 1, not '$minutes'" >&2
  exit 2
fi
root=$(cd "$(dirname "$0")/.." && pwd)
build=${VEIL_FUZZ_BUILD:-$root/build-fuzz}
if [ ! -f "$build/CMakeCache.txt" ]; then
  CC=clang CXX=clang++ cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DVEIL_FUZZ=ON -DVEIL_SANITIZE=ON -DVEIL_BUILD_TESTS=OFF -DVEIL_BUILD_BENCH=OFF
fi
cmake --build "$build" --target "veil_fuzz_$target"
corpus=$build/corpus/$target
artifacts=$build/artifacts/$target/
mkdir -p "$corpus" "$artifacts"
mapfile -t seeds < "$build/fuzz/$target.seeds"
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
log=$build/fuzz-$target.log
parallel=()
if [ "$jobs" -gt 1 ]; then
  parallel=(-jobs="$jobs" -workers="$jobs")
fi
set +e
# scene_build builds whole scenes (CGAL mechanics checks, Embree) under the sanitizers, which
# run them about 35 times slower than Release (the 6-lens example: 6.7 s against 0.19 s): its
# limit is 60 s, about 2 s of Release work.
timeout=10
if [ "$target" = scene_build ]; then
  timeout=60
fi
"$build/fuzz/veil_fuzz_$target" -max_total_time=$((minutes * 60)) -timeout=$timeout \
  -rss_limit_mb=2048 -max_len=131072 -print_final_stats=1 "${parallel[@]}" \
  -artifact_prefix="$artifacts" "$corpus" "${seeds[@]}" > "$log" 2>&1
status=$?
set -e
grep -E "ERROR|SUMMARY|Done [0-9]+ runs|stat::number_of_executed_units|stat::peak_rss|artifact" "$log" || true
echo "tools/fuzz.sh: $target exit $status; log $log; artifacts $artifacts"
exit "$status"
