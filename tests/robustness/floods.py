"""No work before a token: floods that reach dembufd's port, and a user's calls beside them.

Against a real daemon on loopback (tokens required). While each flood runs, alice (a user
with a token) asks for her job every 20 ms; every one of her calls must be answered, and the
daemon's memory must stay within a bound (docs/service.md has the figures this prints):
1. token-less: 3,000 unary calls at once without a token (they took the 80 threads of the
   pool before: users got "Server Threadpool Exhausted"). Each is refused UNAUTHENTICATED.
2. gzip: three 382 KB gzip requests on one connection, each inflating to 384 MB (one was
   inflated whole before the request size limit applied). Refused, none inflated.
3. one user's flood: bob sends 3,000 calls at once with his token. At most 64 of his wait;
   the rest are refused RESOURCE_EXHAUSTED, and alice's calls are answered in turn with his.
4. rapid reset (HTTP/2 HEADERS then RST_STREAM, CVE-2023-44487) from 4 connections for 8 s,
   through the front proxy of deploy/haproxy/ (--front): Debian's gRPC 1.51 does not hold
   against it alone; behind haproxy a reset stream never reaches it.
   --direct-reset runs it against the daemon itself to measure that (not in CI: it grew the
   daemon by gigabytes).
5. slow headers on the web pages (slowloris): 200 connections each sending a GET's headers a
   byte every 2 s for 6 s, through haproxy's web front: a page asked for meanwhile is answered.
   dembufd serves a connection on a thread until its request is whole, so 80 such took every
   thread of its web pages; --direct-slow measures that against the daemon itself.

Timings are figures, not assertions (a loaded machine must pass): the test asserts answers,
refusals and memory. Usage:
  floods.py DEMBUF DEMBUFD PYTHON_PACKAGE_DIR SOURCE_DIR [--direct-reset] [--direct-slow]
            [--json FILE]
Exits 0 when everything held, 1 with the reason otherwise. Loopback only; about a minute.
"""
import argparse
import asyncio
import json
import os
import re
import socket
import subprocess
import sys
import tempfile
import threading
import time
import zlib

RESET_SECONDS = 8
RESET_CONNECTIONS = 4
SLOW_SECONDS = 6
SLOW_CONNECTIONS = 200
# What a flood may add to the daemon's memory (it runs in a few tens of MB).
MEMORY_BOUND_MB = 200


def fail(why):
    sys.exit(f"FAIL: {why}")


def percentile(values, q):
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))] if ordered else float("nan")


def rss_mb(pid):
    with open(f"/proc/{pid}/status") as f:
        return int(re.search(r"VmRSS:\s+(\d+)", f.read()).group(1)) / 1024


# -- HTTP/2 by hand: the floods that a gRPC client library will not send ------------------------

def literal(name, value):
    """An HPACK header field, literal without indexing (the same bytes for every stream)."""
    n, v = name.encode(), value.encode()
    return b"\x00" + bytes([len(n)]) + n + bytes([len(v)]) + v


def headers_block(authority, method, extra=()):
    fields = [(":method", "POST"), (":scheme", "http"), (":path", "/dembuf.v1.Dembuf/" + method),
              (":authority", authority), ("content-type", "application/grpc"),
              ("te", "trailers"), *extra]
    return b"".join(literal(k, v) for k, v in fields)


def frame(kind, flags, stream, payload):
    return len(payload).to_bytes(3, "big") + bytes([kind, flags]) + stream.to_bytes(4, "big") + payload


PREFACE = b"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n" + frame(4, 0, 0, b"")  # and empty SETTINGS
SETTINGS_ACK = frame(4, 1, 0, b"")
HEADERS, RST_STREAM, END_HEADERS, CANCEL = 1, 3, 4, 8


def rapid_reset(address, seconds, connections):
    """HEADERS then RST_STREAM on new streams, as fast as the sockets take them; the number of
    streams opened and reset."""
    host, port = address.rsplit(":", 1)
    block = headers_block(address, "ServerInfo")
    sent = [0]
    stop = time.time() + seconds

    def batch(first, count):
        out = bytearray()
        for stream in range(first, first + 2 * count, 2):
            out += frame(HEADERS, END_HEADERS, stream, block)
            out += frame(RST_STREAM, 0, stream, CANCEL.to_bytes(4, "big"))
        return bytes(out)

    def one():
        sock = socket.create_connection((host, int(port)))
        sock.sendall(PREFACE + SETTINGS_ACK)
        threading.Thread(target=lambda: drain(sock), daemon=True).start()
        stream = 1
        try:
            while time.time() < stop and stream < 2**31 - 10000:
                sock.sendall(batch(stream, 2000))
                stream += 4000
                sent[0] += 2000
        except OSError:
            pass  # the server closed the connection: a way to hold, too
        sock.close()

    threads = [threading.Thread(target=one) for _ in range(connections)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    return sent[0]


def drain(sock):
    try:
        while sock.recv(1 << 16):
            pass
    except OSError:
        pass


def gzip_requests(address, inflated_mb, count):
    """`count` unary calls, one after the other on one connection, each a gzip message that
    inflates to `inflated_mb`: the grpc-status of each answer, and the compressed size."""
    import h2.config
    import h2.connection
    import h2.events
    host, port = address.rsplit(":", 1)
    compressor = zlib.compressobj(9, zlib.DEFLATED, 31)
    size, varint = inflated_mb << 20, bytearray()
    while True:
        varint.append((size & 0x7F) | (0x80 if size > 0x7F else 0))
        size >>= 7
        if not size:
            break
    body = compressor.compress(bytes([(15 << 3) | 2]) + bytes(varint))  # field 15, bytes
    zeros = b"\0" * (1 << 20)
    for _ in range(inflated_mb):
        body += compressor.compress(zeros)
    body += compressor.flush()
    message = b"\x01" + len(body).to_bytes(4, "big") + body
    sock = socket.create_connection((host, int(port)), timeout=30)
    conn = h2.connection.H2Connection(h2.config.H2Configuration(client_side=True,
                                                                header_encoding="utf-8"))
    conn.initiate_connection()
    sock.sendall(conn.data_to_send())
    statuses = []
    for stream in range(1, 2 * count, 2):
        conn.send_headers(stream, [(":method", "POST"), (":scheme", "http"),
                                   (":path", "/dembuf.v1.Dembuf/ServerInfo"),
                                   (":authority", address), ("content-type", "application/grpc"),
                                   ("te", "trailers"), ("grpc-encoding", "gzip")])
        sock.sendall(conn.data_to_send())
        answer, sent, ended = {}, 0, False
        while not ended:
            window = min(conn.local_flow_control_window(stream), conn.max_outbound_frame_size,
                         len(message) - sent) if sent < len(message) else 0
            if window > 0:
                conn.send_data(stream, message[sent:sent + window],
                               end_stream=sent + window == len(message))
                sent += window
                sock.sendall(conn.data_to_send())
                continue
            data = sock.recv(1 << 16)
            if not data:
                break
            for event in conn.receive_data(data):
                if getattr(event, "stream_id", None) != stream:
                    continue
                if isinstance(event, (h2.events.ResponseReceived, h2.events.TrailersReceived)):
                    answer.update(dict(event.headers))
                if isinstance(event, (h2.events.StreamEnded, h2.events.StreamReset)):
                    ended = True
            sock.sendall(conn.data_to_send())
        statuses.append(answer.get("grpc-status"))
    sock.close()
    return statuses, len(body)


# -- HTTP/1.1 slowly: the web pages ------------------------------------------------------------

def page_seconds(address, timeout=4.0):
    """Seconds a GET /login took at `address`, or None when it was not answered in time."""
    host, port = address.rsplit(":", 1)
    start = time.time()
    try:
        with socket.create_connection((host, int(port)), timeout=timeout) as sock:
            sock.settimeout(timeout)
            sock.sendall(f"GET /login HTTP/1.1\r\nHost: {address}\r\nConnection: close\r\n\r\n".encode())
            if not sock.recv(12).startswith(b"HTTP/1.1 200"):
                return None
        return time.time() - start
    except OSError:
        return None


def slow_headers(address, seconds, connections):
    """`connections` requests whose headers come a byte every 2 s, for `seconds`; a page asked
    for all the while. How many pages were answered, and how many were asked for."""
    host, port = address.rsplit(":", 1)
    slow = []
    for _ in range(connections):
        sock = socket.create_connection((host, int(port)), timeout=5)
        sock.sendall(f"GET /login HTTP/1.1\r\nHost: {address}\r\nX-Slow: ".encode())
        slow.append(sock)
    pages, end = [], time.time() + seconds
    next_byte = time.time()
    while time.time() < end:
        if time.time() >= next_byte:
            for sock in slow:
                try:
                    sock.send(b"a")
                except OSError:
                    pass  # dropped by the server: as it should be
            next_byte += 2
        pages.append(page_seconds(address))
        time.sleep(0.2)
    for sock in slow:
        sock.close()
    answered = [p for p in pages if p is not None]
    return {"pages_asked": len(pages), "pages_answered": len(answered),
            "page_p99_ms": round(1e3 * percentile(answered, 0.99), 1) if answered else None}


# -- the test ------------------------------------------------------------------------------------

class Daemon:
    def __init__(self, dembufd, work):
        self.db = os.path.join(work, "dembuf.db")
        self.tokens = {}
        for name in ["alice", "bob"]:
            self.tokens[name] = subprocess.run([dembufd, "--db", self.db, "token-create", name],
                                               check=True, capture_output=True,
                                               text=True).stdout.strip()
        self.log_path = os.path.join(work, "dembufd.log")
        self.log = open(self.log_path, "w")
        self.process = subprocess.Popen([dembufd, "--listen", "127.0.0.1:0", "--db", self.db,
                                         "--http", "127.0.0.1:0",
                                         "--workers", "1", "--threads-per-job", "1"],
                                        stdout=self.log, stderr=self.log)
        self.address = self.web_address = None
        for _ in range(100):
            log = open(self.log_path).read()
            match = re.search(r"listening on .* \(port (\d+)\)", log)
            web = re.search(r"web pages on http://(127\.0\.0\.1:\d+)/", log)
            if match and web:
                self.address = f"127.0.0.1:{match.group(1)}"
                self.web_address = web.group(1)
                return
            if self.process.poll() is not None:
                fail(f"dembufd exited: {open(self.log_path).read()[-500:]}")
            time.sleep(0.1)
        fail("dembufd did not start")

    def stop(self):
        self.process.terminate()
        try:
            self.process.wait(30)
        except subprocess.TimeoutExpired:
            self.process.kill()


class Alice:
    """A user asking for her job every 20 ms while a flood runs."""

    def __init__(self, address, token, job):
        self.stub = pb_grpc.DembufStub(grpc.insecure_channel(address))
        self.metadata = [("authorization", "Bearer " + token)]
        self.job = job
        self.latencies, self.errors = [], {}
        self.running = True
        self.thread = threading.Thread(target=self.run)
        self.thread.start()

    def run(self):
        while self.running:
            start = time.time()
            try:
                self.stub.GetJob(pb.GetJobRequest(id=self.job), metadata=self.metadata, timeout=30)
                self.latencies.append(time.time() - start)
            except grpc.RpcError as e:
                key = f"{e.code().name}: {(e.details() or '')[:60]}"
                self.errors[key] = self.errors.get(key, 0) + 1
            time.sleep(0.02)

    def finish(self):
        self.running = False
        self.thread.join()
        return {"calls": len(self.latencies) + sum(self.errors.values()),
                "answered": len(self.latencies), "errors": self.errors,
                "p50_ms": round(1e3 * percentile(self.latencies, 0.5), 1),
                "p99_ms": round(1e3 * percentile(self.latencies, 0.99), 1)}


async def unary_flood(address, count, token=None):
    """`count` ServerInfo calls at once; how they were answered, by status."""
    channel = grpc.aio.insecure_channel(address)
    stub = pb_grpc.DembufStub(channel)
    metadata = [("authorization", "Bearer " + token)] if token else None

    async def one():
        try:
            await stub.ServerInfo(pb.ServerInfoRequest(), metadata=metadata, timeout=60)
            return "OK"
        except grpc.aio.AioRpcError as e:
            return e.code().name

    answers = await asyncio.gather(*[one() for _ in range(count)])
    await channel.close()
    counts = {}
    for a in answers:
        counts[a] = counts.get(a, 0) + 1
    return counts


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("dembuf")
    parser.add_argument("dembufd")
    parser.add_argument("package")
    parser.add_argument("source")
    parser.add_argument("--direct-reset", action="store_true")
    parser.add_argument("--direct-slow", action="store_true")
    parser.add_argument("--json")
    opt = parser.parse_args()
    sys.path.insert(0, opt.package)
    global grpc, pb, pb_grpc
    import grpc
    import grpc.aio  # noqa: F401
    from dembuf.v1 import dembuf_pb2 as pb
    from dembuf.v1 import dembuf_pb2_grpc as pb_grpc

    work = tempfile.mkdtemp()
    daemon = Daemon(opt.dembufd, work)
    front = None
    figures = {}
    try:
        stub = pb_grpc.DembufStub(grpc.insecure_channel(daemon.address))
        alice_auth = [("authorization", "Bearer " + daemon.tokens["alice"])]
        job = stub.SubmitJob(pb.SubmitJobRequest(scene=pb.SceneSpec(set=["bed.thickness_m=0"])),
                             metadata=alice_auth, timeout=30).job.id

        def during(name, flood, address=daemon.address):
            before = rss_mb(daemon.process.pid)
            alice = Alice(address, daemon.tokens["alice"], job)
            time.sleep(0.3)
            result = flood()
            time.sleep(0.3)
            seen = alice.finish()
            seen["flood"] = result
            seen["daemon_rss_mb"] = {"before": round(before), "after": round(rss_mb(daemon.process.pid))}
            figures[name] = seen
            print(f"{name}: {json.dumps(seen)}", flush=True)
            if seen["errors"]:
                fail(f"{name}: alice's calls failed: {seen['errors']}")
            if seen["daemon_rss_mb"]["after"] - before > MEMORY_BOUND_MB:
                fail(f"{name}: the daemon grew from {before:.0f} to "
                     f"{seen['daemon_rss_mb']['after']} MB")
            return result

        answers = during("token-less unary calls", lambda: asyncio.run(unary_flood(daemon.address, 3000)))
        if answers != {"UNAUTHENTICATED": 3000}:
            fail(f"token-less calls: {answers}")

        statuses, _ = during("gzip requests", lambda: gzip_requests(daemon.address, 384, 3))
        # Each refused (UNIMPLEMENTED: "Compression algorithm 'gzip' is disabled", or, should
        # the header pass, a message that does not parse), none inflated: memory is checked.
        if None in statuses or "0" in statuses:
            fail(f"gzip requests were taken: grpc-status {statuses}")

        answers = during("one user's 3,000 calls",
                         lambda: asyncio.run(unary_flood(daemon.address, 3000, daemon.tokens["bob"])))
        if set(answers) - {"OK", "RESOURCE_EXHAUSTED"} or answers.get("OK", 0) < 64:
            fail(f"bob's calls: {answers}")

        # The front proxy of deploy/haproxy/, on a port of its own.
        front_port, web_front_port = free_port(), free_port()
        front_log = open(os.path.join(work, "haproxy.log"), "w")
        front = subprocess.Popen(["bash", os.path.join(opt.source, "deploy/haproxy/front.sh"),
                                  f"127.0.0.1:{front_port}", daemon.address,
                                  f"127.0.0.1:{web_front_port}", daemon.web_address],
                                 stdout=front_log, stderr=front_log)
        front_address = f"127.0.0.1:{front_port}"
        for _ in range(100):
            try:
                socket.create_connection(("127.0.0.1", front_port)).close()
                break
            except OSError:
                if front.poll() is not None:
                    fail("haproxy exited: " + open(os.path.join(work, "haproxy.log")).read()[-500:])
                time.sleep(0.1)
        pb_grpc.DembufStub(grpc.insecure_channel(front_address)).GetJob(
            pb.GetJobRequest(id=job), metadata=alice_auth, timeout=30)
        during("rapid reset through haproxy",
               lambda: rapid_reset(front_address, RESET_SECONDS, RESET_CONNECTIONS), front_address)
        if opt.direct_reset:
            try:
                during("rapid reset at the daemon itself",
                       lambda: rapid_reset(daemon.address, RESET_SECONDS, RESET_CONNECTIONS))
            except SystemExit as e:  # the measured limit, reported, not the test's verdict
                print(f"(direct: {e})")
        web_front = f"127.0.0.1:{web_front_port}"
        if page_seconds(web_front, 30) is None:
            fail("the web pages are not answered through haproxy")
        pages = during("slow headers at the web pages through haproxy",
                       lambda: slow_headers(web_front, SLOW_SECONDS, SLOW_CONNECTIONS), front_address)
        if pages["pages_answered"] != pages["pages_asked"]:
            fail(f"slow headers through haproxy: {pages}")
        if opt.direct_slow:  # the measured limit, reported, not the test's verdict
            during("slow headers at the daemon's web pages",
                   lambda: slow_headers(daemon.web_address, SLOW_SECONDS, SLOW_CONNECTIONS))
        if opt.json:
            with open(opt.json, "w") as f:
                json.dump(figures, f, indent=2)
        print("floods test passed")
    finally:
        if front:
            front.terminate()
        daemon.stop()


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


if __name__ == "__main__":
    main()
