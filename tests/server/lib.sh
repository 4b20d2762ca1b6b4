# Shared by the service tests: start a real dembufd on a free loopback port with a temporary
# database, and wait for job states through the real client.
# Sourced as `. lib.sh DEMBUF DEMBUFD`: sets dembuf, dembufd and work (a temporary folder,
# removed at exit together with any daemon still running).
set -eu
dembuf=$1
dembufd=$2
work=$(mktemp -d)
daemon_pid=""
trap 'rc=$?; [ -z "$daemon_pid" ] || kill -9 "$daemon_pid" 2>/dev/null || true; rm -rf "$work"; exit $rc' EXIT
export OMP_WAIT_POLICY=passive

fail() { echo "FAIL: $*"; [ -n "${daemon_log:-}" ] && tail -20 "$daemon_log"; exit 1; }

# start_daemon DB LOG [dembufd flags...]: starts it (on a free loopback port unless the flags
# give --listen), sets daemon_pid and DEMBUF_SERVER. Unless
# the flags give --access or a --config (which then says it), the daemon is the trusted local
# one (--access local): the tests of tokens say so themselves.
start_daemon() {
  local db=$1 log=$2
  shift 2
  daemon_log=$log
  local before=0
  [ -f "$log" ] && before=$(wc -l < "$log")
  # Made here: the daemon's shell may not have opened it yet when it is first read.
  : >> "$log"
  local access=(--access local) listen=(--listen 127.0.0.1:0)
  case " $* " in *" --access "* | *" --config "*) access=() ;; esac
  case " $* " in *" --listen "*) listen=() ;; esac
  "$dembufd" "${listen[@]}" --db "$db" "${access[@]}" "$@" >> "$log" 2>&1 &
  daemon_pid=$!
  local port=""
  for _ in $(seq 100); do
    port=$(tail -n +$((before + 1)) "$log" | sed -n 's/.*listening on .* (port \([0-9]*\)).*/\1/p')
    [ -n "$port" ] && break
    kill -0 "$daemon_pid" 2>/dev/null || fail "dembufd did not start"
    sleep 0.1
  done
  [ -n "$port" ] || fail "dembufd did not report its port"
  export DEMBUF_SERVER=127.0.0.1:$port
}

# web_base LOG: the address of the web pages of the daemon started last ("http://HOST:PORT").
web_base() {
  tail -n 200 "$1" | sed -n 's|.*web pages on \(https\{0,1\}://[^/]*\)/.*|\1|p' | tail -1
}

stop_daemon() {
  kill -TERM "$daemon_pid" 2>/dev/null || true
  wait "$daemon_pid" 2>/dev/null || true
  daemon_pid=""
}

# job_state ID: prints the job's state.
job_state() {
  # (status exits 3 for a failed job: the state is what is wanted here)
  { "$dembuf" status "$1" || true; } | sed -n '1s/.*(\(.*\))$/\1/p'
}

# wait_state ID STATES SECONDS: waits until the job is in one of STATES (separated by spaces).
wait_state() {
  local state="" wanted
  for _ in $(seq $(($3 * 10))); do
    state=$(job_state "$1")
    for wanted in $2; do [ "$state" = "$wanted" ] && return 0; done
    sleep 0.1
  done
  fail "job $1 is $state, not $2, after $3 s"
}

# A bed that settles in seconds: a 2 cm cylinder, a 1.5 cm source cut to 1 cm.
small_scene() {
  cat > "$1" <<'TOML'
[cylinder]
radius_m = 0.02
[bed]
thickness_m = 0.01
source_thickness_m = 0.015
[projectile]
diameter_m = 0.012
mass_kg = 0.01
speed_m_s = 2.0
height_m = 0.02
TOML
}
