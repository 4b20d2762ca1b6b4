#!/usr/bin/env bash
# Bed pushes that cannot hold the daemon's places (docs/robustness.md), through the API as any
# client could (the Python package's stubs):
# - four users each dripping one byte of a push every 0.6 stream timeouts held every PushBed
#   place for good: the timeout counts silence only. Now a push slower than 64 KiB/s on average
#   once the timeout has passed is cut off, and a fifth user's push goes through.
# - a user's next push right after an answer was refused as "still open" (9 of 100): the place
#   was given back after the answer. Now before it: 100 pushes in a row all go through.
# - a user's pushes started back to back, each as the last one's upload ended, piled up in
#   the daemon's memory while they waited to be stored (1.4 GB of 64 MB pushes): the place was
#   given back at the last piece. Now it is held until the bed is stored, and the daemon's
#   peak memory grows by a few pushes at most.
# Usage: pushes_test.sh DEMBUF DEMBUFD
. "$(dirname "$0")/lib.sh" "$1" "$2"
python_dir=$(dirname "$dembuf")/../python
db=$work/dembuf.db
for name in u1 u2 u3 u4 u5; do "$dembufd" --db "$db" token-create "$name" > "$work/$name.token" 2> /dev/null; done
printf 'access = "tokens"\nstream_write_timeout_s = 2\nmax_bed_push_mb = 64\n' > "$work/dembufd.toml"
start_daemon "$db" "$work/dembufd.log" --config "$work/dembufd.toml"
/usr/bin/python3 - "$DEMBUF_SERVER" "$python_dir" "$work" "$daemon_pid" <<'PY' || fail "bed pushes"
import sys, threading, time
import grpc
sys.path.insert(0, sys.argv[2])
from dembuf.v1 import dembuf_pb2 as pb, dembuf_pb2_grpc as pb_grpc
server, _, work, daemon_pid = sys.argv[1:5]
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

# 3. Pushes of 64 MB back to back, each begun as the last one's upload ended.
def peak_mb():
    for line in open(f"/proc/{daemon_pid}/status"):
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
before = peak_mb()
size = 64 << 20
blob = (b"0 0 0.002 0.002\n" * (size // 16 + 1))[:size]
answers3, threads = [], []
for k in range(12):
    uploaded = threading.Event()
    def pieces(k=k, uploaded=uploaded):
        yield pb.BedPiece(kind="file", name=f"big{k}.txt", size=size, data=blob[:1 << 18])
        for at in range(1 << 18, size, 1 << 18):
            yield pb.BedPiece(data=blob[at:at + (1 << 18)])
        uploaded.set()
    def pusher(p=pieces(), uploaded=uploaded):
        answers3.append(push("u5", p, 120))
        if "bed pushes" in answers3[-1]:
            time.sleep(0.1)  # a refused push never reads its last piece: try again shortly
        uploaded.set()
    t = threading.Thread(target=pusher)
    t.start()
    threads.append(t)
    uploaded.wait(60)
for t in threads:
    t.join()
grown = peak_mb() - before
held = sum(1 for a in answers3 if "bed pushes" in a)
print(f"12 pushes of 64 MB back to back: {len(answers3) - held} taken, {held} refused while "
      f"one was being stored; the daemon's peak memory grew by {grown:.0f} MB")
assert all(a == "OK" or "bed pushes" in a for a in answers3), answers3
# One push at a time is stored, with its copies as it is checked (about 200 MB); given back at
# the last piece, the places let the next pushes pile up behind it (360 MB and more).
assert grown < 4 * 64, f"the daemon's peak memory grew by {grown:.0f} MB"
PY
echo "pushes test passed"
