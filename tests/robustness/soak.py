#!/usr/bin/env python3
"""Soak test of dembufd (outside CI; docs/robustness.md has its last result).

Sends N random requests, valid and invalid, to one daemon through the real client, and kills
the daemon with SIGKILL at random moments, restarting it each time on the same database.
Every job seen done is fetched at once and its files' SHA-256 noted. At the end, when the
queue is empty: the daemon must be up, every refusal must have said what was wrong (exit 2
naming a field or limit, or exit 1 for a full queue), every job must have ended, and every
result fetched during the run must be byte-identical when fetched again (plate_force.csv,
summary.json); the database must pass SQLite's integrity check.

Usage: soak.py DEMBUF DEMBUFD [--requests 1000] [--kill-every 60] [--seed 1] [--keep DIR]
"""

import argparse
import hashlib
import json
import os
import random
import re
import shutil
import signal
import sqlite3
import subprocess
import sys
import tempfile
import time


def sha(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


class Daemon:
    def __init__(self, binary, db, log):
        self.binary, self.db, self.log = binary, db, log
        self.process, self.address, self.kills, self.starts = None, None, 0, 0

    def start(self):
        log = open(self.log, "a")
        before = os.path.getsize(self.log)
        self.process = subprocess.Popen(
            [self.binary, "--listen", "127.0.0.1:0", "--access", "local", "--db", self.db,
             "--workers", "2",
             "--queue-limit", "400"], stdout=log, stderr=log)
        deadline = time.time() + 30
        while time.time() < deadline:
            with open(self.log) as f:
                f.seek(before)
                m = re.search(r"listening on .* \(port (\d+)\)", f.read())
            if m:
                self.address = "127.0.0.1:" + m.group(1)
                self.starts += 1
                return
            if self.process.poll() is not None:
                # A job that kills the daemon at once is not this test's subject: say so.
                sys.exit("dembufd exited at start: see " + self.log)
            time.sleep(0.05)
        sys.exit("dembufd did not start")

    def kill(self):
        self.process.send_signal(signal.SIGKILL)
        self.process.wait()
        self.kills += 1

    def stop(self):
        self.process.send_signal(signal.SIGTERM)
        self.process.wait(timeout=60)


def client(dembuf, address, *args, timeout=120):
    env = dict(os.environ, DEMBUF_SERVER=address, OMP_WAIT_POLICY="passive")
    try:
        r = subprocess.run([dembuf, *args], env=env, capture_output=True, text=True,
                           timeout=timeout)
        return r.returncode, r.stdout, r.stderr
    except subprocess.TimeoutExpired:
        return 124, "", "timed out"


SMALL_BED = ["--set", "cylinder.radius_m=0.02", "--set", "bed.source_thickness_m=0.015",
             "--set", "projectile.diameter_m=0.012", "--set", "projectile.mass_kg=0.01",
             "--set", "projectile.height_m=0.02", "--set", "cylinder.height_m=1"]


def valid_request(rng):
    """A request the daemon must accept: bare-plate impacts and small beds (three seeds)."""
    if rng.random() < 0.7:
        args = ["submit", "--set", f"projectile.speed_m_s={rng.uniform(0, 8):.4g}",
                "--set", f"projectile.mass_kg={rng.uniform(0.05, 0.5):.4g}",
                "--set", f"projectile.height_m={rng.uniform(0.03, 2):.4g}",
                "--set", f"time.output_interval_s={rng.choice(['1e-6', '1e-5', '1e-4'])}"]
        if rng.random() < 0.2:
            args += ["--set", f"time.end_s={rng.uniform(0.05, 0.6):.3g}"]
    else:
        args = ["submit", *SMALL_BED, "--set", f"bed.seed={rng.randint(1, 3)}",
                "--set", f"bed.thickness_m={rng.choice(['0.008', '0.01'])}",
                "--set", f"projectile.speed_m_s={rng.uniform(0.5, 3):.3g}"]
    if rng.random() < 0.1:
        args[0:1] = ["sweep", "--vary", "projectile.speed_m_s=1,2,3"]
    return args


def invalid_request(rng, work):
    """A request the daemon must refuse, naming what is wrong; and the word it must say."""
    cases = [
        (["--set", "projectile.mass_kg=-1"], "projectile.mass_kg"),
        (["--set", "material.restitution=nan"], "material.restitution"),
        (["--set", "bed.thickness_m=1e300"], "bed.thickness_m"),
        (["--set", "no.such_field=1"], "no.such_field"),
        (["--set", "gravity_m_s2=0", "--set", "projectile.speed_m_s=1e-300"],
         "projectile.speed_m_s"),
        (["--set", "bed.thickness_m=0.02", "--set", "beads.diameter_min_m=1e-6",
          "--set", "beads.diameter_max_m=1e-6"], "beads.diameter_min_m"),
        (["--set", "time.end_s=1000", "--set", "time.alpha=0.01"], "time.end_s"),
        (["--set", "bed.import=/etc/passwd"], "bed.import"),
        (["--set", "output.snapshot_at_peak=true"], "output.snapshot_at_peak"),
        (["--set", "material.shear_stiffness=" + "x" * rng.randint(5000, 9000)],
         "material.shear_stiffness"),
        (["--preset", "e" + str(rng.randint(6, 99))], "preset"),
        (["--accuracy", "sloppy"], "accuracy"),
    ]
    if rng.random() < 0.2:
        path = os.path.join(work, f"deep{rng.randint(0, 10**9)}.toml")
        depth = rng.randint(9, 20000)
        with open(path, "w") as f:
            f.write("[output]\nsnapshot_times_s = " + "[" * depth + "]" * depth + "\n")
        return ["submit", path], "nested more than 8 deep"
    if rng.random() < 0.1:
        return (["sweep", "--vary", "projectile.speed_m_s=1,2", "--vary",
                 "projectile.speed_m_s=3,4"], "varied twice")
    args, word = rng.choice(cases)
    return ["submit", *args], word


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("dembuf")
    parser.add_argument("dembufd")
    parser.add_argument("--requests", type=int, default=1000)
    parser.add_argument("--kill-every", type=float, default=60,
                        help="mean number of requests between kills")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--keep", help="keep the work folder here")
    opt = parser.parse_args()
    rng = random.Random(opt.seed)
    work = opt.keep or tempfile.mkdtemp(prefix="dembuf-soak-")
    os.makedirs(work, exist_ok=True)
    daemon = Daemon(opt.dembufd, os.path.join(work, "soak.db"), os.path.join(work, "dembufd.log"))
    daemon.start()
    started = time.time()
    counts = {"accepted": 0, "refused": 0, "queue full": 0, "bad refusals": 0}
    problems = []
    fetched = {}  # job id -> (sha of plate_force.csv, sha of summary.json)

    def fetch(job):
        out = os.path.join(work, "fetch", f"{job}-{time.time_ns()}")
        code, _, err = client(opt.dembuf, daemon.address, "fetch", str(job), "--out", out,
                              "--no-plots")
        if code not in (0, 3):
            return None, err
        digest = (sha(os.path.join(out, "plate_force.csv")),
                  sha(os.path.join(out, "summary.json")) if os.path.exists(
                      os.path.join(out, "summary.json")) else "")
        shutil.rmtree(out)
        return digest, ""

    def collect():
        """Fetches the jobs newly done; their checksums are the reference."""
        code, out, _ = client(opt.dembuf, daemon.address, "list", "--state", "done",
                              "--limit", "100000")
        if code != 0:
            return
        for line in out.splitlines()[1:]:
            job = int(line.split()[0])
            if job not in fetched:
                digest, err = fetch(job)
                if digest:
                    fetched[job] = digest

    for k in range(opt.requests):
        if rng.random() < 0.75:
            args, word = valid_request(rng), None
        else:
            args, word = invalid_request(rng, work)
        code, out, err = client(opt.dembuf, daemon.address, *args)
        if word is None:
            if code == 0:
                counts["accepted"] += 1
            elif code == 1 and "server is full" in err:
                counts["queue full"] += 1
            elif code == 1 and "cannot reach" in err:
                problems.append(f"request {k}: the daemon was not reachable: {err.strip()}")
            else:
                problems.append(f"request {k} {args}: a valid request refused ({code}): {err}")
        else:
            if code == 2 and word in err:
                counts["refused"] += 1
            else:
                counts["bad refusals"] += 1
                problems.append(f"request {k}: expected a refusal naming {word!r}, got "
                                f"{code}: {err.strip()[:300]}")
        if k % 20 == 0:
            collect()
        if rng.random() < 1.0 / opt.kill_every:
            daemon.kill()
            daemon.start()
        print(f"\r{k + 1}/{opt.requests} requests, {daemon.kills} kills, "
              f"{len(fetched)} results fetched", end="", file=sys.stderr, flush=True)

    # Drain the queue, collecting results as they come.
    deadline = time.time() + 3600
    while time.time() < deadline:
        collect()
        busy = 0
        for state in ("queued", "preparing_bed", "running"):
            code, out, _ = client(opt.dembuf, daemon.address, "list", "--state", state,
                                  "--limit", "100000")
            busy += len(out.splitlines()[1:]) if code == 0 else 1
        if busy == 0:
            break
        time.sleep(2)
    collect()
    print(file=sys.stderr)

    # The checks.
    code, _, err = client(opt.dembuf, daemon.address, "server-info")
    if code != 0:
        problems.append("the daemon is not up at the end: " + err)
    states = {}
    code, out, _ = client(opt.dembuf, daemon.address, "list", "--limit", "100000")
    for line in out.splitlines()[1:]:
        state = line.split()[1]
        states[state] = states.get(state, 0) + 1
    for state in ("queued", "preparing_bed", "running"):
        if states.get(state):
            problems.append(f"{states[state]} jobs still {state}")
    changed = 0
    for job, digest in sorted(fetched.items()):
        again, err = fetch(job)
        if again != digest:
            changed += 1
            problems.append(f"job {job}: the result changed or cannot be fetched: {err}")
    daemon.stop()
    integrity = sqlite3.connect(daemon.db).execute("PRAGMA integrity_check").fetchone()[0]
    if integrity != "ok":
        problems.append("integrity check: " + integrity)

    report = {
        "requests": opt.requests, "seed": opt.seed, "kills": daemon.kills,
        "minutes": round((time.time() - started) / 60, 1), **counts,
        "jobs by state": states, "results checked": len(fetched), "results changed": changed,
        "integrity check": integrity, "problems": problems,
    }
    print(json.dumps(report, indent=2))
    if not opt.keep:
        shutil.rmtree(work, ignore_errors=True)
    sys.exit(1 if problems else 0)


if __name__ == "__main__":
    main()
