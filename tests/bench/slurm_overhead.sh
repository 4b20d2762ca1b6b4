#!/usr/bin/env bash
# What running on Slurm costs per job: the same sweep (N points of a small scene, its bed
# prepared beforehand) through a dembufd with the thread executor (2 workers x 1 thread) and
# one with the Slurm executor (1 CPU per job) on the one-node Slurm of deploy/slurm/, both
# with the same two cores. Prints the wall time of each, from submission to the last job
# done, the overhead per job, and the same as JSON (slurm_overhead.json).
# Usage: tests/bench/slurm_overhead.sh [POINTS]   (from the source folder, after a build)
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
points=${1:-12}
. "$root/tests/server/lib.sh" "$root/build/client/dembuf" "$root/build/server/dembufd"
cluster=$work/cluster
export SLURM_CONF=$cluster/slurm.conf
export DEMBUF_SLURM_PORT=$((20000 + RANDOM % 20000))
trap 'rc=$?; [ -z "${daemon_pid:-}" ] || kill -9 "$daemon_pid" 2> /dev/null || true
      bash "$root/deploy/slurm/down.sh" "$cluster" --purge > /dev/null 2>&1 || true
      rm -rf "$work"; exit $rc' EXIT
bash "$root/deploy/slurm/up.sh" "$cluster" > /dev/null
small_scene "$work/scene.toml"
speeds=$(seq -s, 1 "$points")

# sweep_time: submits the sweep, waits for its last job; prints seconds. Jobs 1.. are the
# bed's warm-up job, then the sweep's.
sweep_time() {
  local start end last=$((points + 1))
  start=$(date +%s.%N)
  "$dembuf" sweep "$work/scene.toml" --vary "projectile.speed_m_s=$speeds" > /dev/null
  wait_state "$last" done 1200
  for id in $(seq 2 "$last"); do wait_state "$id" done 60; done
  end=$(date +%s.%N)
  awk -v a="$start" -v b="$end" 'BEGIN { print b - a }'
}
warm_up() {
  "$dembuf" submit "$work/scene.toml" > /dev/null
  wait_state 1 done 300
}

start_daemon "$work/threads.db" "$work/threads.log" --workers 2 --threads-per-job 1
warm_up
threads=$(sweep_time)
stop_daemon

cat > "$work/slurm.toml" <<TOML
access = "local"
executor = "slurm"
[slurm]
work_dir = "$work/shared"
dembuf = "$dembuf"
cpus_per_job = 1
poll_s = 1.0
TOML
start_daemon "$work/slurm.db" "$work/slurm.log" --config "$work/slurm.toml"
warm_up
slurm=$(sweep_time)
stop_daemon

overhead=$(awk -v s="$slurm" -v t="$threads" -v n="$points" 'BEGIN { print (s - t) / n }')
printf 'sweep of %d jobs, 2 cores: threads %.1f s, Slurm %.1f s; Slurm overhead %.2f s per job (poll_s = 1)\n' \
  "$points" "$threads" "$slurm" "$overhead"
printf '{"jobs": %d, "threads_s": %.3f, "slurm_s": %.3f, "overhead_s_per_job": %.3f, "poll_s": 1.0}\n' \
  "$points" "$threads" "$slurm" "$overhead" > slurm_overhead.json
