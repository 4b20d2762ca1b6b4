#!/usr/bin/env bash
# Set-up command 2: install, build, and run every test: the GoogleTest and CTest suites, the
# same suites built with AddressSanitizer and UndefinedBehaviorSanitizer, and the fuzzers for a
# bounded time. FUZZ_SECONDS (default 60) sets the fuzzing time per target; SANITIZE=0 and
# FUZZ_SECONDS=0 skip those stages.
set -euo pipefail
cd "$(dirname "$0")/.."
bash deploy/build.sh
# ctest runs two test programs at once; OpenMP threads that spin while waiting would then
# steal each other's cores.
export OMP_WAIT_POLICY=passive
(cd build && ctest --output-on-failure --parallel "$(nproc)" --timeout 900)

if [ "${SANITIZE:-1}" != 0 ]; then
  echo "== the unit tests under AddressSanitizer + UndefinedBehaviorSanitizer"
  cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DDEMBUF_SANITIZE=address,undefined > /dev/null
  cmake --build build-asan --parallel "$(nproc)" --target engine_tests server_tests
  export UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 ASAN_OPTIONS=detect_leaks=1
  # The GoogleTest suites only (the script tests need the other binaries), each binary in one
  # process. Tests that prepare beds or integrate long fine-step runs are left to the optimised
  # suite above: under the sanitizers each takes minutes and adds no code path (bed files are
  # also written and read by the store tests).
  build-asan/tests/engine_tests --gtest_brief=1 \
    --gtest_filter='-BedPreparation.*:SmallBedImpact.*:Regression.*:Determinism.*:Energy.*:Restitution.*:HertzElastic.*:HardCase.SingleBeadLayer*:HardCase.ImportedBedWithSmall*:HardCase.Restitution*:HardCase.SizeRatio*:HardCase.ProjectileGrazing*:HardCase.BedImpact*:HardCase.AMillion*' &
  engine=$!
  build-asan/tests/server_tests --gtest_brief=1
  wait "$engine"
fi

if [ "${FUZZ_SECONDS:-60}" != 0 ]; then
  echo "== fuzzing"
  bash tests/fuzz/run.sh "${FUZZ_SECONDS:-60}"
fi
