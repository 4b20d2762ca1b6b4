#!/usr/bin/env bash
# Stops the one-node Slurm that up.sh started from DIR (its jobs end with it), and munged if
# up.sh started it. The folder stays, with the logs; --purge removes it.
#
# Usage: deploy/slurm/down.sh [DIR] [--purge]    (default /var/lib/dembuf-slurm; needs root)
set -euo pipefail
dir=$(realpath -m "${1:-/var/lib/dembuf-slurm}")
purge=${2:-}

if [ "$(id -u)" -ne 0 ]; then
  exec sudo bash "$0" "$dir" "$purge"
fi

# Stops the process of a pid file and waits up to 10 s for it to go.
stop() {
  local pid
  [ -f "$1" ] || return 0
  pid=$(cat "$1")
  kill "$pid" 2> /dev/null || return 0
  for _ in $(seq 100); do
    kill -0 "$pid" 2> /dev/null || return 0
    sleep 0.1
  done
  kill -9 "$pid" 2> /dev/null || true
}

stop "$dir/slurmd.pid"
stop "$dir/slurmctld.pid"
if [ -f "$dir/munged.started-here" ]; then
  pkill -x munged || true
  # Gone before this returns, so that an up.sh right after starts a new one.
  for _ in $(seq 100); do
    pgrep -x munged > /dev/null || break
    sleep 0.1
  done
  rm -f "$dir/munged.started-here"
fi
if [ "$purge" = --purge ]; then
  rm -rf "$dir"
fi
echo "slurm: stopped ($dir)"
