#!/usr/bin/env bash
# Set-up command 2: install, build, and run every test.
set -euo pipefail
cd "$(dirname "$0")/.."
bash deploy/build.sh
cd build
ctest --output-on-failure --parallel "$(nproc)" --timeout 900
