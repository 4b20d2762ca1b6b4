#!/usr/bin/env bash
# Installs the dependencies and builds dembuf (Release) into ./build. Used by the two set-up
# commands of README.md.
set -euo pipefail
cd "$(dirname "$0")/.."
bash deploy/install-deps.sh
# A unity build compiles each target's sources in batches, parsing the heavy headers (gRPC,
# Protobuf, Eigen, toml11) once a batch: it takes 4 minutes here instead of nearly 7, with the
# same results bit for bit (the golden test). Developers editing one file may prefer
# -DCMAKE_UNITY_BUILD=OFF.
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_UNITY_BUILD=ON
cmake --build build --parallel "$(nproc)"
