#!/usr/bin/env bash
# Decisions that follow the truth (docs/robustness.md): what the daemon decided once is
# decided again when the facts change.
# - A token revoked (or replaced) while its holder watched a job: the gRPC watch stream and the
#   web page's event stream went on delivering until the job ended. Now both end within about
#   a second of `dembufd token-revoke` (the test allows 10 s, for a loaded machine).
# Usage: decisions_test.sh DEMBUF DEMBUFD
. "$(dirname "$0")/lib.sh" "$1" "$2"
db=$work/dembuf.db
alice=$("$dembufd" --db "$db" token-create alice 2> /dev/null)
DEMBUF_TOKEN=$("$dembufd" --db "$db" token-create root --admin 2> /dev/null)
export DEMBUF_TOKEN  # the test's own look at the jobs (wait_state)
start_daemon "$db" "$work/dembufd.log" --access tokens --workers 1 --http 0
web=$(web_base "$work/dembufd.log")
# A job that runs for minutes: nothing else would end the streams.
job=$("$dembuf" --token "$alice" submit --set bed.thickness_m=0 --set time.end_s=100 \
  --set time.output_interval_s=1e-3 2> /dev/null)
wait_state "$job" running 60

"$dembuf" --token "$alice" watch "$job" --csv > "$work/watch.csv" 2> "$work/watch.err" &
watch_pid=$!
curl -sN -H "Authorization: Bearer $alice" "$web/api/jobs/$job/events" > "$work/events" 2>&1 &
events_pid=$!
sleep 2
kill -0 "$watch_pid" && kill -0 "$events_pid" || fail "the streams did not open"
revoked_at=$(date +%s%N)
"$dembufd" --db "$db" token-revoke alice 2> /dev/null
ended() { ! kill -0 "$1" 2> /dev/null; }
for _ in $(seq 100); do
  ended "$watch_pid" && ended "$events_pid" && break
  sleep 0.1
done
took=$(( ($(date +%s%N) - revoked_at) / 1000000 ))
ended "$watch_pid" || fail "the watch stream went on after the token was revoked"
ended "$events_pid" || fail "the web event stream went on after the token was revoked"
echo "both streams ended $took ms after token-revoke"
grep -q "token: revoked or replaced" "$work/watch.err" || fail "watch: $(cat "$work/watch.err")"
grep -q "^event: revoked" "$work/events" || fail "events: $(tail -3 "$work/events")"
echo "decisions test passed"
