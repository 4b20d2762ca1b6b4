#!/usr/bin/env bash
# Conventions for scripts and tools. `--version` answers; the standard health service
# (grpc.health.v1) says SERVING for the server ("") and for the service's own name, as load
# balancers and grpc_health_probe -service=dembuf.v1.Dembuf ask, and NOT_FOUND for a name it
# does not serve (asked with python3-grpcio, the request and answer written by hand: one
# string field, one enum field, so that no health stubs are needed; Debian's python3, which
# python3-grpcio is installed for). Server reflection answers on v1: its services, the file
# for dembuf's service, its methods and its dependencies, errors for names it does not know
# (messages from proto/grpc/reflection/v1, compiled by protoc). gRPC's v1alpha is off (it held
# a thread per stream with no cap): UNIMPLEMENTED. `--json` on list, status, server-info, run and sweep gives
# JSON that agrees with the text output and the result files; -q leaves the results alone.
# Usage: conventions_test.sh DEMBUF DEMBUFD
. "$(dirname "$0")/lib.sh" "$1" "$2"

"$dembufd" --version | grep -Eq '^dembufd [0-9]+\.[0-9]+\.[0-9]+$' || fail "dembufd --version"
"$dembuf" --version | grep -Eq '^dembuf [0-9]+\.[0-9]+\.[0-9]+$' || fail "dembuf --version"

start_daemon "$work/dembuf.db" "$work/dembufd.log" --http 127.0.0.1:0
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

proto_dir="$(cd "$(dirname "$0")/../../proto" && pwd)"
mkdir -p "$work/py"
# Compiled from its own folder: a module under grpc/ would hide grpcio's package.
protoc --proto_path="$proto_dir/grpc/reflection/v1" --python_out="$work/py" reflection.proto \
  || fail "protoc cannot compile the reflection proto"
PYTHONPATH="$work/py" timeout 120 /usr/bin/python3 - "$DEMBUF_SERVER" <<'PY' \
  || fail "reflection answers (or no exit within 120 s)"
import sys
import grpc
from google.protobuf import descriptor_pb2
import reflection_pb2 as rv1

channel = grpc.insecure_channel(sys.argv[1])

def ask(version, *requests):
    call = channel.stream_stream(
        f"/grpc.reflection.{version}.ServerReflection/ServerReflectionInfo",
        request_serializer=rv1.ServerReflectionRequest.SerializeToString,
        response_deserializer=rv1.ServerReflectionResponse.FromString)
    answers = list(call(iter(requests), timeout=10))
    assert len(answers) == len(requests), f"{version}: {len(answers)} answers to {len(requests)}"
    for request, answer in zip(requests, answers):
        assert answer.original_request == request, f"{version}: original_request differs"
    return answers

def files(answer):
    assert answer.WhichOneof("message_response") == "file_descriptor_response", answer
    return [descriptor_pb2.FileDescriptorProto.FromString(b)
            for b in answer.file_descriptor_response.file_descriptor_proto]

Q = rv1.ServerReflectionRequest
questions = [Q(list_services=""), Q(file_containing_symbol="dembuf.v1.Dembuf"),
             Q(file_containing_symbol="dembuf.v1.Dembuf.FetchSeries"),
             Q(file_containing_symbol="dembuf.v1.Job"),
             Q(file_by_filename="google/protobuf/api.proto"),
             Q(file_containing_symbol="no.such.Symbol"), Q(file_by_filename="no/such.proto")]
v1 = ask("v1", *questions)
try:
    ask("v1alpha", questions[0])
    sys.exit("v1alpha reflection answered")
except grpc.RpcError as e:
    assert e.code() == grpc.StatusCode.UNIMPLEMENTED, e

services = {s.name for s in v1[0].list_services_response.service}
assert services == {"dembuf.v1.Dembuf", "grpc.health.v1.Health",
                    "grpc.reflection.v1.ServerReflection"}, services

for i, file in ((1, "dembuf/v1/dembuf.proto"), (2, "dembuf/v1/dembuf.proto"),
                (3, "dembuf/v1/dembuf.proto"), (4, "google/protobuf/api.proto")):
    got = files(v1[i])
    assert got[0].name == file, got[0].name
    # Every import comes with the answer, so a client can build the types from it alone.
    names = {f.name for f in got}
    assert all(d in names for f in got for d in f.dependency), names
methods = [m.name for m in files(v1[1])[0].service[0].method]
assert "SubmitJob" in methods and "FetchSeries" in methods, methods

assert len(files(v1[4])) > 1, "api.proto came without its imports"
for answer in v1[5:]:
    assert answer.WhichOneof("message_response") == "error_response", answer
    assert answer.error_response.error_code == grpc.StatusCode.NOT_FOUND.value[0], answer
assert "no.such.Symbol" in v1[5].error_response.error_message

own = files(ask("v1", Q(file_by_filename="grpc/reflection/v1/reflection.proto"))[0])
assert own[0].package == "grpc.reflection.v1" and own[0].service[0].name == "ServerReflection"
empty = ask("v1", Q(host="anything"))[0]
assert empty.error_response.error_code == grpc.StatusCode.INVALID_ARGUMENT.value[0], empty
assert empty.valid_host == "anything"

# Each stream holds a server thread: at most 16 at once, the 17th is refused until one closes.
import queue
def open_stream():
    questions = queue.Queue()
    def requests():
        while (q := questions.get()) is not None:
            yield q
    call = channel.stream_stream(
        "/grpc.reflection.v1.ServerReflection/ServerReflectionInfo",
        request_serializer=rv1.ServerReflectionRequest.SerializeToString,
        response_deserializer=rv1.ServerReflectionResponse.FromString)(requests(), timeout=30)
    questions.put(Q(list_services=""))
    return questions, call
held = []
for k in range(16):
    questions, call = open_stream()
    assert next(call).list_services_response.service, f"stream {k + 1} did not answer"
    held.append((questions, call))
questions, call = open_stream()
try:
    next(call)
    sys.exit("a 17th reflection stream was served")
except grpc.RpcError as e:
    assert e.code() == grpc.StatusCode.RESOURCE_EXHAUSTED, e
    assert "at most 16" in e.details(), e.details()
questions.put(None)
held[0][0].put(None)
list(held[0][1])
questions, call = open_stream()
assert next(call).list_services_response.service, "a stream freed no place"
# Every stream is closed and ended before the channel: Python's exit otherwise waits on calls
# still open.
for q, c in held[1:] + [(questions, call)]:
    q.put(None)
    list(c)
channel.close()
print(f"reflection v1: {len(services)} services, {len(files(v1[1]))} files for dembuf.v1.Dembuf,"
      " as v1alpha answers")
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
"$dembuf" watch "$job" --csv > "$work/watch.csv"
"$dembuf" server-info > "$work/info.txt"
DEMBUF_HTTP=$(web_base "$work/dembufd.log") DEMBUF_PYTHON="$(dirname "$dembuf")/../python" \
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
# One shape for a job: the web API and the Python package say what status --json says, field
# by field (the API said "" and 0 where the CLI said null; Python gave the proto's own names).
import os, urllib.request
sys.path.insert(0, os.environ["DEMBUF_PYTHON"])
import dembuf
api = json.load(urllib.request.urlopen(f"{os.environ['DEMBUF_HTTP']}/api/jobs/{job}"))
with dembuf.connect() as daemon:
    python = daemon.job(job)
# The fetched folder's job.json is that record, without what the folder holds as files.
record = json.load(open(f"{work}/fetched/job.json"))
files_of_their_own = {k: status[k] for k in status if k not in ("summary", "scene_toml")}
for name, other, wanted in (("/api/jobs", api, status), ("Python", python, status),
                            ("job.json", record, files_of_their_own)):
    assert sorted(other) == sorted(wanted), (name, sorted(set(other) ^ set(wanted)))
    for key in wanted:
        assert other[key] == wanted[key], (name, key, other[key], wanted[key])
# The listing likewise: Python's jobs() rows are list --json's jobs (sweep_id None, not 0).
with dembuf.connect() as daemon:
    listed = daemon.jobs(limit=1000)
row = listed[listed["id"] == job].iloc[0].to_dict()
assert sorted(row) == sorted(mine[0]), sorted(set(row) ^ set(mine[0]))
for key in mine[0]:
    assert row[key] == mine[0][key], ("jobs()", key, row[key], mine[0][key])
info = json.load(open(f"{work}/info.json"))
text = open(f"{work}/info.txt").read()
assert f"dembufd {info['version']} at {info['address']}" in text, (info, text)
assert f"workers {info['workers']} x {info['threads_per_job']} threads" in text, (info, text)
# The listings likewise: /api/jobs's row is list --json's, the finished job's peak and P
# included (the API showed a peak 0.0, the CLI none: listings read no summaries).
api_list = json.load(urllib.request.urlopen(f"{os.environ['DEMBUF_HTTP']}/api/jobs"))["jobs"]
api_row = [j for j in api_list if j["id"] == job][0]
assert sorted(api_row) == sorted(mine[0]), sorted(set(api_row) ^ set(mine[0]))
for key in mine[0]:
    assert api_row[key] == mine[0][key], ("/api/jobs", key, api_row[key], mine[0][key])
assert mine[0]["peak_plate_force_N"] == fetched["peak_plate_force_N"], mine[0]
assert mine[0]["progress"]["peak_plate_force_N"] == fetched["peak_plate_force_N"], mine[0]
assert mine[0]["P_N"] == fetched["P_N"], mine[0]
print("list, status and server-info --json agree with the text and the fetched files")

# The live stream at every door, field by field: the gRPC watch (Python's samples and `watch
# --csv`), the web pages' event stream and plate_force.csv have the same columns in the same
# order (the web stream lacked proj_vz_m_s) and the same values.
from dembuf.v1 import dembuf_pb2 as pb
csv_lines = open(f"{work}/fetched/plate_force.csv").read().splitlines()
columns = csv_lines[0].split(",")
assert [f.name for f in pb.ForceSample.DESCRIPTOR.fields] == columns, columns
assert list(dembuf.Sample._fields) == columns == dembuf.SERIES_COLUMNS, columns
watch_lines = open(f"{work}/watch.csv").read().splitlines()
assert watch_lines[0] == "index," + csv_lines[0] + ",state", watch_lines[0]
assert len(watch_lines) == len(csv_lines), (len(watch_lines), len(csv_lines))
for k, (w, c) in enumerate(zip(watch_lines[1:], csv_lines[1:])):
    assert w == f"{k},{c},done", (k, w, c)
with dembuf.connect() as daemon:
    watched = list(daemon.watch(job))
stream = {c: [] for c in columns}
with urllib.request.urlopen(f"{os.environ['DEMBUF_HTTP']}/api/jobs/{job}/events") as events:
    kind = None
    for raw in events:
        line = raw.decode().rstrip("\n")
        if line.startswith("event: "):
            kind = line[7:]
        elif line.startswith("data: ") and kind == "samples":
            batch = json.loads(line[6:])
            assert list(batch)[1:] == columns, list(batch)
            for c in columns:
                stream[c] += batch[c]
        elif line.startswith("data: ") and kind == "end":
            break
assert len(watched) == len(stream["t_s"]) == len(csv_lines) - 1
for k, sample in enumerate(watched):
    for c in columns:
        assert getattr(sample, c) == stream[c][k], (k, c, getattr(sample, c), stream[c][k])
print(f"the live stream: {len(watched)} samples of {len(columns)} columns alike at every door")
PY

# One sweep point at every door: status --sweep --json, /api/sweeps/ID, Python's
# sweep_points() and the fetched folder's points.csv and summary.json, field by field (the
# points were nested in the API, columns in the files, and computed again by Python).
sweep=$("$dembuf" sweep "${bare[@]}" --vary projectile.speed_m_s=4,5 --seeds 2 2> /dev/null)
for _ in $(seq 600); do
  "$dembuf" status --sweep "$sweep" | grep -q "jobs: 4, done 4$" && break
  sleep 0.2
done
"$dembuf" status --sweep "$sweep" --json > "$work/sweep_status.json"
"$dembuf" fetch --sweep "$sweep" --out "$work/fetched_sweep" --no-plots > /dev/null
DEMBUF_HTTP=$(web_base "$work/dembufd.log") DEMBUF_PYTHON="$(dirname "$dembuf")/../python" \
  /usr/bin/python3 - "$work" "$sweep" <<'PY' || fail "a sweep point's doors"
import json, math, os, sys, urllib.request
work, sweep = sys.argv[1], int(sys.argv[2])
sys.path.insert(0, os.environ["DEMBUF_PYTHON"])
import dembuf
status = json.load(open(f"{work}/sweep_status.json"))
wanted, columns = status["points"], status["point_columns"]
assert len(wanted) == 2 and all(p["runs"] == 2 and p["P_N_n"] == 2 for p in wanted), wanted
assert all(sorted(p) == sorted(columns) for p in wanted), (columns, wanted)
api = json.load(urllib.request.urlopen(f"{os.environ['DEMBUF_HTTP']}/api/sweeps/{sweep}"))
folder = json.load(open(f"{work}/fetched_sweep/summary.json"))
for name, other in (("/api/sweeps", api), ("summary.json", folder)):
    assert other["point_columns"] == columns, (name, other["point_columns"])
    assert other["points"] == wanted, (name, other["points"], wanted)
with dembuf.connect() as daemon:
    python = daemon.sweep_points(sweep)
csv = dembuf.read_points(f"{work}/fetched_sweep")
for name, frame in (("Python", python), ("points.csv", csv)):
    assert list(frame.columns) == columns, (name, list(frame.columns))
    for row, point in zip(frame.to_dict("records"), wanted):
        for key in columns:
            a, b = row[key], point[key]
            if b is None:
                assert a is None or (isinstance(a, float) and math.isnan(a)), (name, key, a)
            else:
                assert math.isclose(a, b, rel_tol=1e-9), (name, key, a, b)
print("a sweep point: the same fields and numbers at every door")
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
