#!/usr/bin/env bash
# Decisions that follow the truth (docs/robustness.md): what the daemon decided once is
# decided again when the facts change.
# - A token revoked (or replaced) while its holder watched a job: the gRPC watch stream and the
#   web page's event stream went on delivering until the job ended. Now both end within about
#   a second of `dembufd token-revoke` (the test allows 10 s, for a loaded machine).
# - One user's sweep went first, whole: another user's job waited behind all of it. Now users
#   take turns: bob's one job starts as soon as a worker is free.
# - A user's stored results had no bound (31.9 MB a 2 s job): now quota_stored_mb (10 GB by
#   default) refuses new work past it, naming the quota, and `dembuf delete` frees it.
# - `dembufd --check-db` upgraded an older database, writing checksums over whatever it held,
#   and called it intact. Now it reads only, and says the database is older and not verified.
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
"$dembuf" cancel "$job" > /dev/null
stop_daemon

# Users in turn: one worker; alice's sweep of six, then bob's one job.
bob=$("$dembufd" --db "$db" token-create bob 2> /dev/null)
alice=$("$dembufd" --db "$db" token-create alice 2> /dev/null)
start_daemon "$db" "$work/turns.log" --access tokens --workers 1
short=(--set bed.thickness_m=0 --set projectile.height_m=0.05 --set time.end_s=0.05)
"$dembuf" --token "$alice" sweep "${short[@]}" --vary projectile.speed_m_s=1,2,3,4,5,6 > /dev/null 2>&1
bob_job=$("$dembuf" --token "$bob" submit "${short[@]}" --set projectile.speed_m_s=3 2> /dev/null)
wait_state "$bob_job" done 120
order=$(sed -n 's/.*worker 0: job \([0-9]*\) starts.*/\1/p' "$work/turns.log" | tr '\n' ' ')
second=$(echo "$order" | awk '{print $2}')
[ "$second" = "$bob_job" ] || fail "bob's job $bob_job waited behind alice's sweep: jobs started $order"
# A job not ended is not deleted: the refusal says what to do first.
long=$("$dembuf" --token "$bob" submit --set bed.thickness_m=0 --set time.end_s=100 \
  --set time.output_interval_s=1e-3) || fail "a long job was refused"
expect_exit 1 "not now: job_id: job $long has not ended (\(queued\|running\)): cancel first (dembuf cancel $long)" \
  "$dembuf" --token "$bob" delete "$long"
"$dembuf" --token "$bob" cancel "$long" > /dev/null
DEMBUF_TOKEN=$bob wait_state "$long" cancelled 60
for _ in $(seq 50); do "$dembuf" --token "$bob" delete "$long" > /dev/null 2>&1 && break; sleep 0.2; done
expect_exit 2 "no job $long" "$dembuf" --token "$bob" status "$long"
# A cancelled job's record counts in its owner's stored bytes until it is deleted (cancelled
# sweeps of long command lines grew the database by 477 MB, counted nowhere).
carol=$("$dembufd" --db "$db" token-create carol 2> /dev/null)
stored() { "$dembuf" --token "$carol" server-info --json | python3 -c 'import json, sys; print(json.load(sys.stdin)["stored_bytes"])'; }
sleep 0.5  # the daemon reads new tokens within 250 ms
job=$("$dembuf" --token "$carol" submit --set bed.thickness_m=0 --set time.end_s=100 \
  --set time.output_interval_s=1e-3) || fail "carol's job was refused"
"$dembuf" --token "$carol" cancel "$job" > /dev/null
DEMBUF_TOKEN=$carol wait_state "$job" cancelled 60
[ "$(stored)" -gt 4000 ] || fail "a cancelled job's record is not counted: $(stored) bytes"
for _ in $(seq 50); do "$dembuf" --token "$carol" delete "$job" > /dev/null 2>&1 && break; sleep 0.2; done
[ "$(stored)" = 0 ] || fail "carol's deleted job still counts $(stored) bytes"
stop_daemon

# Stored results have a quota per user; deleting frees it.
printf 'access = "tokens"\nquota_stored_mb = 1.05\n' > "$work/quota.toml"
start_daemon "$db" "$work/quota.log" --config "$work/quota.toml"
"$dembuf" --token "$bob" server-info | grep -q "MB of 1.05 MB of stored results" ||
  fail "server-info does not show the quota: $("$dembuf" --token "$bob" server-info)"
tiny=(--set bed.thickness_m=0 --set projectile.height_m=0.05 --set time.end_s=0.01
  --set time.output_interval_s=1e-3)
expect_exit 1 "over your quota on the server: owner: bob stores .* MB of results.*quota_stored_mb.*dembuf delete" \
  "$dembuf" --token "$bob" submit "${tiny[@]}"
expect_exit 0 "deleted 1 job(s)" "$dembuf" --token "$bob" delete "$bob_job"
expect_exit 2 "no job $bob_job" "$dembuf" --token "$bob" status "$bob_job"
"$dembuf" --token "$bob" submit "${tiny[@]}" > /dev/null 2> "$work/err" || fail "after the delete: $(cat "$work/err")"
stop_daemon

# One user's slow admission holds up no other's submission: alice's sweep of 40 containers
# around an 85,000-bead file is measured run by run (seconds), then refused by her queued
# quota; bob's job, sent meanwhile, is filed before she is answered. (A lock held through the
# whole admission made every submission with a request id, which the clients always send,
# wait behind it.)
python3 - "$work/big.txt" <<'PY'
import math, sys
r, spacing, radius = 0.0005, 0.00105, 0.03
n = int(radius / spacing) + 1
with open(sys.argv[1], "w") as out:
    out.write("# x y z radius (m)\n")
    for k in range(35):
        for i in range(-n, n + 1):
            for j in range(-n, n + 1):
                if math.hypot(i * spacing, j * spacing) + r < 0.99 * radius:
                    out.write(f"{i * spacing:.6f} {j * spacing:.6f} {r + k * spacing:.6f} {r}\n")
PY
printf 'access = "tokens"\nquota_queued_jobs = 5\n' > "$work/slow.toml"
start_daemon "$db" "$work/slow.log" --config "$work/slow.toml"
"$dembuf" --token "$alice" sweep --server "$DEMBUF_SERVER" --set bed.import="$work/big.txt" \
  --set projectile.diameter_m=0.01 --vary cylinder.radius_m=0.0300:0.0339:0.0001 \
  > "$work/slow.out" 2>&1 &
alice_pid=$!
sleep 1  # her file sent, her sweep being admitted
"$dembuf" --token "$bob" submit "${tiny[@]}" > /dev/null 2> "$work/err" || fail "bob's job: $(cat "$work/err")"
kill -0 "$alice_pid" 2> /dev/null ||
  fail "alice's sweep was answered before bob's job was filed, so this shows nothing: $(cat "$work/slow.out")"
wait "$alice_pid" || true
grep -q "quota_queued_jobs" "$work/slow.out" || fail "alice's sweep: $(cat "$work/slow.out")"
stop_daemon

# --check-db on a database of an older schema reads only.
"$dembufd" --db "$work/old.db" token-list > /dev/null 2>&1
python3 - "$work/old.db" <<'PY'
import sqlite3, sys
db = sqlite3.connect(sys.argv[1])
db.executescript("DROP INDEX jobs_done_by_scene; "
                 "ALTER TABLE results DROP COLUMN summary_sha256; ALTER TABLE results DROP COLUMN "
                 "series_sha256; ALTER TABLE job_files DROP COLUMN sha256; DROP TABLE bed_files; "
                 "ALTER TABLE jobs DROP COLUMN bed_file; ALTER TABLE jobs DROP COLUMN result_nonce; "
                 "PRAGMA user_version = 7;")
db.close()
PY
before=$(sha256sum "$work/old.db" | cut -d' ' -f1)
expect_exit 1 "schema version 7, older than this dembufd's .*: not verified" \
  "$dembufd" --db "$work/old.db" --check-db
[ "$(sha256sum "$work/old.db" | cut -d' ' -f1)" = "$before" ] || fail "--check-db changed the database"
echo "decisions test passed"
