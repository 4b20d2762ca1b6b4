#!/usr/bin/env bash
# Set-up command 2: install, build, and run every test.
set -euo pipefail
cd "$(dirname "$0")/.."
bash deploy/build.sh
cd build
# ctest runs two test programs at once; OpenMP threads that spin while waiting would then
# steal each other's cores.
export OMP_WAIT_POLICY=passive
ctest --output-on-failure --parallel "$(nproc)" --timeout 900
