#!/usr/bin/env bash
# A submission sent twice files its work once. A client retrying after a lost reply filed the
# job twice (there was no idempotency key). Now a request carries a client-chosen request id
# (the CLI and the Python package send one and retry with it while the daemon is unreachable):
# the same id from the same owner, sent again or twice at once, is answered with the job or
# sweep filed the first time.
# Usage: retries_test.sh DEMBUF DEMBUFD
. "$(dirname "$0")/lib.sh" "$1" "$2"

db=$work/dembuf.db
alice=$("$dembufd" --db "$db" token-create alice 2>/dev/null)
bob=$("$dembufd" --db "$db" token-create bob 2>/dev/null)
start_daemon "$db" "$work/dembufd.log" --access tokens --workers 1
PYTHONPATH="$(dirname "$dembuf")/../python" /usr/bin/python3 - "$DEMBUF_SERVER" "$alice" "$bob" <<'PY' ||
import sys, threading
import grpc
from dembuf.v1 import dembuf_pb2 as pb, dembuf_pb2_grpc as pb_grpc

server, alice, bob = sys.argv[1:]
stub = pb_grpc.DembufStub(grpc.insecure_channel(server))
def call(method, request, token):
    return method(request, metadata=[("authorization", "Bearer " + token)], timeout=30)
def job(request_id):
    return pb.SubmitJobRequest(scene=pb.SceneSpec(set=["bed.thickness_m=0", "time.end_s=0.001"]),
                               request_id=request_id)

# The same request twice: one job.
first = call(stub.SubmitJob, job("retry-1"), alice).job.id
again = call(stub.SubmitJob, job("retry-1"), alice).job.id
assert first == again, (first, again)
# Ten copies at once: one job.
ids, threads = [], []
for _ in range(10):
    t = threading.Thread(target=lambda: ids.append(call(stub.SubmitJob, job("retry-2"), alice).job.id))
    threads.append(t)
    t.start()
for t in threads:
    t.join()
assert len(set(ids)) == 1 and len(ids) == 10, ids
# Another owner's id is theirs; no id files every time.
assert call(stub.SubmitJob, job("retry-1"), bob).job.id not in (first, ids[0])
assert call(stub.SubmitJob, job(""), alice).job.id != call(stub.SubmitJob, job(""), alice).job.id
# A sweep: the same sweep and jobs.
sweep = pb.SubmitSweepRequest(base=pb.SceneSpec(set=["bed.thickness_m=0", "time.end_s=0.001"]),
                              axes=[pb.SweepAxis(field="projectile.speed_m_s", values=["1", "2"])],
                              request_id="sweep-1")
a, b = call(stub.SubmitSweep, sweep, alice), call(stub.SubmitSweep, sweep, alice)
assert a.sweep.id == b.sweep.id and list(a.job_ids) == list(b.job_ids), (a, b)
# An id used for a job is not a sweep's; a malformed id is refused naming the field.
for request, why in [(pb.SubmitSweepRequest(base=sweep.base, axes=sweep.axes, request_id="retry-1"),
                      "request_id: retry-1 was used for a job"),
                     (job("a b"), "request_id: must be 1 to 64")]:
    try:
        call(stub.SubmitSweep if isinstance(request, pb.SubmitSweepRequest) else stub.SubmitJob,
             request, alice)
        raise SystemExit(f"accepted: {request.request_id!r}")
    except grpc.RpcError as e:
        assert e.code() == grpc.StatusCode.INVALID_ARGUMENT and why in e.details(), e.details()
listed = call(stub.ListJobs, pb.ListJobsRequest(limit=100), alice).jobs
assert len(listed) == 2 + 2 + 2, [j.id for j in listed]  # retry-1, retry-2, two without, the sweep's two
PY
  fail "idempotent submissions"
# The CLI sends an id of its own with each submission.
"$dembuf" --token "$alice" submit --set bed.thickness_m=0 --set time.end_s=0.001 > /dev/null
[ "$(grep -c "submitted by alice" "$work/dembufd.log")" = 6 ] || fail "$(grep submitted "$work/dembufd.log")"
/usr/bin/python3 -c "
import sqlite3, sys
rows = sqlite3.connect(sys.argv[1]).execute('SELECT count(*) FROM submissions WHERE length(request_id) = 32').fetchone()[0]
sys.exit(rows != 1)" "$db" || fail "the CLI sent no request id"
stop_daemon
echo "retries test passed"
