#!/usr/bin/env bash
# The layers' check can fail: on a copy of the sources it must refuse, in engine/study, server/
# and client/ alike, an include cycle planted inside one room and a room that includes one
# above it; and a daemon's file in the client, a source outside every room.
# Usage: layers_planted_test.sh SOURCE_DIR
set -eu
root=$1
check=$root/tests/dependency_check.sh
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

copy_sources() {
  rm -rf "$work/src" && mkdir -p "$work/src"
  cp -r "$root/engine" "$root/server" "$root/client" "$work/src/"
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
# A source of study outside its rooms.
copy_sources
touch "$study/src/loose.cpp"
expect_failure "a study source outside the rooms" "files of engine/study outside its rooms"

# The same in the daemon: the jobs' live state including the feed that includes it, the store
# reaching up into the doors.
copy_sources
server=$work/src/server
sed -i 's|^#pragma once|#pragma once\n#include "jobs/job_feed.h"|' "$server/jobs/live_job.h"
expect_failure "a cycle live_job -> job_feed -> live_job" "include cycle inside server"
copy_sources
echo '#include "doors/service.h"' >>"$server/store/store.cpp"
expect_failure "store including doors" "(room store) includes a room above it"
# The same by a relative path.
copy_sources
echo '#include "../doors/service.h"' >>"$server/store/store.cpp"
expect_failure "store including doors by a relative path" "includes by a relative path"
# A page of the web door (a subfolder) reaching up into the process.
copy_sources
echo '#include "process/config.h"' >>"$server/doors/web/web_views.cpp"
expect_failure "the web pages including process" "(room doors) includes a room above it"

# And in the client: the terminal reaching up into the local commands; the client including a
# room of the daemon; a source left outside every room.
copy_sources
client=$work/src/client
echo '#include "local/plots.h"' >>"$client/terminal/progress.cpp"
expect_failure "terminal including local" "(room terminal) includes a room above it"
copy_sources
echo '#include "jobs/slurm.h"' >>"$client/local/plots.cpp"
expect_failure "the client including the daemon's jobs" "includes a header of the daemon"
copy_sources
sed -i 's|^#pragma once|#pragma once\n#include "local/compare.h"|' "$client/local/plots.h"
expect_failure "a cycle plots -> compare -> plots" "include cycle inside client"
copy_sources
touch "$client/loose.cpp"
expect_failure "a client source outside the rooms" "files of client outside its rooms"
# The daemon including the client, and a daemon's source outside its rooms.
copy_sources
echo '#include "local/commands.h"' >>"$server/process/config.cpp"
expect_failure "the daemon including the client's commands" "includes a header of the client"
copy_sources
touch "$server/loose.h"
expect_failure "a daemon source outside the rooms" "files of server outside its rooms"
echo "layers: planted cycles, room inversions, a crossing between the programs and a stray file are all refused"
