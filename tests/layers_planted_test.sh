#!/usr/bin/env bash
# The layers' check can fail: on a copy of the sources it must refuse an include cycle planted
# inside one room of engine/study, and a room that includes one above it.
# Usage: layers_planted_test.sh SOURCE_DIR
set -eu
root=$1
check=$root/tests/dependency_check.sh
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

copy_sources() {
  rm -rf "$work/src" && mkdir -p "$work/src/server" "$work/src/client"
  cp -r "$root/engine" "$work/src/"
  cp "$root"/server/*.h "$work/src/server/"
  cp "$root"/client/*.h "$work/src/client/"
}

expect_failure() {
  local what=$1 pattern=$2 output
  if output=$(bash "$check" "$work/src" 2>&1); then
    echo "FAIL: the check passed $what"
    exit 1
  fi
  if ! grep -q "$pattern" <<<"$output"; then
    echo "FAIL: the check refused $what without saying \"$pattern\":"
    echo "$output"
    exit 1
  fi
  echo "refused $what:"
  echo "$output" | sed 's/^/  /'
}

copy_sources
bash "$check" "$work/src" >/dev/null || { echo "FAIL: the unchanged copy does not pass"; exit 1; }

# A cycle inside the bed room: bed_io.cpp includes bed.h, which includes bed_io.h.
study=$work/src/engine/study
sed -i 's|^#pragma once|#pragma once\n#include "dembuf/study/bed/bed_io.h"|' "$study/include/dembuf/study/bed/bed.h"
echo '#include "dembuf/study/bed/bed.h"' >>"$study/src/bed/bed_io.cpp"
expect_failure "a cycle bed -> bed_io -> bed" "include cycle"

# The scene room reaching up into the run room.
copy_sources
echo '#include "dembuf/study/run/run_job.h"' >>"$study/src/scene/scene_fields.cpp"
expect_failure "scene including run" "includes a room above it"
echo "layers: a planted cycle and a planted room inversion are both refused"
