#!/usr/bin/env bash
# The Slurm executor on the one-node Slurm of deploy/slurm/, against real dembufd daemons:
#   1. a three-point sweep through executor = "slurm" gives the thread executor's results, bit
#      for bit (summaries but for their wall time, the stored series, the result files), its two bed
#      stages each prepared by one Slurm job, and a second user's sweep prepares none;
#   2. watch shows a Slurm job's samples while it runs, and cancel ends it in Slurm;
#   3. kill -9 of dembufd mid-sweep, and a restart: every job submitted once, all finish;
#   4. a job cancelled with scancel from outside ends failed, saying CANCELLED;
#   5. cancelling a sweep whose bed is being prepared cancels the bed's Slurm job; a bed
#      that fails fails its job, and the array's other task (ended by Slurm) runs again;
#   6. a job past its time limit ends failed, saying TIMEOUT (found by its daemon restarted
#      after the job ended);
#   7. a 12-point parameter table goes as one job array of at most 4 tasks at once, its
#      comment and account naming its user, and gives the local sweep's long table, byte for
#      byte;
#   8. a stored job whose scene this daemon cannot read, or whose folder it may not use, fails,
#      saying why, and the jobs after it still run, alone or in an array;
#   9. a job whose folder cannot be made on a full disk waits, saying why, and runs later;
#  10. an sbatch that queues a job but prints no id: the job is found by name, not sent twice;
#  11. a job cancelled while its bed's sbatch prints no id: the bed's Slurm job is cancelled;
#  12. a bed's Slurm job shown only after its record was cancelled is taken up, not sent twice;
#  13. an sbatch that queues a job twice and prints no id: the newer copy runs, the older is
#      cancelled.
# Usage: executor_test.sh SOURCE_DIR DEMBUF DEMBUFD
set -euo pipefail
root=$1
. "$root/tests/server/lib.sh" "$2" "$3"
cluster=$work/cluster
export SLURM_CONF=$cluster/slurm.conf
export DEMBUF_SLURM_PORT=$((20000 + RANDOM % 20000))
trap 'rc=$?; for p in $(jobs -p) ${daemon_pid:-}; do kill -9 "$p" 2> /dev/null || true; done
      bash "$root/deploy/slurm/down.sh" "$cluster" --purge > /dev/null 2>&1 || true
      umount "$work/full" 2> /dev/null || true; rm -rf "$work"; exit $rc' EXIT
bash "$root/deploy/slurm/up.sh" "$cluster" > /dev/null

# A daemon with the Slurm executor: slurm_config FILE WORK_DIR [more [slurm] lines].
slurm_config() {
  {
    echo 'access = "local"'
    echo 'executor = "slurm"'
    echo '[slurm]'
    echo "work_dir = \"$2\""
    echo "dembuf = \"$dembuf\""
    echo 'poll_s = 0.3'
    shift 2
    for line in "$@"; do echo "$line"; done
  } > "$1"
}
# slurm_state ID: what Slurm says of one of its jobs.
slurm_state() { squeue -h -t all -j "$1" -o '%T' 2> /dev/null || true; }
# wait_cancelled ID: waits up to 10 s for Slurm to say its job ID is CANCELLED; fails if not.
wait_cancelled() {
  for _ in $(seq 100); do
    [ "$(slurm_state "$1")" = CANCELLED ] && return
    sleep 0.1
  done
  fail "Slurm job $1 is $(slurm_state "$1"), not cancelled ($2)"
}
# wait_slurm_job STATES PREFIX: the id of a Slurm job in one of STATES whose name begins with
# PREFIX, once there is one (30 s at most; "" when none came).
wait_slurm_job() {
  local id=""
  for _ in $(seq 300); do
    id=$(squeue -h -t "$1" -o '%i|%j' | awk -F'|' -v p="$2" 'index($2, p) == 1 { print $1; exit }')
    [ -n "$id" ] && break
    sleep 0.1
  done
  echo "$id"
}
# wait_until WHAT COMMAND...: waits up to 30 s for COMMAND to succeed; fails saying WHAT if not.
wait_until() {
  local what=$1
  shift
  for _ in $(seq 300); do
    "$@" && return
    sleep 0.1
  done
  fail "$what"
}
# slurm_id JOB: the Slurm job of a dembuf job, from status.
slurm_id() { "$dembuf" status "$1" | sed -n 's/^Slurm job \([0-9]*\).*/\1/p'; }
small_scene "$work/scene.toml"
# Runs of about 7 s per simulated second on one core, once the bed is ready.
long=(--set time.output_interval_s=1e-3 --set projectile.speed_m_s=0.5)
# Part 1's sweep takes a snapshot 1 ms after contact: its files come back from the nodes.
snap=(--set 'output.snapshot_after_contact_s=[0.001]')

# Part 6's job, with a time limit of 5 s (a minute for Slurm), from a daemon of its own that
# stops while the job runs.
slurm_config "$work/short.toml" "$work/short" 'time_limit = "0:05"'
start_daemon "$work/short.db" "$work/short.log" --config "$work/short.toml"
late=$("$dembuf" submit "$work/scene.toml" "${long[@]}" --set time.end_s=30 | grep -o '[0-9]*' | head -1)
for _ in $(seq 100); do
  [ -n "$(slurm_id "$late")" ] && break
  sleep 0.1
done
[ -n "$(slurm_id "$late")" ] || fail "the time-limited job was not submitted"
stop_daemon

echo "== 1. a sweep on Slurm and on threads, bit for bit ($SECONDS s)"
slurm_config "$work/slurm.toml" "$work/shared"
start_daemon "$work/slurm.db" "$work/slurm.log" --config "$work/slurm.toml"
"$dembuf" sweep "$work/scene.toml" "${snap[@]}" --vary projectile.speed_m_s=1,2,3 > /dev/null
# While its bed is prepared, status says what the job waits for.
for _ in $(seq 100); do
  said=$("$dembuf" status 1 || true)
  [[ "$said" == *"pending: Dependency"* ]] && break
  sleep 0.1
done
[[ "$said" == *"pending: Dependency"* ]] || fail "job 1 does not say it waits for its bed: $said"
for id in 1 2 3; do wait_state $id done 120; done
[ "$(slurm_id 1)" -gt 0 ] || fail "job 1 has no Slurm job"
# A second user's sweep on the same beds prepares none.
"$dembuf" --owner second sweep "$work/scene.toml" --vary projectile.speed_m_s=1,2 > /dev/null
for id in 4 5; do wait_state $id done 120; done
daemon_id=$(sed -n 's/.*jobs run on Slurm as dembuf-\([0-9a-f]*\)-.*/\1/p' "$work/slurm.log" | tail -1)
bed_jobs=$(squeue -h -t all -o '%j' | grep -c -- "^dembuf-$daemon_id-bed-" || true)
[ "$bed_jobs" = 2 ] || fail "$bed_jobs bed jobs in Slurm, not 2 (a source and its cut)"
stop_daemon
start_daemon "$work/threads.db" "$work/threads.log"
"$dembuf" sweep "$work/scene.toml" "${snap[@]}" --vary projectile.speed_m_s=1,2,3 > /dev/null
for id in 1 2 3; do wait_state $id done 120; done
stop_daemon
python3 - "$work/slurm.db" "$work/threads.db" <<'PY'
import json, sqlite3, sys
def results(path):
    db = sqlite3.connect(path)
    out = {}
    for job, summary in db.execute("SELECT job_id, summary_json FROM results WHERE job_id <= 3"):
        s = json.loads(summary)
        s.pop("wall_time_s")
        s.pop("provenance")  # where and when it ran
        # The series' bytes: rows of six doubles, whatever the chunks they were stored in.
        series = b"".join(row[0] for row in db.execute(
            "SELECT data FROM series_chunks WHERE job_id = ? ORDER BY first_index", (job,)))
        files = list(db.execute(
            "SELECT path, data FROM job_files WHERE job_id = ? ORDER BY path", (job,)))
        out[job] = (s, series, files)
    return out
slurm, threads = results(sys.argv[1]), results(sys.argv[2])
assert len(slurm) == 3 and slurm.keys() == threads.keys(), (slurm.keys(), threads.keys())
for job in slurm:
    assert slurm[job][0] == threads[job][0], f"job {job}: summaries differ"
    assert slurm[job][1] == threads[job][1] and slurm[job][1], f"job {job}: series differ"
    # The snapshot's seven files, its snapshots.pvd, the container and the bare-plate series
    # run for lambda.
    paths = [path for path, _ in slurm[job][2]]
    assert slurm[job][2] == threads[job][2] and len(paths) == 10 and \
        "plate_force_bare.csv" in paths and "container.vtp" in paths, \
        f"job {job}: result files {paths}"
print("3 jobs: summaries, series, snapshot and bare-plate files identical;",
      sum(len(v[1]) for v in slurm.values()) // 48, "samples compared")
PY

echo "== 2. watch a Slurm job live, then cancel it ($SECONDS s)"
start_daemon "$work/slurm.db" "$work/slurm.log" --config "$work/slurm.toml"
watched=$("$dembuf" submit "$work/scene.toml" "${long[@]}" --set time.end_s=4 | grep -o '[0-9]*' | head -1)
wait_state "$watched" running 60
"$dembuf" watch "$watched" --csv > "$work/watch.csv" 2> /dev/null &
watcher=$!
sleep 3
rows=$(grep -c '^[0-9]' "$work/watch.csv" || true)
[ "$(job_state "$watched")" = running ] || fail "job $watched ended before the check"
[ "$rows" -ge 10 ] || fail "watch showed $rows samples of a running Slurm job in 3 s"
echo "watch: $rows samples in 3 s while job $watched runs"
sid=$(slurm_id "$watched")
"$dembuf" cancel "$watched" > /dev/null
wait_state "$watched" cancelled 60
[ "$(slurm_state "$sid")" = CANCELLED ] || fail "Slurm job $sid is $(slurm_state "$sid")"
wait "$watcher" || true

echo "== 3. kill -9 of the daemon mid-sweep, and a restart ($SECONDS s)"
"$dembuf" sweep "$work/scene.toml" "${long[@]}" --vary time.end_s=0.6,0.8,1.0 > /dev/null
first=$((watched + 1))
wait_state "$first" running 60
kill -9 "$daemon_pid"
wait "$daemon_pid" 2> /dev/null || true
daemon_pid=""
start_daemon "$work/slurm.db" "$work/slurm.log" --config "$work/slurm.toml"
for id in $first $((first + 1)) $((first + 2)); do wait_state $id done 180; done
# The sweep is one job array, named by its first job: each job is one task of it.
arrays=$(squeue -h -r -t all -o '%j|%F' | grep -c -- "^dembuf-$daemon_id-array-$first|" || true)
for task in 0 1 2; do
  n=$(squeue -h -r -t all -o '%j|%K' | grep -c -- "^dembuf-$daemon_id-array-$first|$task\$" || true)
  [ "$n" = 1 ] || fail "job $((first + task)) was submitted to Slurm $n times (task $task)"
done
[ "$arrays" = 3 ] || fail "$arrays tasks of job arrays named for job $first, not 3"
[ "$(squeue -h -r -t all -o '%j|%F' | grep -- "^dembuf-$daemon_id-array-$first|" | sort -u | wc -l)" = 1 ] ||
  fail "the sweep of job $first went to Slurm as more than one array"
echo "after the restart: 3 jobs done, one job array, each task submitted once"

echo "== 4. scancel from outside ($SECONDS s)"
outside=$("$dembuf" submit "$work/scene.toml" "${long[@]}" --set time.end_s=4 | grep -o '[0-9]*' | head -1)
wait_state "$outside" running 60
scancel "$(slurm_id "$outside")"
wait_state "$outside" failed 60
echo "$("$dembuf" status "$outside" | grep note || true)"
said=$("$dembuf" status "$outside" || true)
[[ "$said" == *"CANCELLED"* ]] || fail "no CANCELLED in: $said"

echo "== 5. a sweep cancelled while its bed is prepared ($SECONDS s)"
"$dembuf" sweep "$work/scene.toml" --set bed.seed=7 --set bed.source_thickness_m=0.03 \
  --vary projectile.speed_m_s=1,2 > /dev/null
sweep=$("$dembuf" list --sweeps --limit 1 | awk 'NR == 2 { print $1 }')
source_job=$(wait_slurm_job running "dembuf-$daemon_id-bed-")
[ -n "$source_job" ] || fail "no bed job runs for the new sweep"
"$dembuf" cancel --sweep "$sweep" > /dev/null
wait_cancelled "$source_job" "the bed job of a cancelled sweep"
echo "bed job $source_job cancelled with its sweep"

echo "== 5b. one bed of a sweep's job array fails: its job fails, the other runs again ($SECONDS s)"
# Two seeds, two beds; the array waits for both, and Slurm ends it when one fails.
"$dembuf" sweep "$work/scene.toml" --set bed.source_thickness_m=0.03 --vary bed.seed=21,22 \
  --json > "$work/two.json"
read -r lost kept < <(python3 -c 'import json, sys; print(*json.load(open(sys.argv[1]))["job_ids"])' "$work/two.json")
bed=$("$dembuf" status "$lost" | sed -n 's/^scene .*, bed \([0-9a-f]*\).*/\1/p')
[ -n "$bed" ] || fail "status $lost names no bed: $("$dembuf" status "$lost")"
bed_job=$(wait_slurm_job all "dembuf-$daemon_id-bed-$bed")
[ -n "$bed_job" ] || fail "no Slurm job prepares job $lost's bed $bed"
scancel "$bed_job"
wait_state "$lost" failed 120
wait_state "$kept" done 240
grep -q "job $kept: queued again: Slurm ended its job array" "$work/slurm.log" ||
  fail "job $kept was not queued again after its array ended"
echo "job $lost failed with its bed; job $kept, ended with the array, ran again and is done"
stop_daemon

echo "== 6. past the time limit ($SECONDS s)"
# Submitted first (below): Slurm counts limits in whole minutes and looks at them every
# half minute or so, so the job runs meanwhile, its daemon stopped; the daemon, started
# again, finds it ended and says why.
start_daemon "$work/short.db" "$work/short.log" --config "$work/short.toml"
wait_state "$late" failed 120
said=$("$dembuf" status "$late" || true)
[[ "$said" == *"TIMEOUT"* ]] || fail "no TIMEOUT in: $said"
echo "$said" | grep note
stop_daemon

echo "== 7. a 12-point table as one job array, accounted to its user ($SECONDS s)"
slurm_config "$work/array.toml" "$work/array" 'array_limit = 4' 'accounts = {second = "proj-b"}'
start_daemon "$work/array.db" "$work/array.log" --config "$work/array.toml"
array_daemon=$(sed -n 's/.*jobs run on Slurm as dembuf-\([0-9a-f]*\)-.*/\1/p' "$work/array.log" | tail -1)
# Bare-plate impacts (no bed to prepare), two fields and the seed as columns.
bare=(--preset e2 --set bed.thickness_m=0 --set time.output_interval_s=1e-4)
{
  printf 'projectile.speed_m_s\tprojectile.mass_kg\tbed.seed\n'
  for speed in 1 2 3 4 5 6; do printf '%s\t0.%s\t1\n%s\t0.3\t2\n' "$speed" "$speed" "$speed"; done
} > "$work/points.tsv"
sweep=$("$dembuf" --owner second sweep "${bare[@]}" --table "$work/points.tsv" 2> "$work/err") ||
  fail "the table sweep: $(cat "$work/err")"
timeout 300 "$dembuf" watch --sweep "$sweep" > "$work/watch" || fail "watch --sweep: $(tail -3 "$work/watch")"
tasks=$(squeue -h -r -t all -o '%j|%F|%K' | grep -- "^dembuf-$array_daemon-array-" || true)
[ "$(echo "$tasks" | wc -l)" = 12 ] || fail "not 12 array tasks in Slurm: $tasks"
array=$(echo "$tasks" | cut -d'|' -f2 | sort -u)
[ "$(echo "$array" | wc -l)" = 1 ] || fail "the table went as more than one array: $tasks"
info=$(scontrol show job -o "$array")
for word in ArrayTaskThrottle=4 Comment=dembuf_user=second Account=proj-b; do
  [ "$(echo "$info" | grep -c -- " $word ")" = 12 ] || fail "not every task has $word: $info"
done
# (The daemon's database is new: the sweep's jobs are 1 to 12, job 5 its task 4.)
"$dembuf" status 5 | grep -q "^Slurm job ${array}_4" || fail "status 5: $("$dembuf" status 5)"
"$dembuf" fetch --sweep "$sweep" --long --no-plots --out "$work/array-fetched" > /dev/null ||
  fail "fetch --sweep --long"
stop_daemon
"$dembuf" sweep --local "${bare[@]}" --table "$work/points.tsv" --long --out "$work/array-local" \
  > "$work/local.out" 2>&1 || fail "the local table sweep: $(cat "$work/local.out")"
cmp "$work/array-local/sweep_long.csv" "$work/array-fetched/sweep_long.csv" ||
  fail "the Slurm array's long table differs from the local sweep's"
echo "12 points: one job array (at most 4 at once, dembuf_user=second, account proj-b), the local long table"

echo "== 8. a stored job this daemon cannot run fails alone; the queue goes on ($SECONDS s)"
# Queued jobs copied from job 1 (of part 7's sweep) into the stopped daemon's database: job
# 13's scene names a field this daemon no longer reads (bed.quench_cut_column = true,
# withdrawn, as a daemon of another version may have left it); job 14's folder,
# jobs/<daemon id>-14, cannot be made, because a file lies there; job 15 is fine. Jobs 16
# and 17 stay in the sweep, so that they go to Slurm as one array: 16's folder is blocked
# the same way, 17 is fine. Each blocked job used to stop every later one from reaching
# Slurm, and was tried again at every poll. The daemon must also leave the file alone: it
# did not make it.
python3 - "$work/array.db" <<'PY'
import sqlite3, sys
db = sqlite3.connect(sys.argv[1])
db.row_factory = sqlite3.Row
row = dict(db.execute("SELECT * FROM jobs WHERE id = 1").fetchone())
assert row["sweep_id"]
for new_id in (13, 14, 15, 16, 17):
    job = dict(row, id=new_id, state="queued", error="",
               slurm_id=0, slurm_task=-1, result_nonce="", started_at="", finished_at="",
               attempts=0, crashes=0, reused_from=0, peak_plate_force_N=None, P_N=None)
    if new_id <= 15:
        job.update(sweep_id=None, sweep_index=0, sweep_values_json="[]")
    else:
        job.update(sweep_index=100 + new_id)
    if new_id == 13:
        assert "[bed]\n" in job["scene_toml"]
        job["scene_toml"] = job["scene_toml"].replace("[bed]\n", "[bed]\nquench_cut_column = true\n", 1)
    names = ", ".join(job)
    db.execute(f"INSERT INTO jobs ({names}) VALUES ({', '.join('?' * len(job))})", list(job.values()))
db.commit()
PY
for blocked in 14 16; do echo "not a folder" > "$work/array/jobs/$array_daemon-$blocked"; done
start_daemon "$work/array.db" "$work/array.log" --config "$work/array.toml"
wait_state 15 done 120
wait_state 17 done 120
wait_state 13 failed 10
said=$("$dembuf" status 13 2>&1 || true)
[[ "$said" == *"withdrawn"* ]] || fail "job 13 does not say why: $said"
for blocked in 14 16; do
  wait_state $blocked failed 10
  said=$("$dembuf" status $blocked 2>&1 || true)
  [[ "$said" == *"$array_daemon-$blocked"* ]] || fail "job $blocked does not name its folder: $said"
  [ "$(cat "$work/array/jobs/$array_daemon-$blocked")" = "not a folder" ] ||
    fail "job $blocked's path was changed"
done
"$dembuf" status 17 | grep -q "^Slurm job [0-9]*_" || fail "job 17 did not go as an array task: $("$dembuf" status 17)"
stop_daemon
echo "job 13 failed, naming the withdrawn field; jobs 14 and 16 (alone and in an array) failed, naming their folders; 15 and 17 ran"
echo "== 9. a full disk: a job waits, saying why, and runs once there is room ($SECONDS s)"
# The daemon's work folder on a tmpfs of few inodes (mounting needs root, as the cluster does),
# filled once the daemon has made its folders: the job's folder cannot be made (ENOSPC). That
# is the machine's trouble, not the job's: it must wait, not fail.
mkdir "$work/full"
mount -t tmpfs -o size=8m,nr_inodes=64,mode=0700 tmpfs "$work/full" || fail "cannot mount a tmpfs"
slurm_config "$work/full.toml" "$work/full/slurm"
start_daemon "$work/full.db" "$work/full.log" --config "$work/full.toml"
for k in $(seq 64); do : 2> /dev/null > "$work/full/filler-$k" || break; done
waiting=$("$dembuf" submit "${bare[@]}" | grep -o '[0-9]*' | head -1)
for _ in $(seq 100); do
  said=$("$dembuf" status "$waiting" 2>&1 || true)
  [[ "$said" == *"cannot be submitted for now"* ]] && break
  sleep 0.1
done
[[ "$said" == *"No space left on device"* ]] || fail "the job on a full disk does not say why: $said"
[ "$(job_state "$waiting")" = queued ] || fail "the job on a full disk is not queued: $said"
rm -f "$work/full"/filler-*
wait_state "$waiting" done 60
[[ "$("$dembuf" status "$waiting")" != *"cannot be submitted"* ]] || fail "the note stayed after the job ran"
stop_daemon
umount "$work/full"
echo "a full disk: the job waited, saying why, and ran once there was room"
echo "== 10. an sbatch that queues the job but says no id: one Slurm job, not one a poll ($SECONDS s)"
# A wrapper first in the daemon's PATH runs the real sbatch and prints nothing it can read. The
# daemon takes that for a cluster it cannot reach and tries again at the next poll: it must
# find the job by its name there, not queue another run of it into the same folder.
real_sbatch=$(command -v sbatch)
# start_wrapped_daemon NAME SCRIPT: a daemon whose sbatch is the shell script SCRIPT, in
# $work/NAME; its daemon id in $mute_daemon.
start_wrapped_daemon() {
  mkdir "$work/$1"
  printf '#!/bin/sh\n%s\n' "$2" > "$work/$1/sbatch"
  chmod +x "$work/$1/sbatch"
  slurm_config "$work/$1.toml" "$work/$1-work"
  PATH="$work/$1:$PATH" start_daemon "$work/$1.db" "$work/$1.log" --config "$work/$1.toml"
  mute_daemon=$(sed -n 's/.*jobs run on Slurm as dembuf-\([0-9a-f]*\)-.*/\1/p' "$work/$1.log" | tail -1)
}
# start_mute_daemon NAME SECONDS [SHELL LINE]: a daemon whose sbatch queues each job to begin
# SECONDS later (the next poll must find it not yet ended), runs the line, and prints no id.
start_mute_daemon() {
  start_wrapped_daemon "$1" "$(printf '"%s" --begin=now+%s "$@" > /dev/null 2>&1\n%s\necho "sbatch: (no id)"' \
    "$real_sbatch" "$2" "${3:-}")"
}
start_mute_daemon mute 5
lost=$("$dembuf" submit "${bare[@]}" | grep -o '[0-9]*' | head -1)
wait_state "$lost" done 120
copies=$(squeue -h -t all -o '%j' | grep -c -x "dembuf-$mute_daemon-$lost" || true)
[ "$copies" = 1 ] || fail "job $lost went to Slurm $copies times"
grep -q "job $lost: found in Slurm as job" "$work/mute.log" || fail "job $lost was not taken up by name"
# The same for the jobs that prepare a job's beds (the source, then the cut).
bedded=$("$dembuf" submit "$work/scene.toml" | grep -o '[0-9]*' | head -1)
wait_state "$bedded" done 180
bed_jobs=$(squeue -h -t all -o '%j' | grep "^dembuf-$mute_daemon-bed-" | sort || true)
[ "$(echo "$bed_jobs" | wc -l)" = 2 ] || fail "not two bed jobs in Slurm: $bed_jobs"
[ -z "$(echo "$bed_jobs" | uniq -d)" ] || fail "a bed went to Slurm more than once: $bed_jobs"
stop_daemon
echo "a lost id: job $lost and its beds' jobs found by name, each one Slurm job"
echo "== 11. a job cancelled while its bed's sbatch says no id: the bed's Slurm job goes too ($SECONDS s)"
# This wrapper queues the job (held for 20 s), then takes 2 s to say no id; the dembuf job is
# cancelled meanwhile (the cancel waits for the daemon's pass). No job needs the bed any more:
# the daemon must find its Slurm job by name and cancel it, not leave it to prepare a bed for
# nobody.
start_mute_daemon slow 20 "touch '$work/slow/queued'; sleep 2"
# A seed of its own: its beds are not in the cache.
unneeded=$("$dembuf" submit "$work/scene.toml" --set bed.seed=23 | grep -o '[0-9]*' | head -1)
wait_until "the bed's sbatch did not run" test -e "$work/slow/queued"
"$dembuf" cancel "$unneeded" > /dev/null
[ "$(job_state "$unneeded")" = cancelled ] || fail "job $unneeded is $(job_state "$unneeded")"
# The source's job; and the cut's too where the cancel came after the next pass, which takes the
# source up by name and sends the cut, whose sbatch says no id in turn: either way a bed whose
# id the daemon does not know has to be found and cancelled.
bed_jobs=$(squeue -h -t all -o '%i|%j' |
  awk -F'|' -v p="dembuf-$mute_daemon-bed-" 'index($2, p) == 1 { print $1 }')
[ -n "$bed_jobs" ] || fail "the bed's job is not in Slurm"
for bed_job in $bed_jobs; do
  wait_cancelled "$bed_job" "a bed job of the cancelled job $unneeded"
done
stop_daemon
echo "bed jobs ${bed_jobs//$'\n'/ }, whose ids sbatch did not say, cancelled with job $unneeded"
echo "== 12. a bed job Slurm shows only after its record was cancelled is taken up ($SECONDS s)"
# The first sbatch takes 2 s to say no id (the job is cancelled meanwhile, as in part 11) and
# queues the bed's job only once the test says "go", after the daemon has marked the bed's
# record cancelled (nothing of that name in Slurm then); later ones pass straight through. A job needing the same bed must take the late job up, not send a
# second.
start_wrapped_daemon late "$(printf 'if mkdir "%s" 2> /dev/null; then
  (for _ in $(seq 600); do [ -e "%s" ] && break; sleep 0.1; done
   "%s" --begin=now+10 "$@") > /dev/null 2>&1 < /dev/null &
  sleep 2; echo "sbatch: (no id)"
else exec "%s" "$@"; fi' "$work/late/first" "$work/late/go" "$real_sbatch" "$real_sbatch")"
early=$("$dembuf" submit "$work/scene.toml" --set bed.seed=24 | grep -o '[0-9]*' | head -1)
wait_until "the bed's sbatch did not run" test -d "$work/late/first"
"$dembuf" cancel "$early" > /dev/null
wait_until "the cancelled job's bed record was not marked cancelled" \
  grep -q "no job needs it any more, and Slurm lists no job preparing it" "$work/late.log"
touch "$work/late/go"
late_job=$(wait_slurm_job all "dembuf-$mute_daemon-bed-")
[ -n "$late_job" ] || fail "the late bed job did not come to Slurm"
again=$("$dembuf" submit "$work/scene.toml" --set bed.seed=24 | grep -o '[0-9]*' | head -1)
wait_state "$again" done 180
bed_jobs=$(squeue -h -t all -o '%j' | grep "^dembuf-$mute_daemon-bed-" | sort || true)
[ -z "$(echo "$bed_jobs" | uniq -d)" ] || fail "a bed went to Slurm more than once: $bed_jobs"
grep -q "job $again: .* found in Slurm as job $late_job; taken up" "$work/late.log" ||
  fail "the late bed job $late_job was not taken up by job $again"
stop_daemon
echo "bed job $late_job, shown after its record was cancelled, taken up by job $again"
echo "== 13. an sbatch that queues the job twice and says no id: the older copy is cancelled ($SECONDS s)"
# Both copies would run into the job's one folder. The daemon follows the newest (the last
# sbatch's, whose result the job's nonce accepts) and must cancel the other.
start_wrapped_daemon twice "$(printf '"%s" --begin=now+5 "$@" > /dev/null 2>&1
"%s" --begin=now+5 "$@" > /dev/null 2>&1
echo "sbatch: (no id)"' "$real_sbatch" "$real_sbatch")"
doubled=$("$dembuf" submit "${bare[@]}" | grep -o '[0-9]*' | head -1)
wait_state "$doubled" done 120
copies=$(squeue -h -t all -o '%i|%j|%T' | awk -F'|' -v n="dembuf-$mute_daemon-$doubled" '$2 == n' | sort -n)
[ "$(echo "$copies" | wc -l)" = 2 ] || fail "not two Slurm jobs of job $doubled: $copies"
[ "$(echo "$copies" | cut -d'|' -f3 | tr '\n' ' ')" = "CANCELLED COMPLETED " ] ||
  fail "the older copy of job $doubled was not cancelled, the newer not followed: $copies"
stop_daemon
echo "job $doubled, queued twice: the older Slurm job cancelled, the newer ran"
echo "PASS ($SECONDS s)"
