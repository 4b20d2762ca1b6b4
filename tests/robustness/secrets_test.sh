#!/usr/bin/env bash
# No secret at rest or in output. `dembuf --token T submit` kept the whole command line, token
# included, in the jobs table, summary.json's provenance, /api/jobs/ID, `status --json` and the
# fetched files, and the database was created world-readable (0644): whoever could read one job
# acted as its owner. Now a token given as --token, --token=, or anywhere in a command line a
# client sends never reaches the database, a log, an answer or a file; the daemon creates its
# files for its own account only.
# Usage: secrets_test.sh DEMBUF DEMBUFD
. "$(dirname "$0")/lib.sh" "$1" "$2"

umask 022  # as a login shell leaves it: the daemon must not rely on it
db=$work/dembuf.db
alice=$("$dembufd" --db "$db" token-create alice 2>/dev/null)
start_daemon "$db" "$work/dembufd.log" --access tokens --http 127.0.0.1:0 --log-file "$work/file.log"
web=$(web_base "$work/dembufd.log")
scene=(--set bed.thickness_m=0 --set projectile.speed_m_s=2 --set time.end_s=0.002)
job=$("$dembuf" --token "$alice" submit "${scene[@]}" 2>/dev/null)
job2=$("$dembuf" "--token=$alice" submit "${scene[@]}" 2>/dev/null)
export DEMBUF_TOKEN=$alice
wait_state "$job" done 60
wait_state "$job2" done 60
# A client that puts the token into its command line in another way (a script's arguments).
job3=$(PYTHONPATH="$(dirname "$dembuf")/../python" /usr/bin/python3 - "$alice" <<'PY'
import sys
token = sys.argv[1]
sys.argv = ["analysis.py", "--api-key", token]
import dembuf
with dembuf.connect(token=token) as daemon:
    print(daemon.submit(set=["bed.thickness_m=0", "projectile.speed_m_s=2", "time.end_s=0.002"]))
PY
) || fail "the Python client's job"
wait_state "$job3" done 60
"$dembuf" status "$job3" --json | grep -q -- '--api-key <hidden>' || fail "the Python client's line kept"
"$dembuf" status "$job" --json > "$work/status.json"
grep -q '"command_line": ".*--token <hidden> submit' "$work/status.json" ||
  fail "the command line kept: $(grep command_line "$work/status.json")"
"$dembuf" status "$job2" --json | grep -q -- '--token=<hidden>' || fail "--token= kept"
"$dembuf" fetch "$job" --out "$work/fetched" --no-plots > /dev/null
curl -s -H "Authorization: Bearer $alice" "$web/api/jobs/$job" > "$work/api.json"
grep -q '<hidden>' "$work/api.json" || fail "the web API's command line: $(head -c 300 "$work/api.json")"
stop_daemon
# Nowhere: the database (with its WAL folded in), the logs, the answers, the fetched files.
sqlite3_dump() { /usr/bin/python3 -c 'import sqlite3,sys; print("\n".join(map(str, sqlite3.connect(sys.argv[1]).iterdump())))' "$1"; }
for file in "$db" "$work/dembufd.log" "$work/file.log" "$work/status.json" "$work/api.json" \
  "$work/fetched/summary.json"; do
  if grep -qa "$alice" "$file"; then fail "the token is in $file"; fi
done
if sqlite3_dump "$db" | grep -q "$alice"; then fail "the token is in the database"; fi

# The daemon's files are its own account's only, whatever the umask it was started with.
for file in "$db" "$work/file.log" "$(readlink -f "$db").lock"; do
  mode=$(stat -c %a "$file")
  [ "$mode" = 600 ] || fail "$file is $mode, not 600"
done
# A database left readable by others is closed at start, with a warning.
chmod 644 "$db"
start_daemon "$db" "$work/again.log" --access tokens
grep -q "could be read by other accounts; made readable by this one only" "$work/again.log" ||
  fail "no warning about the open database"
for file in "$db" "$db-wal" "$db-shm"; do
  [ ! -e "$file" ] || [ "$(stat -c %a "$file")" = 600 ] || fail "$file is $(stat -c %a "$file")"
done
stop_daemon
echo "secrets test passed"
