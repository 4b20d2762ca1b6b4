#!/usr/bin/env bash
# Stored results are checked, never served damaged. One flipped byte in a stored summary was
# served as the result (P = 9625 N beside Pa = 4625 N): series chunks had checksums, summaries
# and result files did not. Now each has one, checked on every read: a mismatch is reported
# as damage (gRPC DATA_LOSS, the web API's error, status's note) and `dembufd --check-db`
# finds it offline.
# Usage: integrity_test.sh DEMBUF DEMBUFD
. "$(dirname "$0")/lib.sh" "$1" "$2"

db=$work/dembuf.db
start_daemon "$db" "$work/dembufd.log" --http 127.0.0.1:0
job=$("$dembuf" submit --set bed.thickness_m=0 --set projectile.speed_m_s=2 2>/dev/null)
wait_state "$job" done 60
expect_exit 1 "is in use by another dembufd" "$dembufd" --db "$db" --check-db
stop_daemon
"$dembufd" --db "$db" --check-db > "$work/check.txt" || fail "an intact database: $(cat "$work/check.txt")"
grep -q "1 summaries, 1 series chunks and 0 result files checked: intact" "$work/check.txt" ||
  fail "$(cat "$work/check.txt")"

# A byte of the summary flipped (the peak's first digit).
/usr/bin/python3 - "$db" <<'PY'
import sqlite3, sys
db = sqlite3.connect(sys.argv[1])
summary = db.execute("SELECT summary_json FROM results").fetchone()[0]
at = summary.index('"peak_plate_force_N": ') + len('"peak_plate_force_N": ')
flipped = summary[:at] + ("9" if summary[at] != "9" else "8") + summary[at + 1:]
db.execute("UPDATE results SET summary_json = ?", (flipped,))
db.commit()
PY
expect_exit 1 "the summary of job $job is damaged: it does not match its checksum" \
  "$dembufd" --db "$db" --check-db
grep -q "checked: 1 damaged" "$work/out" || fail "$(cat "$work/out")"

start_daemon "$db" "$work/dembufd.log" --http 127.0.0.1:0
web=$(web_base "$work/dembufd.log")
expect_exit 1 "data loss: the summary of job $job is damaged" "$dembuf" fetch "$job" --out "$work/f" --no-plots
[ ! -e "$work/f/summary.json" ] || fail "a damaged summary was written"
"$dembuf" status "$job" > "$work/status.txt" 2>&1 || true
grep -q "note: the summary of job $job is damaged" "$work/status.txt" || fail "status: $(cat "$work/status.txt")"
if grep -q "^P = " "$work/status.txt"; then fail "status showed the damaged result"; fi
code=$(curl -s -o "$work/body" -w '%{http_code}' "$web/api/jobs/$job/files/summary.json")
[ "$code" = 500 ] && grep -q "is damaged" "$work/body" || fail "web: $code $(cat "$work/body")"
curl -s "$web/api/jobs/$job" | grep -q '"summary":null' || fail "the web API served the summary"
stop_daemon
echo "integrity test passed"
