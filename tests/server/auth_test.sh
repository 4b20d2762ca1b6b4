#!/usr/bin/env bash
# A shared server's guarantees: per-user tokens (stored hashed) required on every request,
# users confined to their own jobs unless admin, per-user quotas, and TLS with a certificate
# made here. No token, a wrong token, another user's job and a passed quota are each refused
# with their own status.
# Usage: auth_test.sh DEMBUF DEMBUFD
. "$(dirname "$0")/lib.sh" "$1" "$2"

# A self-signed certificate for localhost.
openssl req -x509 -newkey rsa:2048 -nodes -days 1 -subj "/CN=localhost" \
  -addext "subjectAltName=DNS:localhost,IP:127.0.0.1" \
  -keyout "$work/key.pem" -out "$work/cert.pem" 2> /dev/null || fail "openssl"
db=$work/dembuf.db
alice=$("$dembufd" --db "$db" token-create alice 2>/dev/null)
bob=$("$dembufd" --db "$db" token-create bob 2>/dev/null)
root=$("$dembufd" --db "$db" token-create root --admin 2>/dev/null)
[ ${#alice} = 64 ] || fail "token: $alice"
"$dembufd" --db "$db" token-list | grep -q "^root (admin)$" || fail "token-list"
# Only hashes are stored.
if grep -qa "$alice" "$db"; then fail "a token is stored in clear"; fi

cat > "$work/dembufd.toml" <<TOML
access = "tokens"
tls_cert = "$work/cert.pem"
tls_key = "$work/key.pem"
quota_queued_jobs = 2
quota_beads = 20000
TOML
start_daemon "$db" "$work/dembufd.log" --config "$work/dembufd.toml" --workers 1
port=${DEMBUF_SERVER##*:}
export DEMBUF_SERVER=localhost:$port DEMBUF_TLS_CA=$work/cert.pem

expect() {  # expect PATTERN COMMAND...: fails unless the command fails saying PATTERN
  local pattern=$1
  shift
  if "$dembuf" "$@" > "$work/out" 2> "$work/err"; then fail "'$*' was allowed"; fi
  grep -q "$pattern" "$work/err" || fail "'$*': $(cat "$work/err")"
}
expect "needs a token" server-info
expect "not known" --token "$(printf '%064d' 0)" server-info
"$dembuf" --token "$alice" server-info > /dev/null || fail "alice over TLS"
# Without TLS the server does not answer.
if DEMBUF_TLS_CA= "$dembuf" --token "$alice" server-info > /dev/null 2> "$work/err"; then
  fail "a plain-text client was answered"
fi
grep -q "cannot reach" "$work/err" || fail "plain-text client: $(cat "$work/err")"

# Alice's job: hers to see; not Bob's; the admin's too.
scene=(--set bed.thickness_m=0 --set projectile.enabled=false --set time.end_s=2)
job=$("$dembuf" --token "$alice" submit "${scene[@]}" 2>/dev/null)
"$dembuf" --token "$alice" status "$job" | grep -q "owner alice" || fail "alice's job owner"
expect "belongs to alice" --token "$bob" status "$job"
expect "belongs to alice" --token "$bob" cancel "$job"
expect "belongs to alice" --token "$bob" watch "$job"
"$dembuf" --token "$root" status "$job" > /dev/null || fail "admin status"
[ -z "$("$dembuf" --token "$bob" list | tail -n +2)" ] || fail "bob sees alice's jobs"
# A claimed owner does not beat the token: only an admin may file work under another name.
expect "owner: bob may act only as bob, not as alice" --token "$bob" --owner alice submit "${scene[@]}"

# Quotas: two queued jobs per user (alice's first one runs), and the bed size.
"$dembuf" --token "$alice" submit "${scene[@]}" > /dev/null 2>&1 || fail "alice's 2nd job"
"$dembuf" --token "$alice" submit "${scene[@]}" > /dev/null 2>&1 || true
expect "quota of 2" --token "$alice" submit "${scene[@]}"
expect "limit is 2e+04 per run" --token "$bob" submit --preset e2 --set bed.thickness_m=0.08
"$dembuf" --token "$root" cancel "$job" > /dev/null || fail "admin cancel"
stop_daemon
echo "auth test passed"
