#!/usr/bin/env bash
# Bed pushes that cannot hold the daemon's places (docs/robustness.md), through the API as any
# client could (the Python package's stubs):
# - four users each dripping one byte of a push every 0.6 stream timeouts held every PushBed
#   place for good: the timeout counts silence only. Now a push slower than 64 KiB/s on average
#   once the timeout has passed is cut off, and a fifth user's push goes through.
# - a user's next push right after an answer was refused as "still open" (9 of 100): the place
#   was given back after the answer. Now before it: 100 pushes in a row all go through.
# Usage: pushes_test.sh DEMBUF DEMBUFD
. "$(dirname "$0")/lib.sh" "$1" "$2"
python_dir=$(dirname "$dembuf")/../python
db=$work/dembuf.db
for name in u1 u2 u3 u4 u5; do "$dembufd" --db "$db" token-create "$name" > "$work/$name.token" 2> /dev/null; done
printf 'access = "tokens"\nstream_write_timeout_s = 2\n' > "$work/dembufd.toml"
start_daemon "$db" "$work/dembufd.log" --config "$work/dembufd.toml"
/usr/bin/python3 - "$DEMBUF_SERVER" "$python_dir" "$work" <<'PY' || fail "bed pushes"
import sys, threading, time
import grpc
sys.path.insert(0, sys.argv[2])
from dembuf.v1 import dembuf_pb2 as pb, dembuf_pb2_grpc as pb_grpc
server, _, work = sys.argv[1:4]
token = {u: open(f"{work}/{u}.token").read().strip() for u in ["u1", "u2", "u3", "u4", "u5"]}
stub = pb_grpc.DembufStub(grpc.insecure_channel(server))
data = b"0 0 0.002 0.002\n"

def push(user, pieces, timeout=60):
    try:
        stub.PushBed(pieces, metadata=[("authorization", "Bearer " + token[user])], timeout=timeout)
        return "OK"
    except grpc.RpcError as e:
        return f"{e.code().name}: {e.details()}"

# 1. Four drippers: a byte every 1.2 s of a 1 MB push.
def drip():
    yield pb.BedPiece(kind="file", name="drip.txt", size=1 << 20, data=b"0")
    for _ in range(200):
        time.sleep(1.2)
        yield pb.BedPiece(data=b"0")

answers = {}
drippers = [threading.Thread(target=lambda u=u: answers.__setitem__(u, push(u, drip(), 300)))
            for u in ["u1", "u2", "u3", "u4"]]
for t in drippers:
    t.start()
time.sleep(1.0)
fifth, started = None, time.time()
while time.time() - started < 60:
    fifth = push("u5", iter([pb.BedPiece(kind="file", name="bed.txt", size=len(data), data=data)]))
    if fifth == "OK":
        break
    assert "bed pushes" in fifth, fifth
    time.sleep(0.5)
for t in drippers:
    t.join()
print(f"a fifth user's push went through {time.time() - started:.1f} s after four drippers began;"
      f" the drippers were told: {sorted(set(answers.values()))}")
assert fifth == "OK", f"the drippers held every place: {fifth}"
assert all("slower than 64 KiB/s" in a for a in answers.values()), answers

# 2. A hundred pushes in a row.
refused = [a for a in (push("u5", iter([pb.BedPiece(kind="file", name=f"b{k}.txt",
                                                    size=len(data), data=data)]))
                       for k in range(100)) if a != "OK"]
assert not refused, f"{len(refused)} of 100 refused, e.g. {refused[0]}"
PY
echo "pushes test passed"
