#!/usr/bin/env bash
# Builds the fuzz targets with clang (libFuzzer, AddressSanitizer, UndefinedBehaviorSanitizer)
# and runs each for SECONDS (default 60) from its checked-in corpus. Exits non-zero on any
# crash, sanitizer report, leak or hang; the input that caused it is left in build-fuzz/.
# Usage: tests/fuzz/run.sh [SECONDS]
set -euo pipefail
cd "$(dirname "$0")/../.."
seconds=${1:-60}
CC=clang CXX=clang++ cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DDEMBUF_FUZZ=ON > /dev/null
cmake --build build-fuzz --target scene_parser_fuzz request_fuzz config_fuzz bed_import_fuzz
# One target a core at a time; each one's report is printed when it ends.
fuzz() {
  local target=$1 work=build-fuzz/corpus-$1 log=build-fuzz/fuzz-$1.log status=0
  mkdir -p "$work"
  # New inputs go to a scratch folder; the checked-in corpus stays as it is.
  (cd build-fuzz && "./tests/fuzz/${target}_fuzz" -max_total_time="$seconds" -timeout=10 \
     -rss_limit_mb=2048 -max_len=4096 -print_final_stats=1 \
     "corpus-$target" "../tests/fuzz/corpus/$target") > "$log" 2>&1 || status=$?
  echo "fuzzed $target for $seconds s:"
  tail -12 "$log"
  return "$status"
}
failed=0
running=0
for target in scene_parser request config bed_import; do
  if [ "$running" -ge "$(nproc)" ]; then
    wait -n || failed=1
    running=$((running - 1))
  fi
  fuzz "$target" &
  running=$((running + 1))
done
for ((; running > 0; running--)); do wait -n || failed=1; done
[ "$failed" = 0 ] || { echo "fuzzing: a target failed (its input is in build-fuzz/)"; exit 1; }
echo "fuzzing: no crashes"
