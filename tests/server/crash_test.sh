#!/usr/bin/env bash
# kill -9 of dembufd while a sweep runs, then a restart on the same database: every job is
# still there, completed results are intact and identical, the interrupted job runs again and
# finishes. Then a kill during a bed preparation: the job prepares the bed again and finishes.
# Usage: crash_test.sh DEMBUF DEMBUFD
. "$(dirname "$0")/lib.sh" "$1" "$2"
small_scene "$work/small.toml"
start_daemon "$work/dembuf.db" "$work/dembufd.log" --workers 1

sweep=$("$dembuf" sweep "$work/small.toml" --set bed.seed=6 --set time.end_s=0.3 \
        --vary projectile.speed_m_s=1,1.25,1.5,1.75,2,2.25,2.5,2.75 2>/dev/null)
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
echo "crash test passed: $(wc -l < "$work/done_before") results kept, jobs re-run: $running," \
  "a bed preparation redone"
