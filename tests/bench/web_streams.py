#!/usr/bin/env python3
"""What open web pages cost a running job: the same impact run on a dembufd alone and with N
pages following it (each an event stream of /api/jobs/ID/events, as the job page opens), in
turns. Prints the samples per second the pages receive and the job's steps per second in both
cases, and writes them as JSON.

Usage: web_streams.py DEMBUF DEMBUFD [--pages 50] [--repeats 2] [--json FILE] [-- SCENE ARGS]
The scene arguments go to `dembuf submit` (default: the paper's E2 on a 2 cm bed cut from a
3 cm one, as the first run of the README, to 150 ms). Its beds are prepared by a first run, not
timed; the runs alone and with pages alternate, so that a drift of the machine hits both.
"""
import argparse
import json
import os
import re
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request
from pathlib import Path

# E2 on the first run's bed, stepped on to 150 ms (some 60,000 steps, 15,000 samples) so that a
# run lasts long enough to be timed.
DEFAULT_SCENE = ["--preset", "e2", "--set", "bed.thickness_m=0.02",
                 "--set", "bed.source_thickness_m=0.03", "--set", "time.end_s=0.15"]


class Daemon:
    """A dembufd on free loopback ports with a database of its own."""

    def __init__(self, dembufd, work):
        self.log_path = work / "dembufd.log"
        self.log = open(self.log_path, "w")
        self.process = subprocess.Popen(
            [dembufd, "--listen", "127.0.0.1:0", "--access", "local", "--db", str(work / "bench.db"),
             "--workers", "1",
             "--http", "127.0.0.1:0"], stdout=self.log, stderr=self.log)
        self.grpc = self.web = None
        for _ in range(100):
            text = self.log_path.read_text()
            grpc = re.search(r"listening on .* \(port (\d+)\)", text)
            web = re.search(r"web pages on (http://[^/]+)/", text)
            if grpc and web:
                self.grpc, self.web = f"127.0.0.1:{grpc.group(1)}", web.group(1)
                return
            time.sleep(0.1)
        raise SystemExit(f"dembufd did not start: {self.log_path.read_text()}")

    def cpu_seconds(self):
        """The daemon's CPU time so far (user and system, all its threads)."""
        fields = Path(f"/proc/{self.process.pid}/stat").read_text().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")

    def stop(self):
        self.process.terminate()
        self.process.wait(timeout=60)


def api(daemon, path):
    with urllib.request.urlopen(daemon.web + path, timeout=30) as response:
        return json.load(response)


def submit(dembuf, daemon, scene):
    out = subprocess.run([dembuf, "--server", daemon.grpc, "submit", *scene], check=True,
                         capture_output=True, text=True)
    return int(out.stdout.strip().splitlines()[-1])


def wait_done(daemon, job):
    while True:
        details = api(daemon, f"/api/jobs/{job}")
        if details["state"] in ("done", "failed", "cancelled"):
            if details["state"] != "done":
                raise SystemExit(f"job {job} {details['state']}: {details['error']}")
            return details["summary"]
        time.sleep(0.5)


class Page(threading.Thread):
    """One open job page: reads the event stream, and counts samples by the events' ids."""

    def __init__(self, daemon, job):
        super().__init__(daemon=True)
        host, port = daemon.web.removeprefix("http://").split(":")
        self.address, self.job = (host, int(port)), job
        self.samples = 0
        self.first_at = self.last_at = None
        self.ended = False

    def run(self):
        with socket.create_connection(self.address, timeout=600) as s:
            s.sendall(f"GET /api/jobs/{self.job}/events HTTP/1.1\r\nHost: bench\r\n"
                      "Accept: text/event-stream\r\n\r\n".encode())
            tail = b""
            while not self.ended:
                data = s.recv(1 << 16)
                if not data:
                    break
                text = tail + data
                ids = re.findall(rb"\nid: (\d+)\n", text)
                if ids:
                    now = time.monotonic()
                    self.first_at = self.first_at or now
                    self.last_at = now
                    self.samples = int(ids[-1])
                self.ended = b"event: end\n" in text
                tail = text[-64:]


def run(dembuf, daemon, scene, pages):
    cpu_before = daemon.cpu_seconds()
    job = submit(dembuf, daemon, scene)
    readers = [Page(daemon, job) for _ in range(pages)]
    for reader in readers:
        reader.start()
    summary = wait_done(daemon, job)
    for reader in readers:
        reader.join(timeout=60)
    result = {"job": job, "steps": summary["steps"], "wall_time_s": summary["wall_time_s"],
              "steps_per_s": summary["steps"] / summary["wall_time_s"],
              "daemon_cpu_s": daemon.cpu_seconds() - cpu_before}
    if pages:
        received = [r.samples for r in readers]
        span = max(r.last_at for r in readers) - min(r.first_at for r in readers)
        result.update({
            "pages": pages,
            "samples_per_page": statistics.mean(received),
            "pages_with_every_sample": sum(r.ended for r in readers),
            "samples_per_s_delivered": sum(received) / span,
            "stream_span_s": span,
        })
    return result


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dembuf")
    parser.add_argument("dembufd")
    parser.add_argument("--pages", type=int, default=50)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--json", type=Path)
    argv = sys.argv[1:]
    split = argv.index("--") if "--" in argv else len(argv)
    args = parser.parse_args(argv[:split])
    scene = argv[split + 1:] or DEFAULT_SCENE
    with tempfile.TemporaryDirectory() as folder:
        daemon = Daemon(args.dembufd, Path(folder))
        try:
            print("preparing the beds (a first run, not timed) ...", flush=True)
            wait_done(daemon, submit(args.dembuf, daemon, scene))
            alone, watched = [], []
            for repeat in range(args.repeats):
                for pages, results in ((0, alone), (args.pages, watched)):
                    r = run(args.dembuf, daemon, scene, pages)
                    results.append(r)
                    print(f"  run {repeat + 1}, {pages:3d} pages: {r['steps']} steps in "
                          f"{r['wall_time_s']:.1f} s, {r['steps_per_s']:.0f} steps/s"
                          + (f", {r['samples_per_s_delivered']:.0f} samples/s delivered"
                             f" ({r['pages_with_every_sample']} of {pages} pages got them all)"
                             if pages else ""), flush=True)
        finally:
            daemon.stop()
    alone_rate = statistics.mean(r["steps_per_s"] for r in alone)
    watched_rate = statistics.mean(r["steps_per_s"] for r in watched)
    # Each run with pages against the run alone just before it: the machine drifts less
    # between neighbours than over the whole bench.
    pair_slowdowns = [1 - w["steps_per_s"] / a["steps_per_s"] for a, w in zip(alone, watched)]
    # The daemon's CPU time for the job with pages beyond the job alone: what serving the pages
    # cost, whatever else the machine was doing.
    cpu_alone = statistics.mean(r["daemon_cpu_s"] for r in alone)
    cpu_watched = statistics.mean(r["daemon_cpu_s"] for r in watched)
    report = {
        "scene": scene,
        "pages": args.pages,
        "repeats": args.repeats,
        "steps_per_s_alone": alone_rate,
        "steps_per_s_with_pages": watched_rate,
        "slowdown": 1 - watched_rate / alone_rate,
        "slowdown_median_of_pairs": statistics.median(pair_slowdowns),
        "daemon_cpu_s_alone": cpu_alone,
        "daemon_cpu_s_with_pages": cpu_watched,
        "cpu_overhead": cpu_watched / cpu_alone - 1,
        "samples_per_s_delivered": statistics.mean(r["samples_per_s_delivered"] for r in watched),
        "samples_per_s_per_page": statistics.mean(r["samples_per_s_delivered"] for r in watched) / args.pages,
        "every_page_got_every_sample": all(r["pages_with_every_sample"] == args.pages for r in watched),
        "runs": {"alone": alone, "with_pages": watched},
    }
    median = report["slowdown_median_of_pairs"]
    change = f"{100 * median:.1f}% slower" if median >= 0 else f"{-100 * median:.1f}% faster"
    print(f"\n{args.pages} open pages: {report['samples_per_s_delivered']:.0f} samples/s delivered "
          f"({report['samples_per_s_per_page']:.0f} per page)\n"
          f"the job stepped {change} than alone (median of {len(pair_slowdowns)} pairs; means "
          f"{watched_rate:.0f} against {alone_rate:.0f} steps/s; target: at most 5% slower)\n"
          f"the daemon's CPU time per run: {cpu_watched:.1f} s with the pages, {cpu_alone:.1f} s "
          f"alone ({100 * report['cpu_overhead']:+.1f}%)")
    if args.json:
        args.json.write_text(json.dumps(report, indent=1) + "\n")
        print(f"wrote {args.json}")
    return 0 if report["every_page_got_every_sample"] else 1


if __name__ == "__main__":
    sys.exit(main())
