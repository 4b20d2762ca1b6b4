#!/usr/bin/env bash
# Conventions for scripts and tools. `--version` answers; the standard health service
# (grpc.health.v1) says SERVING for the server ("") and for the service's own name, as load
# balancers and grpc_health_probe -service=dembuf.v1.Dembuf ask, and NOT_FOUND for a name it
# does not serve (asked with python3-grpcio, the request and answer written by hand: one
# string field, one enum field, so that no health stubs are needed; Debian's python3, which
# python3-grpcio is installed for). `--json` on list, status, server-info, run and sweep gives
# JSON that agrees with the text output and the result files; -q leaves the results alone.
# Usage: conventions_test.sh DEMBUF DEMBUFD
. "$(dirname "$0")/lib.sh" "$1" "$2"

"$dembufd" --version | grep -Eq '^dembufd [0-9]+\.[0-9]+\.[0-9]+$' || fail "dembufd --version"
"$dembuf" --version | grep -Eq '^dembuf [0-9]+\.[0-9]+\.[0-9]+$' || fail "dembuf --version"

start_daemon "$work/dembuf.db" "$work/dembufd.log"
/usr/bin/python3 - "$DEMBUF_SERVER" <<'PY' || fail "health answers"
import sys
import grpc

channel = grpc.insecure_channel(sys.argv[1])
check = channel.unary_unary("/grpc.health.v1.Health/Check")

def status(service):
    name = service.encode()
    request = (b"\x0a" + bytes([len(name)]) + name) if name else b""
    try:
        answer = check(request, timeout=10)
    except grpc.RpcError as e:
        return e.code().name
    # HealthCheckResponse { ServingStatus status = 1; }: SERVING is 1.
    return {b"\x08\x01": "SERVING", b"\x08\x02": "NOT_SERVING"}.get(answer, repr(answer))

for service, wanted in (("", "SERVING"), ("dembuf.v1.Dembuf", "SERVING"),
                        ("no.such.Service", "NOT_FOUND")):
    got = status(service)
    if got != wanted:
        sys.exit(f"health of {service!r}: {got}, expected {wanted}")
print("health: SERVING for the server and dembuf.v1.Dembuf, NOT_FOUND for another name")
PY

# --- --json and -q ------------------------------------------------------------------------
bare=(--set projectile.mass_kg=0.3 --set projectile.speed_m_s=5 --set projectile.height_m=0.3)
"$dembuf" -q submit "${bare[@]}" --name json-check > "$work/submit.out" 2> "$work/submit.err"
job=$(cat "$work/submit.out")
[[ "$job" =~ ^[0-9]+$ ]] || fail "submit -q printed '$job', not the job id alone"
[ ! -s "$work/submit.err" ] || fail "submit -q said more: $(cat "$work/submit.err")"
wait_state "$job" done 120
"$dembuf" list --json > "$work/list.json"
"$dembuf" list > "$work/list.txt"
"$dembuf" status "$job" --json > "$work/status.json"
"$dembuf" fetch "$job" --out "$work/fetched" --no-plots > /dev/null
"$dembuf" server-info --json > "$work/info.json"
"$dembuf" server-info > "$work/info.txt"
/usr/bin/python3 - "$work" "$job" <<'PY' || fail "JSON output"
import json, sys
work, job = sys.argv[1], int(sys.argv[2])
jobs = json.load(open(f"{work}/list.json"))["jobs"]
mine = [j for j in jobs if j["id"] == job]
assert len(mine) == 1, f"job {job} not once in list --json"
assert mine[0]["state"] == "done" and mine[0]["name"] == "json-check", mine[0]
# The table shows the same jobs, states and names.
rows = [line.split() for line in open(f"{work}/list.txt").read().splitlines()[1:]]
assert [(int(r[0]), r[1]) for r in rows] == [(j["id"], j["state"]) for j in jobs], "list differs"
status = json.load(open(f"{work}/status.json"))
fetched = json.load(open(f"{work}/fetched/summary.json"))
assert status["id"] == job and status["state"] == "done"
assert status["summary"] == fetched, "status --json summary differs from the fetched one"
assert status["peak_plate_force_N"] == fetched["peak_plate_force_N"]
assert status["started_at"] and status["finished_at"] and status["sweep_id"] is None
info = json.load(open(f"{work}/info.json"))
text = open(f"{work}/info.txt").read()
assert f"dembufd {info['version']} at {info['address']}" in text, (info, text)
assert f"workers {info['workers']} x {info['threads_per_job']} threads" in text, (info, text)
print("list, status and server-info --json agree with the text and the fetched files")
PY
stop_daemon

# Local runs: the JSON alone on stdout (the report on stderr), the summary as written.
"$dembuf" run "${bare[@]}" --no-plots --json --out "$work/run" > "$work/run.json" 2> "$work/run.err"
grep -q 'peak plate force' "$work/run.err" || fail "run --json: the report is not on stderr"
"$dembuf" sweep "${bare[@]}" --vary projectile.speed_m_s=4,5 --local --json --out "$work/sweep" \
  > "$work/sweep.json" 2> "$work/sweep.err"
/usr/bin/python3 - "$work" <<'PY' || fail "local JSON output"
import json, os, sys
work = sys.argv[1]
run = json.load(open(f"{work}/run.json"))
assert run["out_dir"] == os.path.abspath(f"{work}/run"), run["out_dir"]
assert run["summary"] == json.load(open(f"{work}/run/summary.json"))
sweep = json.load(open(f"{work}/sweep.json"))
assert sweep["failed"] == 0 and sweep["summary"] == json.load(open(f"{work}/sweep/summary.json"))
assert len(sweep["summary"]["points"]) == 2, sweep["summary"]["points"]
print("run and sweep --json: the folder and its summary.json")
PY
# -q: no report, no progress; the results are written all the same.
"$dembuf" -q run "${bare[@]}" --no-plots --out "$work/quiet" > "$work/quiet.out" 2>&1
[ ! -s "$work/quiet.out" ] || fail "run -q printed: $(cat "$work/quiet.out")"
[ -f "$work/quiet/summary.json" ] || fail "run -q wrote no summary.json"
echo "conventions: --version, health by service name, --json, -q"
