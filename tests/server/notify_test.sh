#!/usr/bin/env bash
# Notifications through a chat hook, against a real HTTP server on loopback standing for
# Mattermost or Slack:
#   1. a daemon without a hook refuses --notify, saying so; one whose URL file others may read
#      does not start, and never prints the URL;
#   2. a job and a sweep submitted with --notify are each posted once when they have ended
#      ({"text": ...}, the owner mentioned, a user's @channel defused); a job without it is not;
#      a hook that answers 503 is tried again;
#   3. a notification owed while the hook is down survives a restart of the daemon;
#   4. Python's submit(notify=True) asks for one too.
# Usage: notify_test.sh DEMBUF DEMBUFD PYTHON_DIR
. "$(dirname "$0")/lib.sh" "$1" "$2"
python_dir=$3
export OMP_NUM_THREADS=1
bare=(--preset e2 --set bed.thickness_m=0 --set time.output_interval_s=1e-4)

# The hook: answers 503 to its first POST, 200 after, and appends each body it took to
# hook.log (one JSON document a line); its port in hook.port.
hook_pid=""
start_hook() {
  rm -f "$work/hook.port"
  python3 - "$work" "${1:-0}" <<'PY' &
import http.server, json, sys
work, port = sys.argv[1], int(sys.argv[2])
refused = []
class Hook(http.server.BaseHTTPRequestHandler):
    def do_POST(self):
        body = self.rfile.read(int(self.headers["Content-Length"]))
        if not refused:
            refused.append(body)
            self.send_response(503)
            self.end_headers()
            return
        assert self.headers["Content-Type"] == "application/json", self.headers
        with open(work + "/hook.log", "a") as log:
            log.write(json.dumps(json.loads(body)) + "\n")
        self.send_response(200)
        self.end_headers()
    def log_message(self, *args):
        pass
server = http.server.HTTPServer(("127.0.0.1", port), Hook)
open(work + "/hook.port", "w").write(str(server.server_address[1]))
server.serve_forever()
PY
  hook_pid=$!
  for _ in $(seq 100); do [ -s "$work/hook.port" ] && break; sleep 0.1; done
  [ -s "$work/hook.port" ] || fail "the hook did not start"
}
stop_hook() { kill "$hook_pid" 2> /dev/null || true; wait "$hook_pid" 2> /dev/null || true; }
trap 'rc=$?; stop_hook; [ -z "$daemon_pid" ] || kill -9 "$daemon_pid" 2>/dev/null || true; rm -rf "$work"; exit $rc' EXIT
# hook_lines N SECONDS: waits until the hook has taken N messages.
hook_lines() {
  for _ in $(seq $(($2 * 10))); do
    [ "$(cat "$work/hook.log" 2> /dev/null | wc -l)" -ge "$1" ] && return 0
    sleep 0.1
  done
  fail "the hook took $(cat "$work/hook.log" 2> /dev/null | wc -l) messages, not $1: $(cat "$work/hook.log" 2> /dev/null)"
}

echo "== 1. no hook: --notify refused; a URL file others may read: no start"
start_daemon "$work/none.db" "$work/none.log"
if "$dembuf" submit "${bare[@]}" --notify > "$work/out" 2>&1; then fail "--notify was taken without a hook"; fi
grep -q "notify: this daemon has no chat hook" "$work/out" || fail "the refusal: $(cat "$work/out")"
if "$dembuf" sweep "${bare[@]}" --vary projectile.speed_m_s=1,2 --notify > "$work/out" 2>&1; then
  fail "sweep --notify was taken without a hook"
fi
if "$dembuf" sweep --local "${bare[@]}" --vary projectile.speed_m_s=1,2 --notify --out "$work/l" > "$work/out" 2>&1; then
  fail "a local sweep took --notify"
fi
grep -q "a sweep run here ends in this terminal" "$work/out" || fail "local --notify: $(cat "$work/out")"
"$dembuf" server-info | grep -q notifications && fail "server-info tells of notifications without a hook"
stop_daemon

start_hook
printf 'http://127.0.0.1:%s/hooks/secret-key-123\n' "$(cat "$work/hook.port")" > "$work/hook.url"
chmod 0644 "$work/hook.url"
if "$dembufd" --listen 127.0.0.1:0 --db "$work/n.db" --access local --setting notify_url_file="$work/hook.url" \
  > "$work/refused.log" 2>&1; then fail "dembufd started with a URL file others may read"; fi
grep -q "chmod 0640" "$work/refused.log" || fail "the refusal: $(cat "$work/refused.log")"
grep -q "secret-key-123" "$work/refused.log" && fail "dembufd printed the hook's URL"
# --check-config reads the file as the start would, and does not print the URL either.
if "$dembufd" --setting notify_url_file="$work/hook.url" --check-config > "$work/check" 2>&1; then
  fail "--check-config took a URL file others may read"
fi
grep -q "notify_url_file: $work/hook.url: mode 0644" "$work/check" || fail "--check-config: $(cat "$work/check")"
chmod 0600 "$work/hook.url"
"$dembufd" --setting notify_url_file="$work/hook.url" --check-config > "$work/check" 2>&1 ||
  fail "--check-config: $(cat "$work/check")"
grep -q "secret-key-123" "$work/check" && fail "--check-config printed the hook's URL"

echo "== 2. a job and a sweep told of once they end"
hooked=(--setting notify_url_file="$work/hook.url" --setting notify_mention=true)
start_daemon "$work/n.db" "$work/n.log" "${hooked[@]}"
"$dembuf" server-info | grep -q "notifications: submit --notify" || fail "server-info: $("$dembuf" server-info)"
job=$("$dembuf" --owner alice submit "${bare[@]}" --name '@channel <!here> look' --notify)
quiet=$("$dembuf" --owner alice submit "${bare[@]}")
sweep=$("$dembuf" --owner bob sweep "${bare[@]}" --vary projectile.speed_m_s=1,2,3 --name curve --notify)
# The first POST is answered 503: tried again 5 s later.
hook_lines 2 60
grep -q "secret-key-123" "$work/n.log" && fail "the daemon logged the hook's URL"
python3 - "$work/hook.log" "$job" "$sweep" <<'PY' || fail "the messages: $(cat "$work/hook.log")"
import json, sys
lines = [json.loads(l) for l in open(sys.argv[1])]
job, sweep = sys.argv[2], sys.argv[3]
assert all(set(m) == {"text"} for m in lines), lines
texts = sorted(m["text"] for m in lines)
job_text = next(t for t in texts if f"job {job} " in t)
sweep_text = next(t for t in texts if f"sweep {sweep} " in t)
assert job_text.startswith(f'@alice dembuf: job {job} "?channel ??here? look" of alice is done: '
                           "P = "), job_text
assert job_text.endswith(f"(dembuf fetch {job})"), job_text
assert sweep_text == (f'@bob dembuf: sweep {sweep} "curve" of bob has ended: 3 done of 3 jobs '
                      f"(dembuf fetch --sweep {sweep})"), sweep_text
print("posted:", *texts, sep="\n  ")
PY
grep -q "did not take its end (HTTP 503" "$work/n.log" || fail "the 503 was not logged as tried again"
[ "$(job_state "$quiet")" = done ] || fail "job $quiet did not end"
sleep 3  # (a message for the job without --notify would have come by now)
[ "$(wc -l < "$work/hook.log")" = 2 ] || fail "more messages than asked for: $(cat "$work/hook.log")"

echo "== 3. owed while the hook is down, sent after a restart"
stop_hook
late=$("$dembuf" --owner alice submit "${bare[@]}" --notify)
wait_state "$late" done 60
for _ in $(seq 100); do grep -q "did not take its end (no answer" "$work/n.log" && break; sleep 0.1; done
grep -q "did not take its end (no answer" "$work/n.log" || fail "the hook being down was not noticed"
stop_daemon
start_hook "$(sed -n 's|.*:\([0-9]*\)/hooks.*|\1|p' "$work/hook.url")"
# (This hook answers 503 first again: the restarted daemon tries twice.)
start_daemon "$work/n.db" "$work/n.log" "${hooked[@]}"
hook_lines 3 60
grep -q "job $late .* of alice is done" "$work/hook.log" || fail "job $late: $(tail -1 "$work/hook.log")"

echo "== 4. Python's submit(notify=True)"
PYTHONPATH="$python_dir" /usr/bin/python3 - <<'PY' || fail "Python"
import dembuf
with dembuf.connect(owner="carol") as daemon:
    job = daemon.submit(preset="e2", set={"bed.thickness_m": 0, "time.output_interval_s": 1e-4},
                        notify=True)
    assert daemon.server_info()["notify"] is True
print("Python: job", job)
PY
hook_lines 4 60
tail -1 "$work/hook.log" | grep -q "@carol dembuf: job" || fail "Python's job: $(tail -1 "$work/hook.log")"
stop_daemon
echo "PASS"
