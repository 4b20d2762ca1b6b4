#!/usr/bin/env bash
# Brings up a Slurm cluster of one node on this machine: for dembuf's tests of the Slurm
# executor, and for trying it before a lab's cluster. munged, slurmctld and slurmd start
# without systemd; everything Slurm writes (its configuration, state, spool, logs, the job
# completion log) stays in one folder, so nothing of a system's own Slurm is touched.
# Safe to run again: a cluster already running from the folder is left as it is.
#
# Usage: deploy/slurm/up.sh [DIR]        (default /var/lib/dembuf-slurm; needs root)
#   DEMBUF_SLURM_PORT   slurmctld's port, slurmd's is the next one (default 6917: beside,
#                       not on, Slurm's own 6817 and 6818)
# Then: export SLURM_CONF=DIR/slurm.conf   (sbatch, squeue, scancel, sinfo read it)
set -euo pipefail
dir=$(realpath -m "${1:-/var/lib/dembuf-slurm}")
port=${DEMBUF_SLURM_PORT:-6917}
here=$(dirname "$(readlink -f "$0")")

if [ "$(id -u)" -ne 0 ]; then
  exec sudo DEMBUF_SLURM_PORT="$port" bash "$0" "$dir"
fi

bash "$here/../install-deps.sh" munge slurmctld slurmd slurm-client > /dev/null

# A process from a pid file, if it still runs.
running() { [ -f "$1" ] && kill -0 "$(cat "$1")" 2>/dev/null; }

mkdir -p "$dir"/state "$dir"/spool "$dir"/log
conf=$dir/slurm.conf

# munge authenticates Slurm's messages; one munged serves every Slurm on the machine.
if ! pgrep -x munged > /dev/null; then
  mkdir -p /run/munge
  chown munge:munge /run/munge
  [ -f /etc/munge/munge.key ] || { mungekey --create 2> /dev/null || create-munge-key -f; }
  runuser -u munge -- /usr/sbin/munged
  touch "$dir/munged.started-here"
fi

# The machine's cores: nproc alone would follow an OMP_NUM_THREADS set for the caller.
cpus=$(env -u OMP_NUM_THREADS -u OMP_THREAD_LIMIT nproc)
if running "$dir/slurmctld.pid" && running "$dir/slurmd.pid"; then
  echo "slurm: already running from $dir"
else
  node=$(hostname -s)
  # Leave a fifth of the memory to the machine; jobs get 512 MB a CPU unless they ask.
  memory_mb=$(awk '/MemTotal/ { print int($2 / 1024 * 0.8) }' /proc/meminfo)
  sed -e "s|@DIR@|$dir|g" -e "s|@NODE@|$node|g" -e "s|@CPUS@|$cpus|g" \
      -e "s|@MEMORY_MB@|$memory_mb|g" -e "s|@CTLD_PORT@|$port|g" \
      -e "s|@SLURMD_PORT@|$((port + 1))|g" "$here/slurm.conf.in" > "$conf"
  chmod 644 "$conf"
  running "$dir/slurmctld.pid" || slurmctld -i -f "$conf"
  running "$dir/slurmd.pid" || slurmd -f "$conf"
fi

# Ready when the node takes jobs.
export SLURM_CONF=$conf
for _ in $(seq 60); do
  state=$(sinfo -h -N -o '%T' 2> /dev/null | head -1 || true)
  case "$state" in
    idle* | mixed* | allocated*)
      echo "slurm: node $(hostname -s) $state, $cpus CPUs; export SLURM_CONF=$conf"
      exit 0
      ;;
  esac
  sleep 0.5
done
echo "slurm: the node did not come up within 30 s; logs in $dir/log" >&2
tail -n 20 "$dir"/log/*.log >&2 || true
exit 1
