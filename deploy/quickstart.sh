#!/usr/bin/env bash
# Set-up command 1: install, build, and run the default paper scene locally (no daemon).
set -euo pipefail
cd "$(dirname "$0")/.."
bash deploy/build.sh
./build/client/dembuf run --out runs/default --force "$@"
