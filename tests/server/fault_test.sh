#!/usr/bin/env bash
# Faults, each shown to lose nothing that was completed:
# 1. kill -9 of dembufd while a sweep runs, then a restart on the same database: every job is
#    still there, completed results are intact and identical, the interrupted job runs again.
# 2. kill -9 during a bed preparation: the job prepares the bed again and finishes.
# 3. kill -9 halfway through writing a result (the daemon's fault point
#    kill-during-result-write, between the series and the job's state): the half-written
#    result is rolled back, the job runs again and its result is complete.
# 4. A damaged database file: the daemon refuses to start, says why, and leaves it untouched.
# 5. Slurm cannot be reached: dembufd starts degraded, saying so; a queued job says why.
# 6. The disk fills while a job runs (a small tmpfs; needs root to mount, else skipped with a
#    notice): the daemon keeps serving, refuses new jobs with RESOURCE_EXHAUSTED, puts the
#    job back in the queue, and finishes it once space is freed; earlier results are intact.
# Usage: fault_test.sh DEMBUF DEMBUFD
. "$(dirname "$0")/lib.sh" "$1" "$2"
small_scene "$work/small.toml"
start_daemon "$work/dembuf.db" "$work/dembufd.log" --workers 1

# (A tall wall: on some beds the fastest impacts throw a bead 30 cm up, over the default rim.)
sweep=$("$dembuf" sweep "$work/small.toml" --set bed.seed=6 --set time.end_s=0.3 \
        --set cylinder.height_m=1 --vary projectile.speed_m_s=1,1.25,1.5,1.75,2,2.25,2.5,2.75 \
        2>/dev/null)
done_count() { "$dembuf" list --sweep "$sweep" --state done --limit 100 | tail -n +2 | wc -l; }
for _ in $(seq 1200); do
  [ "$(done_count)" -ge 2 ] && break
  sleep 0.1
done
[ "$(done_count)" -ge 2 ] || fail "no jobs finished before the crash"
"$dembuf" list --sweep "$sweep" --state done --limit 100 | awk 'NR > 1 { print $1 }' > "$work/done_before"
while read -r id; do
  "$dembuf" fetch "$id" --out "$work/before/$id" --no-plots > /dev/null
done < "$work/done_before"
running=$("$dembuf" list --sweep "$sweep" --limit 100 | awk '$2 == "running" || $2 == "preparing_bed" { print $1 }')

kill -9 "$daemon_pid"
wait "$daemon_pid" 2>/dev/null || true
start_daemon "$work/dembuf.db" "$work/dembufd.log" --workers 2

[ "$("$dembuf" list --sweep "$sweep" --limit 100 | tail -n +2 | wc -l)" = 8 ] || fail "jobs lost"
for id in $running; do
  grep -q "job $id was running when the daemon stopped; queued to run again" "$work/dembufd.log" ||
    fail "job $id was not re-queued"
done
for _ in $(seq 1800); do
  "$dembuf" status --sweep "$sweep" | grep -q "jobs: 8, done 8$" && break
  sleep 0.1
done
"$dembuf" status --sweep "$sweep" | grep -q "jobs: 8, done 8$" || fail "the sweep did not finish"
while read -r id; do
  "$dembuf" fetch "$id" --out "$work/after/$id" --no-plots > /dev/null
  for f in summary.json plate_force.csv; do
    cmp -s "$work/before/$id/$f" "$work/after/$id/$f" || fail "job $id: $f changed by the crash"
  done
done < "$work/done_before"
for id in $running; do
  "$dembuf" status "$id" | grep -q "attempts 2" || fail "job $id: $("$dembuf" status "$id")"
done

# kill -9 while a job prepares its bed: after the restart it prepares it again and finishes.
bedjob=$("$dembuf" submit "$work/small.toml" --set bed.seed=8 2>/dev/null)
wait_state "$bedjob" preparing_bed 60
kill -9 "$daemon_pid"
wait "$daemon_pid" 2>/dev/null || true
start_daemon "$work/dembuf.db" "$work/dembufd.log" --workers 2
wait_state "$bedjob" done 180
"$dembuf" status "$bedjob" | grep -q "attempts 2" || fail "bed job: $("$dembuf" status "$bedjob")"
stop_daemon

# kill -9 halfway through writing a result: the series is in the open transaction when the
# daemon dies. After the restart the job is not done (the write rolled back), runs again, and
# its result is complete and equal to a local run of the same scene.
DEMBUFD_FAULT=kill-during-result-write start_daemon "$work/dembuf.db" "$work/dembufd.log" \
  --workers 1
writejob=$("$dembuf" submit "$work/small.toml" --set time.end_s=0.2 2>/dev/null)
for _ in $(seq 1800); do
  kill -0 "$daemon_pid" 2>/dev/null || break
  sleep 0.1
done
kill -0 "$daemon_pid" 2>/dev/null && fail "the daemon did not stop at the fault point"
wait "$daemon_pid" 2>/dev/null || true
daemon_pid=""
start_daemon "$work/dembuf.db" "$work/dembufd.log" --workers 1
grep -q "job $writejob was running when the daemon stopped; queued to run again" \
  "$work/dembufd.log" || fail "the half-written job $writejob was not re-queued"
wait_state "$writejob" done 180
"$dembuf" status "$writejob" | grep -q "attempts 2" || fail "write job: $("$dembuf" status "$writejob")"
"$dembuf" fetch "$writejob" --out "$work/written" --no-plots > /dev/null
"$dembuf" run "$work/small.toml" --set time.end_s=0.2 --bed-cache "$work/local-beds" \
  --out "$work/local-written" > /dev/null 2>&1
cmp -s "$work/written/plate_force.csv" "$work/local-written/plate_force.csv" ||
  fail "the result written after the crash differs from a local run"
stop_daemon

# A damaged database: refused at start with a clear message, the file left exactly as it was.
cp "$work/dembuf.db" "$work/damaged.db"
# Overwrite the header of the schema's b-tree page (page 1, after the 100-byte file header).
printf 'this is not a b-tree page header' | dd of="$work/damaged.db" bs=1 seek=100 conv=notrunc \
  2> /dev/null
sum_before=$(sha256sum < "$work/damaged.db")
if "$dembufd" --listen 127.0.0.1:0 --db "$work/damaged.db" > "$work/damaged.log" 2>&1; then
  fail "dembufd started on a damaged database"
fi
grep -q "cannot be used.*untouched" "$work/damaged.log" || fail "no clear reason: $(cat "$work/damaged.log")"
[ "$(sha256sum < "$work/damaged.db")" = "$sum_before" ] || fail "the damaged database was changed"

# Slurm cannot be reached (sbatch and squeue answer as they do with slurmctld down): dembufd
# starts degraded, saying so, and the queued job waits, saying why in status (it had no note,
# and a submission that failed this way failed the job).
mkdir "$work/no-slurm"
for program in sbatch squeue scontrol scancel; do
  printf '#!/bin/sh\necho "%s: error: Batch job submission failed: Unable to contact slurm controller (connect failure)" >&2\nexit 1\n' \
    "$program" > "$work/no-slurm/$program"
  chmod +x "$work/no-slurm/$program"
done
printf 'access = "local"\nexecutor = "slurm"\n[slurm]\nwork_dir = "%s"\ndembuf = "%s"\npoll_s = 0.2\n' \
  "$work/slurm-work" "$dembuf" > "$work/no-slurm.toml"
PATH="$work/no-slurm:$PATH" start_daemon "$work/no-slurm.db" "$work/no-slurm.log" \
  --config "$work/no-slurm.toml"
grep -q "serving anyway, jobs stay queued until Slurm answers" "$work/no-slurm.log" ||
  fail "no word of the unreachable Slurm at the start: $(cat "$work/no-slurm.log")"
waiting=$("$dembuf" -q submit --set bed.thickness_m=0)
[ -n "$waiting" ] || fail "no job submitted to the degraded daemon"
for _ in $(seq 50); do
  "$dembuf" status "$waiting" | grep -q "^note: waiting: cannot reach Slurm (.*Unable to contact.*)$" && break
  sleep 0.1
done
"$dembuf" status "$waiting" | grep -q "^note: waiting: cannot reach Slurm" ||
  fail "the waiting job does not say why: $("$dembuf" status "$waiting")"
[ "$(job_state "$waiting")" = queued ] || fail "the job is $(job_state "$waiting"), not queued"
stop_daemon

# The disk fills while a job runs.
disk=$work/disk
mkdir "$disk"
if ! mount -t tmpfs -o size=4m,mode=0700 tmpfs "$disk" 2> /dev/null; then
  echo "fault test passed (disk-full case skipped: mounting a tmpfs needs root)"
  exit 0
fi
trap 'rc=$?; [ -z "$daemon_pid" ] || kill -9 "$daemon_pid" 2>/dev/null || true
      umount "$disk" 2>/dev/null || true; rm -rf "$work"; exit $rc' EXIT
start_daemon "$disk/dembuf.db" "$work/full.log" --workers 1 --storage-retry 1
first=$("$dembuf" submit "$work/small.toml" --set time.end_s=0.3 2>/dev/null)
wait_state "$first" done 120
"$dembuf" fetch "$first" --out "$work/full-before" --no-plots > /dev/null
# A job with a bed of its own, so that the disk is full by the time it ends (a 1 m wall: in
# 0.3 s its splash throws a bead over a 30 cm one).
second=$("$dembuf" submit "$work/small.toml" --set time.end_s=0.3 --set bed.seed=9 \
         --set cylinder.height_m=1 2>/dev/null)
dd if=/dev/zero of="$disk/filler" bs=64k 2> /dev/null || true
for _ in $(seq 1200); do
  grep -q "job $second: the server's disk is full" "$work/full.log" && break
  sleep 0.1
done
grep -q "job $second: the server's disk is full" "$work/full.log" || fail "the full disk went unnoticed"
"$dembuf" server-info > /dev/null || fail "the daemon stopped serving on a full disk"
if "$dembuf" submit "$work/small.toml" > "$work/refused.txt" 2>&1; then
  fail "a job was accepted on a full disk"
fi
grep -q "disk is full" "$work/refused.txt" || fail "unclear refusal: $(cat "$work/refused.txt")"
rm "$disk/filler"
wait_state "$second" done 120
"$dembuf" fetch "$first" --out "$work/full-after" --no-plots > /dev/null
for f in summary.json plate_force.csv; do
  cmp -s "$work/full-before/$f" "$work/full-after/$f" || fail "job $first: $f changed on a full disk"
done
stop_daemon
umount "$disk"
echo "fault test passed: $(wc -l < "$work/done_before") results kept, jobs re-run: $running," \
  "a bed preparation redone, a half-written result redone, a damaged database refused," \
  "a full disk survived"
