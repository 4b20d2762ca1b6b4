#!/usr/bin/env bash
# One admission for every job (docs/robustness.md): the scene a worker will run passes the
# daemon's admission whatever request brought it, and no executor writes or reads a path that
# came from a request.
# - A sweep whose base sent a bed file and whose axis set bed.import to an absolute path (or
#   ../) was accepted, and the Slurm executor wrote the user's file to that path: the axes were
#   applied after SubmitJob's check. Now refused, and the executor writes only names it makes.
# - The same axis without a sent file told apart existing and missing files on the daemon's
#   disk ("does not read files on its disk" against "does not exist"), and hashed the file
#   once per run. Now one refusal for both, and the daemon never opens the path.
# - A scene file naming its bed file, submitted with the file, was refused unless the daemon's
#   own folder held a file of that name.
# - A sweep of too many axes naming an unsent bed file was refused for the file, after a
#   look-up; now for its axes, before it.
# Usage: admission_test.sh DEMBUF DEMBUFD
. "$(dirname "$0")/lib.sh" "$1" "$2"
python_dir=$(dirname "$dembuf")/../python
refusal="bed.import: the server reads no files of its own"

# A daemon on a fake cluster that runs nothing: the test looks at what it was given.
fake=$work/fake-slurm
mkdir -p "$fake/bin"
for command in sbatch squeue scontrol scancel; do
  ln -s "$(cd "$(dirname "$0")" && pwd)/fake_slurm/fake_slurm.sh" "$fake/bin/$command"
done
export FAKE_SLURM_DIR=$fake/state PATH=$fake/bin:$PATH
mkdir -m 0700 "$work/shared"
printf 'access = "local"\nexecutor = "slurm"\n[slurm]\nwork_dir = "%s"\ndembuf = "%s"\npoll_s = 0.2\n' \
  "$work/shared" "$dembuf" > "$work/slurm.toml"
start_daemon "$work/dembuf.db" "$work/dembufd.log" --config "$work/slurm.toml"

small_scene "$work/small.toml"
# A small bed file that the small scene accepts.
"$dembuf" prepare-bed "$work/small.toml" --bed-cache "$work/beds" > /dev/null 2>&1 || fail "prepare-bed"
"$dembuf" bed export "$work/small.toml" --bed-cache "$work/beds" --format text --out "$work/bed.txt" \
  > /dev/null || fail "bed export"

echo "secret" > "$work/existing"
# Through the API as any client could, with the sent file's hash in the base.
/usr/bin/python3 - "$DEMBUF_SERVER" "$python_dir" "$work" "$refusal" <<'PY' || fail "admission"
import sys
import grpc
sys.path.insert(0, sys.argv[2])
from dembuf.v1 import dembuf_pb2 as pb, dembuf_pb2_grpc as pb_grpc
server, _, work, refusal = sys.argv[1:5]
stub = pb_grpc.DembufStub(grpc.insecure_channel(server))
scene = open(f"{work}/small.toml").read()
data = open(f"{work}/bed.txt", "rb").read()
sent = stub.PushBed(iter([pb.BedPiece(kind="file", name="bed.txt", size=len(data), data=data)]),
                    timeout=30).hash

def refused(call, request, what):
    try:
        call(request, timeout=30)
    except grpc.RpcError as e:
        assert e.code() == grpc.StatusCode.INVALID_ARGUMENT, (what, e.code(), e.details())
        return e.details()
    raise AssertionError(f"{what}: accepted")

# A sweep axis naming a path the daemon may write, with and without a sent file.
for target in [f"{work}/victim", "../victim", f"{work}/existing", f"{work}/missing"]:
    for bed_file in [sent, ""]:
        base = pb.SceneSpec(scene_toml=scene, bed_file=bed_file)
        request = pb.SubmitSweepRequest(base=base, axes=[pb.SweepAxis(field="bed.import",
                                                                      values=[target])])
        why = refused(stub.SubmitSweep, request, f"axis {target} with file {bool(bed_file)}")
        assert why.startswith(refusal), why
        assert target not in why, f"the refusal repeats the path: {why}"
# One job naming a path: the same words whether the file exists or not.
words = {refused(stub.SubmitJob, pb.SubmitJobRequest(scene=pb.SceneSpec(
    scene_toml=scene, set=[f"bed.import={path}"])), path) for path in
    [f"{work}/existing", f"{work}/missing", "/etc/hostname"]}
assert len(words) == 1 and words.pop().startswith(refusal), words
# A sweep's shape is refused before the bed file it names is looked up: no axis, or more
# axes than a sweep may have.
unsent = pb.SceneSpec(scene_toml=scene, bed_file="0" * 64)
why = refused(stub.SubmitSweep, pb.SubmitSweepRequest(base=unsent), "a sweep without axes")
assert why.startswith("axes: a sweep needs at least one axis"), why
axes = [pb.SweepAxis(field="bed.seed", values=["1"]) for _ in range(17)]
why = refused(stub.SubmitSweep, pb.SubmitSweepRequest(base=unsent, axes=axes), "17 axes")
assert why.startswith("axes: 17 axes; at most 16"), why
# A scene file that names its bed file, sent with it: accepted (the daemon looks for nothing).
job = stub.SubmitJob(pb.SubmitJobRequest(scene=pb.SceneSpec(
    scene_toml=scene.replace("[bed]\n", '[bed]\nimport = "somewhere/bed.txt"\n'),
    bed_file=sent)), timeout=30)
PY
[ ! -e "$work/victim" ] && [ ! -e "$work/../victim" ] || fail "a user's file was written outside its job's folder"

# The job that was accepted: its scene and bed file sit in its own folder, under names the
# daemon made, and nothing of the request names a file.
for _ in $(seq 100); do
  [ -n "$(ls "$FAKE_SLURM_DIR/jobs" 2> /dev/null)" ] && break
  sleep 0.1
done
written=$(cd "$work/shared" && find . -type f | sort)
echo "$written" | grep -q "bed.txt" && fail "a file is named after the request: $written"
echo "$written" | grep -q "/bed-file$" || fail "the sent bed file was not written as bed-file: $written"
echo "admission test passed"
