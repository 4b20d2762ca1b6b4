#!/usr/bin/env bash
# Beds sent to the daemon. A bed prepared on this machine and pushed (dembuf bed push) is used
# by a job without preparing it again, and the job's series is a local run's on the same bed;
# pushing it again changes nothing. A bed the daemon cannot vouch for is refused, naming why:
# damaged bytes, a bed of another scene. A bed file named by bed.import goes with the job: the
# job imports it as a local run does (same bed hash), under the file's plain name; a bad file
# is refused at submission, naming its line; a path alone names nothing on the daemon's disk.
# Usage: beds_test.sh DEMBUF DEMBUFD PYTHON_PACKAGE_DIR
. "$(dirname "$0")/lib.sh" "$1" "$2"
python_dir=$3
small_scene "$work/small.toml"
start_daemon "$work/dembuf.db" "$work/dembufd.log" --workers 1
scene=("$work/small.toml" --set bed.seed=7)
beds=$work/beds

# --- a pushed bed --------------------------------------------------------------------------
"$dembuf" prepare-bed "${scene[@]}" --bed-cache "$beds" > "$work/prepared" 2>&1 ||
  fail "prepare-bed: $(cat "$work/prepared")"
"$dembuf" bed push "${scene[@]}" --bed-cache "$beds" > "$work/push" || fail "push: $(cat "$work/push")"
grep -q "^source bed [0-9a-f]* (.* beads): pushed$" "$work/push" || fail "push: $(cat "$work/push")"
grep -q "^cut bed [0-9a-f]* (.* beads): pushed$" "$work/push" || fail "push: $(cat "$work/push")"
"$dembuf" beds push "${scene[@]}" --bed-cache "$beds" > "$work/again" || fail "second push"
[ "$(grep -c "the server had it" "$work/again")" = 2 ] || fail "second push: $(cat "$work/again")"

job=$("$dembuf" submit "${scene[@]}")
wait_state "$job" "done failed" 120
[ "$(job_state "$job")" = done ] || fail "job $job on the pushed bed: $("$dembuf" status "$job")"
"$dembuf" status "$job" --json > "$work/job.json"
python3 - "$work/job.json" "$work/prepared" <<'PY' || fail "the job prepared its bed again"
import json, re, sys
job = json.load(open(sys.argv[1]))
cut = re.search(r"cut bed ([0-9a-f]+)", open(sys.argv[2]).read()).group(1)
assert job["beds_prepared"] == [], job["beds_prepared"]
assert job["bed_hash"] == cut, (job["bed_hash"], cut)
PY
"$dembuf" fetch "$job" --out "$work/fetched" --no-plots > /dev/null
"$dembuf" run "${scene[@]}" --bed-cache "$beds" --no-plots --out "$work/local" > /dev/null 2>&1
cmp "$work/local/plate_force.csv" "$work/fetched/plate_force.csv" ||
  fail "the job on the pushed bed differs from a local run on it"

# --- beds the daemon refuses: asked by hand, as a client that skips its own checks would ----
cut=$(sed -n 's/^cut bed \([0-9a-f]*\).*/\1/p' "$work/push")
/usr/bin/python3 - "$DEMBUF_SERVER" "$beds/$cut.bed" "$work/small.toml" "$1" "$python_dir" <<'PY' ||
import subprocess, sys
import grpc
sys.path.insert(0, sys.argv[5])
from dembuf.v1 import dembuf_pb2 as pb, dembuf_pb2_grpc as pb_grpc

server, bed_path, scene_path, dembuf = sys.argv[1:5]
stub = pb_grpc.DembufStub(grpc.insecure_channel(server))
def scene(seed):
    return subprocess.run([dembuf, "scene", scene_path, "--set", f"bed.seed={seed}", "--print"],
                          check=True, capture_output=True, text=True).stdout
def push(data, scene_toml, kind="prepared"):
    pieces = [pb.BedPiece(kind=kind, size=len(data), scene_toml=scene_toml, data=data[:1000]),
              pb.BedPiece(data=data[1000:])]
    try:
        stub.PushBed(iter(pieces), timeout=30)
    except grpc.RpcError as e:
        return e.code(), e.details()
    return grpc.StatusCode.OK, ""
bed = open(bed_path, "rb").read()
code, why = push(bed, scene(8))  # another seed: another scene's bed
assert code == grpc.StatusCode.INVALID_ARGUMENT and "none of the scene's beds" in why, (code, why)
damaged = bytearray(bed)
damaged[-100] ^= 1
code, why = push(bytes(damaged), scene(7))
assert code == grpc.StatusCode.INVALID_ARGUMENT and why.startswith("data:"), (code, why)
code, why = push(bed, scene(7), kind="bed")
assert code == grpc.StatusCode.INVALID_ARGUMENT and why.startswith("kind:"), (code, why)
# More bytes than the first piece said: refused before they are kept.
pieces = [pb.BedPiece(kind="file", name="a.txt", size=5, data=b"0 0 0"), pb.BedPiece(data=b"1")]
try:
    stub.PushBed(iter(pieces), timeout=30)
    raise AssertionError("more bytes than stated were taken")
except grpc.RpcError as e:
    assert e.code() == grpc.StatusCode.INVALID_ARGUMENT and "size:" in e.details(), e.details()
for name in ["../a.txt", ".hidden", "a b.txt", ""]:
    pieces = [pb.BedPiece(kind="file", name=name, size=5, data=b"0 0 0")]
    try:
        stub.PushBed(iter(pieces), timeout=30)
        raise AssertionError(f"the name {name!r} was taken")
    except grpc.RpcError as e:
        assert e.code() == grpc.StatusCode.INVALID_ARGUMENT and e.details().startswith("name:"), e.details()
# A file named with no bytes sent: the daemon does not look on its own disk.
try:
    stub.SubmitJob(pb.SubmitJobRequest(scene=pb.SceneSpec(set=["bed.import=/etc/hostname"])),
                   timeout=30)
    raise AssertionError("a path on the daemon's disk was taken")
except grpc.RpcError as e:
    assert "the server reads no files of its own" in e.details(), e.details()
# Another user's (or no) file by its hash: none sent by this caller.
try:
    stub.SubmitJob(pb.SubmitJobRequest(scene=pb.SceneSpec(bed_file="0" * 64)), timeout=30)
    raise AssertionError("a bed file never sent was taken")
except grpc.RpcError as e:
    assert e.details().startswith("bed_file:"), e.details()
PY
  fail "the daemon took a bed it cannot vouch for"

# --- a bed file sent with the job ----------------------------------------------------------
"$dembuf" bed export "${scene[@]}" --bed-cache "$beds" --format lammps --out "$work/my bed.data" \
  > /dev/null
"$dembuf" prepare-bed "$work/small.toml" --set "bed.import=$work/my bed.data" \
  --bed-cache "$work/local-import" > "$work/imported" 2>&1 || fail "local import"
import_hash=$(sed -n 's/^import bed \([0-9a-f]*\).*/\1/p' "$work/imported")
job=$("$dembuf" submit "$work/small.toml" --set "bed.import=$work/my bed.data" 2> "$work/sent")
grep -q "sent .*my bed.data" "$work/sent" || fail "the bed file was not sent: $(cat "$work/sent")"
wait_state "$job" "done failed" 120
[ "$(job_state "$job")" = done ] || fail "job $job on a sent bed file: $("$dembuf" status "$job")"
"$dembuf" status "$job" --json > "$work/job.json"
python3 - "$work/job.json" "$import_hash" <<'PY' || fail "the sent bed file's job"
import json, sys
job = json.load(open(sys.argv[1]))
assert job["bed_hash"] == sys.argv[2], (job["bed_hash"], sys.argv[2])
assert 'import = "my_bed.data"' in job["scene_toml"], "the scene names the file's plain name"
PY
# A sweep on the same file sends it again (the daemon keeps one copy) and runs.
sweep=$("$dembuf" sweep "$work/small.toml" --set "bed.import=$work/my bed.data" \
  --vary projectile.speed_m_s=1,2 2> /dev/null)
"$dembuf" list --sweep "$sweep" > "$work/list"
[ "$(grep -c "queued\|running\|done\|preparing" "$work/list")" = 2 ] || fail "sweep: $(cat "$work/list")"
# A bead outside the cylinder: refused when submitted, naming the field and the line.
awk 'NR == 20 { $3 = 0.5 } { print }' "$work/my bed.data" > "$work/bad.data"
code=0
"$dembuf" submit "$work/small.toml" --set "bed.import=$work/bad.data" 2> "$work/err" || code=$?
[ "$code" = 2 ] || fail "a bad bed file: exit $code"
grep -q "bed.import: bad.data:20: radius 0.25 m" "$work/err" || fail "a bad bed file: $(cat "$work/err")"
echo "PASS"
