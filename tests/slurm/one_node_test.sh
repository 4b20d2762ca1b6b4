#!/usr/bin/env bash
# The one-node Slurm of deploy/slurm/ that the Slurm executor's tests run on: it comes up
# (twice in a row without harm), runs two one-CPU jobs side by side, holds a job back until
# the job it depends on has ended well, cancels a job with scancel, and goes down.
# Usage: one_node_test.sh SOURCE_DIR
set -euo pipefail
root=$1
dir=$(mktemp -d)
export SLURM_CONF=$dir/slurm.conf
# Ports of its own, so that it does not meet another cluster of these tests or the machine's.
export DEMBUF_SLURM_PORT=$((20000 + RANDOM % 20000))
trap 'bash "$root/deploy/slurm/down.sh" "$dir" --purge > /dev/null' EXIT
fail() {
  echo "FAIL: $*"
  squeue -h -t all -o '%i|%j|%T|%r' || true
  tail -n 20 "$dir"/log/*.log || true
  exit 1
}

bash "$root/deploy/slurm/up.sh" "$dir"
again=$(bash "$root/deploy/slurm/up.sh" "$dir")
[[ "$again" == *"already running"* ]] || fail "up.sh twice: $again"
[ "$(pgrep -fc "slurmctld -i -f $dir/")" = 1 ] || fail "one slurmctld after two up.sh"

# The state of job $1 in Slurm, as squeue says it.
state() { squeue -h -t all -j "$1" -o '%T' 2> /dev/null || true; }
# Waits up to $3 seconds for job $1 to reach state $2.
await() {
  for _ in $(seq $(($3 * 5))); do
    [ "$(state "$1")" = "$2" ] && return 0
    sleep 0.2
  done
  fail "job $1 is $(state "$1"), not $2, after $3 s"
}

# Two one-CPU jobs run at once on the two cores (cons_tres, CR_Core_Memory).
a=$(sbatch --parsable -J dembuf-test-a -c 1 --mem 64 -o "$dir/a.out" --wrap 'sleep 3; echo a')
b=$(sbatch --parsable -J dembuf-test-b -c 1 --mem 64 -o "$dir/b.out" --wrap 'sleep 3; echo b')
# A job that waits for a, as an impact waits for its bed.
c=$(sbatch --parsable -J dembuf-test-c -c 1 --mem 64 -o "$dir/c.out" \
      --dependency="afterok:$a" --wrap 'echo c')
await "$a" RUNNING 20
await "$b" RUNNING 20
[ "$(squeue -h -j "$c" -o '%T|%r')" = "PENDING|Dependency" ] || fail "c does not wait for a"
await "$a" COMPLETED 20
await "$c" COMPLETED 20
await "$b" COMPLETED 20
[ "$(cat "$dir/a.out" "$dir/b.out" "$dir/c.out" | tr -d '\n')" = abc ] || fail "job outputs"

# scancel ends a running job, and Slurm says so.
d=$(sbatch --parsable -J dembuf-test-d -c 1 --mem 64 -o /dev/null --wrap 'sleep 60')
await "$d" RUNNING 20
scancel "$d"
await "$d" CANCELLED 20
grep -q "JobId=$d .*JobState=CANCELLED" "$dir/log/jobcomp.txt" || fail "job completion log"

bash "$root/deploy/slurm/down.sh" "$dir" > /dev/null
! pgrep -f "slurmctld -i -f $dir/" > /dev/null || fail "slurmctld still runs after down.sh"
echo "slurm: one node up, jobs side by side, a dependency, scancel, down"
