#!/usr/bin/env bash
# Item 8 of the robustness suite (docs/robustness.md): denial of service. Each watch stream
# held a server thread, and 3,000 of them exhausted the threads: now streams are capped per
# user and in all (max_watch_streams_per_user, max_watch_streams), the thread pool is sized
# above the cap so that other requests are still answered, and a request larger than
# max_request_kb is refused before it is read. (Costs are bounded by the job limits of the
# costs test.) Here with small caps: 3 per user, 5 in all, 64 kB requests.
# Usage: streams_test.sh DEMBUF DEMBUFD
. "$(dirname "$0")/lib.sh" "$1" "$2"
cat > "$work/dembufd.toml" <<'TOML'
access = "tokens"
max_watch_streams_per_user = 3
max_watch_streams = 5
max_request_kb = 64
TOML
declare -A token
for user in alice bob carol; do
  token[$user]=$("$dembufd" --db "$work/dembuf.db" token-create "$user" 2>/dev/null)
done
start_daemon "$work/dembuf.db" "$work/dembufd.log" --config "$work/dembufd.toml"
as() { local user=$1; shift; "$dembuf" --token "${token[$user]}" "$@"; }
job=$(as alice submit --set time.end_s=30 --set time.output_interval_s=1e-3 2>/dev/null)

watchers=()
# Each user watches a job of their own (another user's job would be refused as not theirs).
bob_job=$(as bob submit --set time.end_s=30 --set time.output_interval_s=1e-3 2>/dev/null)
carol_job=$(as carol submit --set time.end_s=30 --set time.output_interval_s=1e-3 2>/dev/null)
job_of() { case $1 in alice) echo "$job" ;; bob) echo "$bob_job" ;; carol) echo "$carol_job" ;; esac; }
watch() {  # watch USER: a stream in the background
  "$dembuf" --token "${token[$1]}" watch "$(job_of "$1")" --csv > /dev/null 2>> "$work/watch.err" &
  watchers+=($!)
}
refused_watch() {  # refused_watch USER PATTERN
  local code=0
  timeout -s KILL 10 "$dembuf" --token "${token[$1]}" watch "$(job_of "$1")" --csv > /dev/null \
    2> "$work/err" || code=$?
  [ "$code" = 1 ] || fail "watch by $1 exited $code: $(cat "$work/err")"
  grep -q -- "$2" "$work/err" || fail "watch by $1: $(cat "$work/err")"
}
for _ in 1 2 3; do watch alice; done
sleep 1
refused_watch alice "alice has 3 watch streams open; at most 3 per user"
watch bob
watch bob
sleep 1
refused_watch carol "the server has 5 watch streams open; at most 5"
# Everything else is still answered (the client's deadline ends a request left waiting for a
# thread; timings are the load benchmark's, docs/service.md).
as carol server-info > /dev/null || fail "server-info while the streams are open"
as alice status "$job" > /dev/null || fail "status while the streams are open"
# A stream that ends gives its place back (once the server sees its client gone).
kill "${watchers[0]}"
wait "${watchers[0]}" 2>/dev/null || true
for _ in $(seq 20); do
  code=0
  timeout -s KILL 2 "$dembuf" --token "${token[alice]}" watch "$job" --csv > /dev/null \
    2> "$work/err" || code=$?
  [ "$code" = 137 ] && break  # still streaming when stopped: it had a place
  sleep 0.5
done
[ "$code" = 137 ] || fail "alice could not watch again after a stream ended: $(cat "$work/err")"

# A request larger than the server reads.
{ echo "# $(head -c 100000 /dev/zero | tr '\0' 'x')"; echo "[bed]"; echo "thickness_m = 0.0"; } > "$work/big.toml"
code=0
as alice submit "$work/big.toml" > /dev/null 2> "$work/err" || code=$?
[ "$code" = 2 ] || fail "a 100 kB request exited $code: $(cat "$work/err")"
grep -q "larger than this server accepts (max_request_kb)" "$work/err" || fail "$(cat "$work/err")"
as alice server-info > /dev/null || fail "the daemon died"
kill "${watchers[@]}" 2>/dev/null || true
for user in alice bob carol; do as "$user" cancel "$(job_of "$user")" > /dev/null; done
stop_daemon
echo "streams test passed"
