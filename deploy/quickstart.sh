#!/usr/bin/env bash
# Set-up command 1: install, build, and run a first impact on a bed locally (no daemon): the
# paper's E2 projectile on a 2 cm bed (prepared here, about two minutes on 2 cores), with F(t)
# drawn beside the same impact on the bare plate.
set -euo pipefail
cd "$(dirname "$0")/.."
bash deploy/build.sh
# A 3 cm source bed instead of 9 cm: one thickness needs no deeper bed to cut it from.
./build/client/dembuf run --preset e2 --set bed.thickness_m=0.02 \
  --set bed.source_thickness_m=0.03 --out runs/first --force "$@"
