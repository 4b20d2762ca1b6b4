#!/usr/bin/env bash
# Item 10 of the robustness suite (docs/robustness.md): the web pages (--http) against hostile
# and careless requests. Bad parameters are refused naming them; paths reach only stored files;
# event streams are capped per user and in all while everything else is still answered; users
# see only their own jobs; forms from another site, oversized requests and headers are refused;
# a second daemon on the same web port is refused; with TLS configured, the pages are HTTPS
# only; a daemon with open event streams stops cleanly. The daemon serves on throughout.
# Usage: web_test.sh DEMBUF DEMBUFD
. "$(dirname "$0")/lib.sh" "$1" "$2"
small_scene "$work/small.toml"

# status URL [curl options]: the HTTP status of a GET.
status() {
  local url=$1
  shift
  curl -s -o "$work/body" -w '%{http_code}' --max-time 10 "$@" "$url" || true
}
# refused URL CODE PATTERN [curl options]: the request is refused with CODE, saying PATTERN.
refused() {
  local url=$1 want=$2 pattern=$3
  shift 3
  local code
  code=$(status "$url" "$@")
  [ "$code" = "$want" ] || fail "$url answered $code, not $want: $(head -c 300 "$work/body")"
  grep -q -- "$pattern" "$work/body" || fail "$url: $(head -c 300 "$work/body")"
}

cat > "$work/dembufd.toml" <<'TOML'
http_max_streams_per_user = 2
http_max_streams = 3
TOML
db=$work/dembuf.db
declare -A token
for user in alice bob carol; do
  token[$user]=$("$dembufd" --db "$db" token-create "$user" 2>/dev/null)
done
start_daemon "$db" "$work/dembufd.log" --config "$work/dembufd.toml" --workers 2 \
  --shutdown-grace 1 --http 0.0.0.0:0
web="http://127.0.0.1:$(web_base "$work/dembufd.log" | sed 's|.*:||')"
as() { local user=$1; shift; "$dembuf" --token "${token[$user]}" "$@"; }
auth() { echo "Authorization: Bearer ${token[$1]}"; }

# Long jobs, one each for alice and bob, so that their streams stay open.
alice_job=$(as alice submit "$work/small.toml" --set time.end_s=60 --set time.output_interval_s=1e-3 2>/dev/null)
bob_job=$(as bob submit "$work/small.toml" --set time.end_s=60 --set time.output_interval_s=1e-3 2>/dev/null)

# --- bad parameters: 400 naming the parameter, the value and the range -------------------------
refused "$web/api/jobs?limit=abc" 400 'limit: \\"abc\\" must be a whole number from 1 to 1000' -H "$(auth alice)"
refused "$web/api/jobs?limit=1000000" 400 "limit: .* from 1 to 1000" -H "$(auth alice)"
refused "$web/api/jobs?state=sleeping" 400 "state: .*sleeping.* must be queued" -H "$(auth alice)"
refused "$web/api/jobs?sweep=-1" 400 "sweep: " -H "$(auth alice)"
refused "$web/api/jobs/$alice_job/events" 400 "Last-Event-ID: .* must be a whole number" \
  -H "$(auth alice)" -H "Last-Event-ID: ../../1"
refused "$web/api/jobs/123456789012345678901234" 404 "no such page" -H "$(auth alice)"
refused "$web/api/jobs/99999" 404 "id: no job 99999" -H "$(auth alice)"
refused "$web/api/sweeps/0" 400 "id: .*0.* must be a whole number from 1" -H "$(auth alice)"
refused "$web/api/sweeps/77" 404 "id: no sweep 77" -H "$(auth alice)"

# --- paths: only the stored files of an ended job, by name --------------------------------------
refused "$web/api/jobs/$alice_job/files/plate_force.csv" 409 "is running\|is preparing_bed\|is queued" -H "$(auth alice)"
for path in ../../../etc/passwd %2e%2e/%2e%2e/etc/passwd /etc/passwd 'snapshots/../../x' '%00'; do
  code=$(status "$web/api/jobs/$alice_job/files/$path" -H "$(auth alice)" --path-as-is)
  case "$code" in 404 | 409 | 400) ;; *) fail "files/$path answered $code" ;; esac
  if grep -q "root:" "$work/body"; then fail "files/$path served a file of the machine"; fi
done
refused "$web/static/../../dembuf.db" 404 "" --path-as-is

# --- users: their own jobs only ------------------------------------------------------------------
refused "$web/api/jobs/$bob_job" 403 "belongs to bob" -H "$(auth alice)"
refused "$web/api/jobs/$bob_job/events" 403 "belongs to bob" -H "$(auth alice)"
[ "$(status "$web/api/jobs" -H "$(auth alice)")" = 200 ] || fail "alice's list"
grep -q "\"owner\":\"bob\"" "$work/body" && fail "alice's list shows bob's job"
refused "$web/api/jobs" 401 "Bearer TOKEN" -H "Authorization: Basic YWxpY2U6eA=="
refused "$web/api/jobs" 401 "token: not known" -H "Authorization: Bearer $(printf '%064d' 0)"
refused "$web/api/jobs" 401 "needs a token" -H "Cookie: dembuf_session=$(printf '%064d' 0)"

# --- event streams: capped per user and in all; the rest is answered at once --------------------
stream() {  # stream USER JOB: an event stream in the background
  curl -s -N --max-time 120 -H "$(auth "$1")" "$web/api/jobs/$2/events" > /dev/null &
  streams+=($!)
}
streams=()
stream alice "$alice_job"
stream alice "$alice_job"
sleep 1
refused "$web/api/jobs/$alice_job/events" 429 "alice has 2 event streams open; at most 2 per user" -H "$(auth alice)"
stream bob "$bob_job"
sleep 1
refused "$web/api/jobs/$bob_job/events" 429 "the server has 3 event streams open; at most 3 (http_max_streams)" -H "$(auth bob)"
# Every one answered (a starved pool would leave them waiting for a thread: curl's --max-time
# in status() ends a hang); how fast is the benchmark's business (tests/bench/web_streams.py).
for _ in $(seq 20); do
  [ "$(status "$web/api/jobs/$alice_job" -H "$(auth alice)")" = 200 ] || fail "a request while the streams are open"
done
# A stream whose page left gives its place back.
kill "${streams[0]}"
for _ in $(seq 30); do
  code=$(status "$web/api/jobs/$alice_job/events" -H "$(auth alice)" --max-time 2)
  [ "$code" = 200 ] && break
  sleep 0.5
done
[ "$code" = 200 ] || fail "alice could not open a stream after one ended ($code)"

# --- forms, sizes and headers ----------------------------------------------------------------------
refused "$web/login" 403 "Origin: not this site" -H "Origin: http://evil.example" \
  --data-urlencode "token=${token[alice]}"
code=$(status "$web/login" --data-urlencode "token=${token[alice]}" \
       --data-urlencode "next=//evil.example/x" -o /dev/null -D "$work/headers")
[ "$code" = 303 ] || fail "login answered $code"
grep -qi "^location: /$(printf '\r')\{0,1\}$" "$work/headers" || fail "login sent elsewhere: $(grep -i location "$work/headers")"
grep -qi "^set-cookie: dembuf_session=.*HttpOnly; SameSite=Strict" "$work/headers" || fail "cookie: $(grep -i set-cookie "$work/headers")"
head -c 100000 /dev/zero | tr '\0' 'x' > "$work/big"
code=$(status "$web/login" --data-binary "@$work/big")
[ "$code" = 413 ] || fail "a 100 kB form answered $code"
code=$(status "$web/api/server" -H "$(auth alice)" -H "X-Big: $(head -c 20000 /dev/zero | tr '\0' 'y')")
case "$code" in 400 | 431 | 000) ;; *) fail "a 20 kB header answered $code" ;; esac
# Slow and silent connections are dropped without holding the server.
for _ in $(seq 5); do (exec 3<> "/dev/tcp/127.0.0.1/${web##*:}"; sleep 20) & done
sleep 1
[ "$(status "$web/api/server" -H "$(auth carol)")" = 200 ] || fail "the server beside silent connections"

# --- one daemon per web port ----------------------------------------------------------------------
expect_exit 1 "http: cannot listen on 0.0.0.0:${web##*:}" "$dembufd" --listen 127.0.0.1:0 \
  --db "$work/two.db" --http "0.0.0.0:${web##*:}"
expect_exit 2 "http: \"localhost\" must be HOST:PORT" "$dembufd" --db "$work/two.db" --http localhost
as alice server-info > /dev/null || fail "the daemon stopped serving"

# --- a stop with streams of running jobs open: clean, within the grace -----------------------------
start=$(date +%s)
stop_daemon
[ $(($(date +%s) - start)) -lt 15 ] || fail "the stop took $(($(date +%s) - start)) s with a stream open"
grep -q "stopped cleanly" "$work/dembufd.log" || fail "no clean stop"
kill "${streams[@]}" 2>/dev/null || true

# --- TLS: the pages are HTTPS only ----------------------------------------------------------------
openssl req -x509 -newkey rsa:2048 -nodes -days 1 -subj "/CN=localhost" \
  -addext "subjectAltName=DNS:localhost,IP:127.0.0.1" \
  -keyout "$work/key.pem" -out "$work/cert.pem" 2> /dev/null || fail "openssl"
printf 'access = "local"\ntls_cert = "%s"\ntls_key = "%s"\n' "$work/cert.pem" "$work/key.pem" > "$work/tls.toml"
start_daemon "$work/tls.db" "$work/tls.log" --config "$work/tls.toml" --http 127.0.0.1:0
base=$(web_base "$work/tls.log")
case "$base" in https://*) ;; *) fail "the pages are not HTTPS: $base" ;; esac
port=${base##*:}
[ "$(status "https://localhost:$port/api/server" --cacert "$work/cert.pem")" = 200 ] ||
  fail "HTTPS with the certificate: $(head -c 200 "$work/body")"
code=$(status "http://127.0.0.1:$port/api/server")
[ "$code" != 200 ] || fail "plain HTTP was answered"
stop_daemon
echo "web test passed"
