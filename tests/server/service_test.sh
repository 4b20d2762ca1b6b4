#!/usr/bin/env bash
# The service end to end: a real dembufd on loopback driven by the real client. A job watched
# live (samples before the end, in order, none missing; a late watcher gets them all), fetched
# and compared with a local run; E5's snapshots stored and fetched as a local run writes them; a sweep of 6 jobs on one bed prepared once; a cancel taking
# effect within a second; bad requests refused naming the field; a full queue refused.
# Usage: service_test.sh DEMBUF DEMBUFD
# With DEMBUF_TEST_SKIP_LOCAL=1 (the ThreadSanitizer build of deploy/test.sh) the local runs
# that the fetched results are compared with are skipped: they settle their beds again, take
# minutes under the sanitizer, and go through no thread of the daemon.
. "$(dirname "$0")/lib.sh" "$1" "$2"
small_scene "$work/small.toml"
start_daemon "$work/dembuf.db" "$work/dembufd.log" --workers 2

"$dembuf" server-info | grep -q "workers 2" || fail "server-info"

# --- a job, watched live from the start and by a late watcher --------------------------------
# A long impact (0.4 s, a sample every 0.1 ms) so that the run lasts well beyond the watch's
# 100 ms polls: at 0.04 s it ran in 70 ms, and one poll could find all its samples ended.
long_impact=(--set bed.seed=3 --set time.end_s=0.4 --set time.output_interval_s=1e-4)
job=$("$dembuf" submit "$work/small.toml" "${long_impact[@]}")
"$dembuf" watch "$job" --csv > "$work/watch1.csv" &
watcher=$!
# Started: running, or already ended. Under a sanitizer on a loaded machine the run itself
# can take less time than one round trip of the client, so "running" alone may never be seen.
wait_state "$job" "running done failed cancelled" 300
sleep 0.5
"$dembuf" watch "$job" --csv > "$work/watch2.csv"
wait "$watcher" || fail "first watcher"
[ "$(job_state "$job")" = done ] || fail "job $job did not finish"
# Watching the finished job into a file: no line twice in a row, and the summary's numbers.
"$dembuf" watch "$job" > "$work/watch_log.txt" || fail "watch of a finished job"
[ -z "$(uniq -d "$work/watch_log.txt")" ] || fail "watch repeated lines: $(uniq -d "$work/watch_log.txt")"
grep -q "done done" "$work/watch_log.txt" && fail "watch: $(cat "$work/watch_log.txt")"
grep -q "^job $job done: peak plate force [0-9.e+]* N, P = " "$work/watch_log.txt" ||
  fail "watch of a finished job lacks the summary's numbers: $(cat "$work/watch_log.txt")"
"$dembuf" fetch "$job" --out "$work/fetched" --no-plots > /dev/null
rows=$(($(wc -l < "$work/fetched/plate_force.csv") - 1))
[ "$rows" -gt 100 ] || fail "only $rows samples"
for w in watch1 watch2; do
  # Every index once, in order, and as many samples as the stored series.
  awk -F, -v rows="$rows" 'NR > 1 { if ($1 != NR - 2) { print "index " $1 " at row " NR; bad = 1 }
                                   if (NR > 2 && $2 <= t) { print "time not increasing"; bad = 1 }
                                   t = $2; n++ }
       END { if (n != rows) { print n " samples, stored " rows; bad = 1 } exit bad }' \
    "$work/$w.csv" || fail "$w: samples missing or out of order"
done
# The first watcher saw samples while the job was still running (live, not replayed).
grep -q ',running$' "$work/watch1.csv" || fail "no sample arrived before the job ended"
# Same values as the stored series.
cut -d, -f2-4 "$work/watch1.csv" | tail -n +2 > "$work/watched"
cut -d, -f1-3 "$work/fetched/plate_force.csv" | tail -n +2 > "$work/stored"
cmp -s "$work/watched" "$work/stored" || fail "watched samples differ from the stored ones"

# --- the fetched run equals a local run of the same scene -------------------------------------
if [ "${DEMBUF_TEST_SKIP_LOCAL:-0}" != 1 ]; then
  "$dembuf" run "$work/small.toml" "${long_impact[@]}" --no-bed-cache \
    --out "$work/local" > /dev/null 2>&1
  cmp "$work/local/plate_force.csv" "$work/fetched/plate_force.csv" || fail "series differ from local"
  # Identical summaries but for the wall time and where, when and how each ran; the scene's
  # and the bed's SHA-256 are the same.
  python3 - "$work/local/summary.json" "$work/fetched/summary.json" <<'PY' ||
import json, sys
local, fetched = (json.load(open(path)) for path in sys.argv[1:])
for key in ("scene_sha256", "bed_sha256", "bed_hash", "seed"):
    assert local["provenance"][key] == fetched["provenance"][key], key
for summary in (local, fetched):
    for key in ("wall_time_s", "provenance"):
        summary.pop(key)
assert local == fetched
PY
    fail "summaries differ from local"
fi

# --- E5 on the service: the snapshots are stored with the job and fetched with it -------------
# The preset's snapshot times (after contact, and at the peak) on the small scene; the files
# fetched are those of a local run, byte for byte.
e5=$("$dembuf" submit --preset e5 "$work/small.toml" --set bed.seed=3)
wait_state "$e5" "done failed cancelled" 300
[ "$(job_state "$e5")" = done ] || fail "E5 job $e5: $("$dembuf" status "$e5")"
"$dembuf" status "$e5" | grep -q "^result files: [1-9]" || fail "status shows no result files"
"$dembuf" fetch "$e5" --out "$work/e5-fetched" --no-plots > /dev/null || fail "fetch of E5"
[ -f "$work/e5-fetched/snapshots/peak/contacts.csv" ] || fail "no peak snapshot fetched"
[ -f "$work/e5-fetched/snapshots/after_contact_0.5ms/beads.vtp" ] || fail "no 0.5 ms snapshot"
[ -f "$work/e5-fetched/snapshots.pvd" ] || fail "no snapshots.pvd fetched"
if [ "${DEMBUF_TEST_SKIP_LOCAL:-0}" != 1 ]; then
  "$dembuf" run --preset e5 "$work/small.toml" --set bed.seed=3 --no-bed-cache --no-plots \
    --out "$work/e5-local" > /dev/null 2>&1 || fail "local E5"
  diff -r "$work/e5-local/snapshots" "$work/e5-fetched/snapshots" > "$work/e5.diff" \
    || fail "fetched snapshots differ from a local run's: $(head -5 "$work/e5.diff")"
  cmp -s "$work/e5-local/snapshots.pvd" "$work/e5-fetched/snapshots.pvd" || fail "snapshots.pvd differs"
fi

# --- a sweep of 6 jobs on one bed: the bed is prepared once -----------------------------------
sweep=$("$dembuf" sweep "$work/small.toml" --set bed.seed=4 \
        --vary projectile.speed_m_s=1,1.5,2,2.5,3,3.5 2>/dev/null)
for _ in $(seq 600); do
  "$dembuf" status --sweep "$sweep" | grep -q "jobs: 6, done 6$" && break
  sleep 0.2
done
"$dembuf" status --sweep "$sweep" | grep -q "jobs: 6, done 6$" || fail "sweep did not finish"
# Two bed stages (the settled source and its cut), each prepared by exactly one job.
"$dembuf" status --sweep "$sweep" | grep -q "beds prepared: 2$" || fail "beds prepared"
"$dembuf" fetch --sweep "$sweep" --out "$work/sweep" --no-plots > /dev/null
[ "$(cat "$work"/sweep/runs/*/job.json | grep -c '"source ')" = 1 ] || fail "source bed count"
[ "$(cat "$work"/sweep/runs/*/job.json | grep -c '"cut ')" = 1 ] || fail "cut bed count"
[ "$(($(wc -l < "$work/sweep/sweep.csv") - 1))" = 6 ] || fail "sweep.csv rows"

# --- cancel a running job: it stops within a second -------------------------------------------
# Within a second in the daemon, from its log: the request's arrival to the job's end. The
# client's round trips (a process start each) count only against a hang: on a loaded machine
# they alone can take a second.
long=$("$dembuf" submit "$work/small.toml" --set bed.seed=3 --set projectile.enabled=false \
       --set time.end_s=5)
wait_state "$long" running 60
"$dembuf" cancel "$long" > /dev/null
wait_state "$long" cancelled 5
for _ in $(seq 50); do  # the log line follows the stored state
  grep -q "] job $long: cancelled while running" "$work/dembufd.log" && break
  sleep 0.1
done
latency=$(awk -v id="$long" '
  function at(field) { sub(/\]/, "", field); split(field, hms, ":"); return hms[1] * 3600 + hms[2] * 60 + hms[3] }
  index($0, "] job " id ": cancel requested") { asked = at($2) }
  index($0, "] job " id ": cancelled while running") { stopped = at($2) }
  END { print (asked == "" || stopped == "") ? "unknown" : stopped - asked }' "$work/dembufd.log")
awk -v t="$latency" 'BEGIN { exit !(t != "unknown" && t < 1.0) }' ||
  fail "cancel took $latency s in the daemon"
if "$dembuf" cancel "$long" 2>/dev/null; then fail "cancelled an ended job"; fi
# Cancelled is cancelled everywhere: status, watch and fetch exit 4, and the fetched folder
# says incomplete.json, as a local run stopped early (fetch wrote failure.json, watch exited 1).
for command in "status $long" "watch $long" "fetch $long --out $work/cancelled --no-plots"; do
  code=0
  "$dembuf" $command > /dev/null 2>&1 || code=$?
  [ "$code" = 4 ] || fail "dembuf $command of a cancelled job exited $code, not 4"
done
[ -f "$work/cancelled/incomplete.json" ] && [ ! -e "$work/cancelled/failure.json" ] ||
  fail "the cancelled job's folder: $(ls "$work/cancelled")"

# --- bad requests: INVALID_ARGUMENT (exit 2) and the field in the message --------------------
bad() {  # bad FIELD COMMAND...
  local field=$1
  shift
  local code=0
  "$dembuf" "$@" > /dev/null 2> "$work/err" || code=$?
  [ "$code" = 2 ] || fail "'$*' gave exit code $code: $(cat "$work/err")"
  grep -q "the server refused the request: .*$field" "$work/err" || fail "'$*': $(cat "$work/err")"
}
printf '[bed]\nthickness_m = "thick"\n' > "$work/bad.toml"
bad bed.thickness_m submit --set bed.thickness_m=-0.01
bad projectile.mass_kg submit --set projectile.mass_kg=nan
bad material.restitution submit --set material.restitution=1.5
bad no.such_field submit --set no.such_field=1
bad preset submit --preset e9
bad accuracy submit --accuracy sloppy
bad time.alpha submit --set time.alpha=fast
bad beads.diameter_min_m submit --set beads.diameter_min_m=0.006
bad bed.import submit --set bed.import=/etc/passwd
bad output.snapshot_times_s submit --set "$(python3 -c 'print("output.snapshot_times_s=[" + ", ".join(["0.001"] * 101) + "]")')"
bad bed.thickness_m submit "$work/bad.toml"
bad bed.thickness_m sweep --vary bed.thickness_m=0.02:0.01:0.005
bad nope.field sweep --vary nope.field=1,2
bad seeds sweep --seeds 5000 --vary projectile.speed_m_s=1,2
bad axes sweep --vary projectile.speed_m_s=0:10:0.01 --vary bed.seed=1:100:1
# Unknown ids are NOT_FOUND, not a crash.
if "$dembuf" status 999999 2> "$work/err"; then fail "status of an unknown job"; fi
grep -q "no job 999999" "$work/err" || fail "unknown job message: $(cat "$work/err")"
"$dembuf" server-info > /dev/null || fail "the daemon died on bad requests"
stop_daemon
grep -q "stopped cleanly" "$work/dembufd.log" || fail "no clean shutdown"

# --- a full queue: RESOURCE_EXHAUSTED, nothing stored -----------------------------------------
start_daemon "$work/small-queue.db" "$work/small-queue.log" --workers 1 --queue-limit 3
code=0
"$dembuf" sweep --set bed.thickness_m=0 --vary projectile.speed_m_s=1,2,3,4 2> "$work/err" || code=$?
[ "$code" = 1 ] && grep -q "server is full" "$work/err" || fail "full queue: $code $(cat "$work/err")"
[ -z "$("$dembuf" list | tail -n +2)" ] || fail "a refused sweep left jobs behind"
stop_daemon
echo "service test passed"
