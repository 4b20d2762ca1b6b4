#!/usr/bin/env bash
# Set-up command 2: install, build, and run every test: the GoogleTest and CTest suites, the
# same suites built with AddressSanitizer and UndefinedBehaviorSanitizer, the threaded parts
# under ThreadSanitizer, and the fuzzers for a bounded time. FUZZ_SECONDS (default 20) sets the
# fuzzing time per target; SANITIZE=0 and FUZZ_SECONDS=0 skip those stages.
set -euo pipefail
cd "$(dirname "$0")/.."
# Each stage says when it starts, so that a slow one is named in the log.
stage() { echo "== $* (at $((SECONDS / 60)) min $((SECONDS % 60)) s)"; }
stage "installing and building"
bash deploy/build.sh
stage "the test suites"
# ctest runs as many test programs at once as there are cores. The engine's threads meet at a
# barrier several times a step, so a run of two threads beside another test, each waiting for
# the other's core, goes three times slower than alone: the tests run the engine on one thread
# (OMP_NUM_THREADS), but those about threads, which say how many cores they take (PROCESSORS).
# OpenMP threads that spin while waiting would also steal each other's cores.
export OMP_WAIT_POLICY=passive
(cd build && OMP_NUM_THREADS=1 ctest --output-on-failure --parallel "$(nproc)" --timeout 900)

sanitizer_opt_flags="-O2 -gline-tables-only -DNDEBUG"
if [ "${SANITIZE:-1}" != 0 ]; then
  stage "the unit tests under AddressSanitizer + UndefinedBehaviorSanitizer"
  # One clang build serves these tests and the fuzzers below (tests/fuzz/run.sh): everything
  # in it is built with both sanitizers (and libFuzzer's coverage, which does not change what
  # the tests check), so the sources are compiled once for the two stages.
  # Line tables are all a sanitizer's report needs of the debugging information, and they
  # compile faster; so does a unity build (deploy/build.sh).
  CC=clang CXX=clang++ cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="$sanitizer_opt_flags" -DCMAKE_UNITY_BUILD=ON -DDEMBUF_FUZZ=ON > /dev/null
  cmake --build build-fuzz --parallel "$(nproc)" --target engine_tests server_tests
  export UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 ASAN_OPTIONS=detect_leaks=1
  # The GoogleTest suites only (the script tests need the other binaries), in three
  # processes: the bed preparation tests, which share one settled bed (settling is the
  # longest part under the sanitizers), and the rest of the engine's in two shards (gtest's
  # own sharding: alone, the rest took five times the bed tests), then the service's.
  # Tests that prepare beds of their own or integrate long fine-step runs are left to the
  # optimised suite above: under the sanitizers each takes one to three minutes and adds no
  # code path (bed files are also written and read by the store tests, imported bed files
  # parsed by their fuzzer below, with the sanitizers). The shared bed is settled locally (the
  # default), through the settling regions' copying and renumbering; the test comparing it with
  # a bed settled whole is left out, as that settling takes minutes here.
  engine_long='BedPreparation.CachedBed*:BedPreparation.KineticDamping*:BedPreparation.LocalSettling*:SmallBedImpact.*:Regression.*:Determinism.*:Energy.*:Restitution.*:HertzElastic.*:HardCase.SingleBeadLayer*:HardCase.ImportedBedWithSmall*:HardCase.Restitution*:HardCase.SizeRatio*:HardCase.ProjectileGrazing*:HardCase.BedImpact*:HardCase.AMillion*:ResourceEstimate.CountsTheBeds*:BedImport.ASettledBeds*:BedImport.LargerOverlapsAreSeparated*:BedImport.ABedSettledByLammps*'
  build-fuzz/tests/engine_tests --gtest_brief=1 --gtest_filter="BedPreparation.*-$engine_long" &
  bed_tests=$!
  GTEST_TOTAL_SHARDS=2 GTEST_SHARD_INDEX=0 build-fuzz/tests/engine_tests --gtest_brief=1 \
    --gtest_filter="*-BedPreparation.*:$engine_long" &
  first_shard=$!
  GTEST_TOTAL_SHARDS=2 GTEST_SHARD_INDEX=1 build-fuzz/tests/engine_tests --gtest_brief=1 \
    --gtest_filter="*-BedPreparation.*:$engine_long"
  build-fuzz/tests/server_tests --gtest_brief=1
  wait "$first_shard"
  wait "$bed_tests"

  stage "the threaded parts under ThreadSanitizer"
  # clang with LLVM's OpenMP runtime, whose Archer tool shows ThreadSanitizer OpenMP's barriers
  # (without it, or with GCC's libgomp, every parallel loop would be reported as a race).
  CC=clang CXX=clang++ cmake -S . -B build-tsan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="$sanitizer_opt_flags" -DCMAKE_UNITY_BUILD=ON -DDEMBUF_SANITIZE=thread > /dev/null
  cmake --build build-tsan --parallel "$(nproc)" --target engine_thread_tests dembufd
  OMP_TOOL_LIBRARIES="$(dirname "$(readlink -f "$(command -v clang)")")/../lib/libarcher.so"
  export OMP_TOOL_LIBRARIES
  # (tests/tsan.supp: gRPC's callback machinery, whose synchronization is in its uninstrumented
  # library.)
  export TSAN_OPTIONS="halt_on_error=1 ignore_noninstrumented_modules=1 second_deadlock_stack=1 suppressions=$PWD/tests/tsan.supp"
  # The engine's parallel force and integration loops (1, 2 and changing threads, and nested
  # in a team of workers, as a sweep runs them; bit-identical), the pair list built in
  # parallel chunks, the bed cache shared by threads, the run queue a sweep's workers take
  # their runs from, and the daemon end to end: its scheduler, worker pool, live streaming and
  # cancellation (the service test against a TSan-built daemon, driven by the optimised
  # client: the client's own threads are the sweep's, tested here in the engine's parts).
  # The two side by side: the service test waits for its jobs much of the time.
  build-tsan/tests/engine_thread_tests --gtest_brief=1 \
    --gtest_filter='Determinism.*:BedCacheThreads.*:PairList.*:RunQueue.*' &
  thread_tests=$!
  # The daemon's threads only: the local runs it compares with are left to the build above.
  DEMBUF_TEST_SKIP_LOCAL=1 bash tests/server/service_test.sh build/client/dembuf \
    build-tsan/server/dembufd
  # The streams' reactors and clock: refused, unread, cut off by the write deadline, and 160
  # open beside polling clients.
  /usr/bin/python3 tests/server/stream_load.py build/client/dembuf build-tsan/server/dembufd \
    build/python --users 20 --pollers 10 --calls 10
  wait "$thread_tests"
  unset OMP_TOOL_LIBRARIES TSAN_OPTIONS
fi

if [ "${FUZZ_SECONDS:-20}" != 0 ]; then
  stage "fuzzing"
  bash tests/fuzz/run.sh "${FUZZ_SECONDS:-20}"
fi
stage "all passed"
