#!/usr/bin/env bash
# Item 3 of the robustness suite (docs/robustness.md): no legal job can crash the daemon.
# - The crash-loop job: a 100 m drop sampled every 0.15 us. Its 30 million free-fall samples
#   threw "blob too big" in SQLite and killed the daemon, again at every restart, and its
#   cancel did too. Now the free fall is not sampled and any series is stored in chunks.
# - A long series (about 470,000 samples) is stored while the job runs; a watcher that joins
#   late reads the stored part and gets every sample, equal to the fetched series and to a
#   local run.
# - A store failure inside a worker fails the job with the reason; the daemon goes on.
# - A job that kills the daemon twice (a fault point at its start) is failed as a poison job
#   at the next start instead of being run again for ever.
# - Cancel works on queued jobs, on a job preparing its bed, and says so on an ended job.
# Usage: jobs_test.sh DEMBUF DEMBUFD
. "$(dirname "$0")/lib.sh" "$1" "$2"
small_scene "$work/small.toml"

# --- the crash-loop job -------------------------------------------------------------------
start_daemon "$work/dembuf.db" "$work/dembufd.log" --workers 1
drop=$("$dembuf" submit --set projectile.height_m=100 --set time.output_interval_s=1.5e-7 2>/dev/null)
wait_state "$drop" "done failed" 120
[ "$(job_state "$drop")" = done ] || fail "the 100 m drop: $("$dembuf" status "$drop")"
if "$dembuf" cancel "$drop" 2> "$work/err"; then fail "cancelled an ended job"; fi
grep -q "has already ended (done)" "$work/err" || fail "cancel of an ended job: $(cat "$work/err")"
"$dembuf" server-info > /dev/null || fail "the daemon died"

# --- a long series, watched late, equal to a local run -------------------------------------
long=(--set time.end_s=5 --set time.output_interval_s=1e-5)
job=$("$dembuf" submit "${long[@]}" 2>/dev/null)
wait_state "$job" running 60
sleep 2  # some 4096-sample chunks are stored by now
[ "$(job_state "$job")" = running ] || fail "the long job ended before its watcher came"
"$dembuf" watch "$job" --csv > "$work/watch.csv" || fail "watch"
wait_state "$job" done 120
"$dembuf" fetch "$job" --out "$work/fetched" --no-plots > /dev/null || fail "fetch"
rows=$(($(wc -l < "$work/fetched/plate_force.csv") - 1))
[ "$rows" -gt 400000 ] || fail "only $rows samples"
cut -d, -f2-4 "$work/watch.csv" | tail -n +2 > "$work/watched"
cut -d, -f1-3 "$work/fetched/plate_force.csv" | tail -n +2 > "$work/stored"
cmp -s "$work/watched" "$work/stored" || fail "the late watcher's samples differ from the stored ones"
"$dembuf" run "${long[@]}" --out "$work/local" > /dev/null 2>&1 || fail "local run"
cmp -s "$work/local/plate_force.csv" "$work/fetched/plate_force.csv" || fail "the stored series differs from a local run"

# --- cancel: queued, preparing its bed, ended ----------------------------------------------
bed=$("$dembuf" submit "$work/small.toml" --set bed.seed=21 2>/dev/null)
queued=$("$dembuf" submit "$work/small.toml" --set bed.seed=22 2>/dev/null)
wait_state "$bed" preparing_bed 60
"$dembuf" cancel "$queued" > /dev/null || fail "cancel a queued job"
[ "$(job_state "$queued")" = cancelled ] || fail "the queued job is $(job_state "$queued")"
"$dembuf" cancel "$bed" > /dev/null || fail "cancel a job preparing its bed"
wait_state "$bed" cancelled 5
stop_daemon

# --- a store failure in a worker: the job fails with the reason, the daemon goes on ---------
DEMBUFD_FAULT=store-error-at-result-write:2 start_daemon "$work/dembuf.db" "$work/dembufd.log" --workers 1
broken=$("$dembuf" submit 2>/dev/null)
wait_state "$broken" "failed done" 60
"$dembuf" status "$broken" | grep -q "note: the server failed while running this job: .*injected fault" ||
  fail "a store failure: $("$dembuf" status "$broken")"
after=$("$dembuf" submit 2>/dev/null)
wait_state "$after" done 60
stop_daemon

# --- a job that kills the daemon twice is failed, not run a third time ----------------------
# The jobs are queued on a healthy daemon, stopped cleanly (a clean stop counts no crash);
# the fault is armed for the restarts, where the first job in the queue kills the daemon.
start_daemon "$work/dembuf.db" "$work/dembufd.log" --workers 1 --shutdown-grace 0
poison=$("$dembuf" submit --name poison --set time.end_s=3 2>/dev/null)
wait_state "$poison" running 60
next=$("$dembuf" submit 2>/dev/null)
stop_daemon
for attempt in 1 2; do
  # Started by hand: the job runs at once and may kill it before it says it listens.
  DEMBUFD_FAULT=kill-at-job-start "$dembufd" --listen 127.0.0.1:0 --db "$work/dembuf.db" \
    --access local --workers 1 >> "$work/dembufd.log" 2>&1 &
  daemon_pid=$!
  for _ in $(seq 100); do kill -0 "$daemon_pid" 2>/dev/null || break; sleep 0.1; done
  kill -0 "$daemon_pid" 2>/dev/null && fail "the fault point did not fire (attempt $attempt)"
  wait "$daemon_pid" 2>/dev/null || true
  daemon_pid=""
done
start_daemon "$work/dembuf.db" "$work/dembufd.log" --workers 1
[ "$(job_state "$poison")" = failed ] || fail "the poison job is $(job_state "$poison")"
"$dembuf" status "$poison" | grep -q "poison job: the daemon stopped twice" || fail "$("$dembuf" status "$poison")"
grep -q "job $poison was running when the daemon stopped, for the second time: failed as a poison job" \
  "$work/dembufd.log" || fail "no log line for the poison job"
wait_state "$next" done 60
stop_daemon
echo "jobs test passed"
