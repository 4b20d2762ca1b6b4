#!/usr/bin/env bash
# The access policy (docs/service.md, "Access"), row by row, on both doors of one daemon: gRPC
# through the real client and the web API through curl, as the job's owner, another user, an
# admin, a caller with no token and one with a wrong token. Then the two ways a daemon used
# to be open by accident: web pages on loopback beside a gRPC address that asks for tokens
# (the pages answered everyone as an admin), and a local daemon listening beyond loopback.
# Server reflection asks for a token as the rest does.
# Usage: access_test.sh DEMBUF DEMBUFD
. "$(dirname "$0")/../robustness/lib.sh" "$1" "$2"

db=$work/dembuf.db
alice=$("$dembufd" --db "$db" token-create alice 2>/dev/null)
bob=$("$dembufd" --db "$db" token-create bob 2>/dev/null)
root=$("$dembufd" --db "$db" token-create root --admin 2>/dev/null)
wrong=$(printf '%064d' 7)
# The default policy (tokens) with gRPC and the web pages both on loopback.
start_daemon "$db" "$work/dembufd.log" --access tokens --workers 1 --http 127.0.0.1:0
web=$(web_base "$work/dembufd.log")

declare -A token=([owner]=$alice [other]=$bob [admin]=$root [wrong]=$wrong [none]="")
callers=(owner other admin none wrong)
# grpc CALLER ARGS...: the client as that caller.
grpc() {
  local who=$1
  shift
  if [ -n "${token[$who]}" ]; then "$dembuf" --token "${token[$who]}" "$@"; else "$dembuf" "$@"; fi
}
# http CALLER PATH: the HTTP status of a GET as that caller; the body in $work/body.
http() {
  local who=$1 auth=()
  [ -n "${token[$who]}" ] && auth=(-H "Authorization: Bearer ${token[$who]}")
  curl -s --max-time 10 -o "$work/body" -w '%{http_code}' "${auth[@]}" "$web$2"
}
# allowed_grpc CALLER PATTERN ARGS...: the call succeeds (or fails for another reason than
# access) and its output says PATTERN.
allowed_grpc() {
  local who=$1 pattern=$2
  shift 2
  grpc "$who" "$@" > "$work/out" 2>&1 || true
  grep -q -- "$pattern" "$work/out" || fail "gRPC $* as $who: $(head -c 300 "$work/out")"
  if grep -q "needs a token\|not known to this server\|belongs to\|may act only" "$work/out"; then
    fail "gRPC $* as $who was refused: $(head -c 300 "$work/out")"
  fi
}
# refused_grpc CALLER PATTERN ARGS...: the call fails saying PATTERN.
refused_grpc() {
  local who=$1 pattern=$2
  shift 2
  if grpc "$who" "$@" > "$work/out" 2>&1; then fail "gRPC $* as $who was allowed"; fi
  grep -q -- "$pattern" "$work/out" || fail "gRPC $* as $who: $(head -c 300 "$work/out")"
}
# expect_http CALLER PATH STATUS [PATTERN]
expect_http() {
  local code
  code=$(http "$1" "$2")
  [ "$code" = "$3" ] || fail "HTTP $2 as $1 answered $code, not $3: $(head -c 300 "$work/body")"
  [ -z "${4:-}" ] || grep -q -- "$4" "$work/body" || fail "HTTP $2 as $1: $(head -c 300 "$work/body")"
}

# Alice's job, ended; a sweep of hers.
scene=(--set bed.thickness_m=0 --set projectile.speed_m_s=2 --set time.end_s=0.002)
job=$(grpc owner submit "${scene[@]}" 2>/dev/null)
DEMBUF_TOKEN=$alice wait_state "$job" "done" 60
sweep=$(grpc owner sweep "${scene[@]}" --vary projectile.speed_m_s=1,2 2>&1 | sed -n 's/^sweep \([0-9]*\).*/\1/p')
[ -n "$sweep" ] || fail "alice's sweep was not submitted"
# Two more of hers, ended, for deleting: one by her, one by the admin.
declare -A deletable
for who in owner admin; do
  deletable[$who]=$(grpc owner submit "${scene[@]}" 2>/dev/null)
  DEMBUF_TOKEN=$alice wait_state "${deletable[$who]}" "done" 60
done

for who in "${callers[@]}"; do
  case $who in
    none)
      for args in "server-info" "list" "status $job" "watch $job" "cancel $job" "delete $job" \
        "fetch $job --out $work/f-none" "status --sweep $sweep" "submit ${scene[*]}"; do
        # shellcheck disable=SC2086
        refused_grpc none "needs a token" $args
      done
      for path in /api/server /api/jobs "/api/jobs/$job" "/api/jobs/$job/events" \
        "/api/jobs/$job/files/summary.json" /api/sweeps "/api/sweeps/$sweep"; do
        expect_http none "$path" 401 "needs a token"
      done
      ;;
    wrong)
      for args in "server-info" "list" "status $job" "watch $job" "cancel $job" "delete $job" \
        "fetch $job --out $work/f-wrong" "submit ${scene[*]}"; do
        # shellcheck disable=SC2086
        refused_grpc wrong "not known to this server" $args
      done
      for path in /api/server /api/jobs "/api/jobs/$job" "/api/jobs/$job/files/summary.json"; do
        expect_http wrong "$path" 401 "not known to this server"
      done
      ;;
    other)
      allowed_grpc other "dembufd" server-info
      grpc other list > "$work/out" 2>&1
      if grep -q "alice" "$work/out"; then fail "bob lists alice's jobs"; fi
      refused_grpc other "owner: bob may act only as bob" list --owner alice
      for args in "status $job" "watch $job" "cancel $job" "fetch $job --out $work/f-other" \
        "status --sweep $sweep" "cancel --sweep $sweep" "delete $job" "delete --sweep $sweep"; do
        # shellcheck disable=SC2086
        refused_grpc other "belongs to alice" $args
      done
      refused_grpc other "may act only as bob, not as alice" --owner alice submit "${scene[@]}"
      expect_http other /api/server 200 '"name":"bob"'
      expect_http other /api/jobs 200
      if grep -q '"owner":"alice"' "$work/body"; then fail "bob's web list shows alice's jobs"; fi
      for path in "/api/jobs/$job" "/api/jobs/$job/events" "/api/jobs/$job/files/summary.json" \
        "/api/sweeps/$sweep"; do
        expect_http other "$path" 403 "belongs to alice"
      done
      ;;
    owner | admin)
      allowed_grpc "$who" "dembufd" server-info
      allowed_grpc "$who" "alice" list
      allowed_grpc "$who" "owner alice" status "$job"
      allowed_grpc "$who" "done" watch "$job"
      allowed_grpc "$who" "has already ended" cancel "$job"
      allowed_grpc "$who" "wrote" fetch "$job" --out "$work/f-$who" --no-plots
      allowed_grpc "$who" "owner alice" status --sweep "$sweep"
      allowed_grpc "$who" "deleted 1 job" delete "${deletable[$who]}"
      allowed_grpc "$who" "" --owner alice submit "${scene[@]}"
      expect_http "$who" /api/server 200 '"tokens_required":true'
      expect_http "$who" /api/jobs 200 '"owner":"alice"'
      expect_http "$who" "/api/jobs/$job" 200 '"owner":"alice"'
      expect_http "$who" "/api/jobs/$job/events" 200 "event: end"
      expect_http "$who" "/api/jobs/$job/files/summary.json" 200 "peak_plate_force_N"
      expect_http "$who" "/api/sweeps/$sweep" 200 '"owner":"alice"'
      ;;
  esac
done
# Only an admin lists another user's jobs by name.
allowed_grpc admin "alice" list --owner alice
# Only an admin puts a prepared bed in the cache everyone's jobs read (its owner is no one).
bed=(--set cylinder.radius_m=0.02 --set bed.thickness_m=0.01 --set bed.source_thickness_m=0.015
  --set projectile.diameter_m=0.012)
"$dembuf" prepare-bed "${bed[@]}" --bed-cache "$work/beds" > /dev/null 2>&1 || fail "prepare-bed"
refused_grpc owner "only an admin may put prepared beds" bed push "${bed[@]}" --bed-cache "$work/beds"
allowed_grpc admin "cut bed [0-9a-f]*.*pushed" bed push "${bed[@]}" --bed-cache "$work/beds"
# Server reflection (for grpcurl: -H "authorization: Bearer TOKEN") identifies its caller
# first, as every other call: a stream without a valid token is refused before it takes one of
# the few places (each holds a thread), and a user holds at most a quarter of them.
/usr/bin/python3 - "$DEMBUF_SERVER" "$alice" "$wrong" <<'PY' || fail "reflection's access"
import queue, sys
import grpc
server, alice, wrong = sys.argv[1:]
channel = grpc.insecure_channel(server)
info = channel.stream_stream("/grpc.reflection.v1.ServerReflection/ServerReflectionInfo")
LIST_SERVICES = b"\x3a\x00"  # ServerReflectionRequest { list_services = "" }
def open_stream(token):
    questions = queue.Queue()
    def requests():
        while (q := questions.get()) is not None:
            yield q
    metadata = [("authorization", "Bearer " + token)] if token else []
    call = info(requests(), metadata=metadata, timeout=30)
    questions.put(LIST_SERVICES)
    return questions, call
def refusal(token):
    questions, call = open_stream(token)
    try:
        next(call)
    except grpc.RpcError as e:
        return e.code(), e.details()
    finally:
        questions.put(None)
    return None
code, why = refusal("")
assert code == grpc.StatusCode.UNAUTHENTICATED and "needs a token" in why, (code, why)
code, why = refusal(wrong)
assert code == grpc.StatusCode.UNAUTHENTICATED and "not known" in why, (code, why)
held = [open_stream(alice) for _ in range(4)]
for _, call in held:
    assert b"dembuf.v1.Dembuf" in next(call), "alice's reflection stream did not answer"
code, why = refusal(alice)
assert code == grpc.StatusCode.RESOURCE_EXHAUSTED and "at most 4 per user" in why, (code, why)
for questions, call in held:
    questions.put(None)
    list(call)
channel.close()
PY
grpc admin cancel --sweep "$sweep" > /dev/null 2>&1 || true
stop_daemon

# One policy for the daemon: gRPC beyond loopback asking for tokens does not leave the web
# pages on loopback open (they answered {"name":"local","admin":true} to anyone).
start_daemon "$db" "$work/lan.log" --access tokens --listen 0.0.0.0:0 --http 127.0.0.1:0
web=$(web_base "$work/lan.log")
expect_http none /api/jobs 401 "needs a token"
expect_http none "/api/jobs/$job" 401 "needs a token"
stop_daemon

# "local" (no token: the machine's trusted user, an admin) only when the operator says so,
# and only on loopback addresses.
expect_exit 2 'access: "local" lets any caller act as an admin, so listen must be' \
  "$dembufd" --db "$work/x.db" --access local --listen 0.0.0.0:0
expect_exit 2 'access: "local" lets any caller act as an admin, so http must be on loopback' \
  "$dembufd" --db "$work/x.db" --access local --listen 127.0.0.1:0 --http 0.0.0.0:0
expect_exit 2 'access: "open" must be "tokens" or "local"' "$dembufd" --db "$work/x.db" --access open
printf 'require_tokens = false\n' > "$work/old.toml"
expect_exit 2 "require_tokens is replaced by access" "$dembufd" --db "$work/x.db" --config "$work/old.toml"
start_daemon "$db" "$work/local.log" --access local --http 127.0.0.1:0
web=$(web_base "$work/local.log")
allowed_grpc none "owner alice" status "$job"
expect_http none /api/server 200 '"admin":true'
expect_http none "/api/jobs/$job" 200 '"owner":"alice"'
# A token still names its holder, who sees only their own.
refused_grpc other "belongs to alice" status "$job"
expect_http other "/api/jobs/$job" 403 "belongs to alice"
expect_http wrong "/api/jobs/$job" 401 "not known to this server"
stop_daemon
echo "access test passed"
