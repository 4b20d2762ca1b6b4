#!/usr/bin/env bash
# Installs the dependencies and builds dembuf (Release) into ./build. Used by the two set-up
# commands of README.md.
set -euo pipefail
cd "$(dirname "$0")/.."
bash deploy/install-deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build build --parallel "$(nproc)"
