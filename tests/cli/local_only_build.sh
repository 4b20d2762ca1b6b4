#!/usr/bin/env bash
# The engine and the CLI's local commands build without the service's libraries
# (-DDEMBUF_SERVICE=OFF): the binary links no gRPC, Protobuf or SQLite, runs a scene, and
# names the remote commands it lacks as unknown.
# Usage: local_only_build.sh SOURCE_DIR
set -eu
src=$1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }

# Unoptimised, without debugging information (-O0 alone) and in a unity build: it compiles
# fastest (86 s on one core here against about 160 s file by file), and the run below is a
# bare-plate impact.
cmake -S "$src" -B "$work/build" -G Ninja -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG=-O0 \
  -DCMAKE_UNITY_BUILD=ON \
  -DDEMBUF_SERVICE=OFF \
  -DDEMBUF_BUILD_TESTS=OFF > "$work/configure.log" 2>&1 || { cat "$work/configure.log"; fail "configure"; }
if grep -E '^(gRPC_DIR|Protobuf_INCLUDE_DIR|SQLite3_INCLUDE_DIR)' "$work/build/CMakeCache.txt"; then
  fail "the configuration looked for the service's libraries"
fi
cmake --build "$work/build" --target dembuf > "$work/build.log" 2>&1 ||
  { tail -30 "$work/build.log"; fail "build"; }
dembuf="$work/build/client/dembuf"
if ldd "$dembuf" | grep -iE 'grpc|protobuf|sqlite'; then fail "dembuf links a service library"; fi

"$dembuf" run --set projectile.mass_kg=0.3 --set projectile.speed_m_s=5 \
  --set projectile.height_m=0.30 --out "$work/run" > "$work/run.log" || fail "local run"
grep -q '"peak_plate_force_N"' "$work/run/summary.json" || fail "no summary"
set +e
"$dembuf" submit --preset e2 > "$work/submit.log" 2>&1
code=$?
set -e
[ "$code" = 2 ] || fail "submit in a local-only build exited $code, expected 2"
grep -q "submit" "$work/submit.log" || fail "the refusal does not name the command"
echo "local-only build: no service library linked, a local run works, remote commands absent"
