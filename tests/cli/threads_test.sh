#!/usr/bin/env bash
# Threads by the CPUs at hand: a run asked for 16 threads (OMP_NUM_THREADS) under
# `taskset -c 0` runs on one, and without it on no more than the CPUs this process may use
# nor than its beads can feed (a thousand a thread); the results are the same bits. A sweep's
# --dry-run plan runs no more at once than those CPUs.
# Usage: threads_test.sh DEMBUF_BINARY
set -eu
dembuf=$1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
command -v taskset > /dev/null || { echo "taskset not installed: skipped"; exit 0; }

# A bed of about 3,000 beads: enough for three threads by the bead rule.
small=(--preset e2 --accuracy draft --set bed.thickness_m=0.01 --set bed.source_thickness_m=0.015)
OMP_NUM_THREADS=16 taskset -c 0 "$dembuf" run "${small[@]}" --bed-cache "$work/beds" --no-plots \
  --out "$work/one_cpu" > "$work/one.log" 2>&1 || { cat "$work/one.log"; fail "run on one CPU"; }
OMP_NUM_THREADS=16 "$dembuf" run "${small[@]}" --bed-cache "$work/beds" --no-plots \
  --out "$work/all_cpus" > "$work/all.log" 2>&1 || { cat "$work/all.log"; fail "run"; }
python3 - "$work/one_cpu/summary.json" "$work/all_cpus/summary.json" <<'PY' ||
import json, os, sys
one, every = (json.load(open(f)) for f in sys.argv[1:3])
cpus = len(os.sched_getaffinity(0))  # (nproc would follow OMP_NUM_THREADS)
assert one["provenance"]["threads"] == 1, f'taskset -c 0 ran on {one["provenance"]["threads"]} threads'
beads = every["beads"]
allowed = max(1, min(cpus, beads // 1000))
assert every["provenance"]["threads"] == allowed, \
    f'{beads} beads on {cpus} CPUs ran on {every["provenance"]["threads"]} threads, not {allowed}'
print(f'16 threads asked: 1 run under taskset -c 0, {allowed} for {beads} beads on {cpus} CPUs')
PY
  fail "the thread counts"
cmp "$work/one_cpu/plate_force.csv" "$work/all_cpus/plate_force.csv" ||
  fail "the series differ between the thread counts"
# The sweep's plan: no more runs at once than CPUs, each seed's source bed once, the one the
# runs above prepared found in the cache.
cpus=$(python3 -c 'import os; print(len(os.sched_getaffinity(0)))')
at_once=$((cpus < 8 ? cpus : 8))
"$dembuf" sweep "${small[@]}" --vary bed.thickness_m=0.0099,0.01 --seeds 2 --jobs 8 --local \
  --bed-cache "$work/beds" --dry-run > "$work/plan.txt" 2>&1 || { cat "$work/plan.txt"; fail "dry run"; }
grep -q "^plan: 4 runs, $at_once at once (--jobs 8, $cpus usable CPUs)" "$work/plan.txt" ||
  { cat "$work/plan.txt"; fail "the plan does not say $at_once runs at once"; }
[ "$(grep -c '^  source bed .*: in the cache; 2 runs' "$work/plan.txt")" = 1 ] &&
  [ "$(grep -c '^  source bed .*: prepared by .*; 2 runs' "$work/plan.txt")" = 1 ] ||
  { cat "$work/plan.txt"; fail "the plan's source beds"; }
# The plan for a bigger machine: each seed's source bed on the threads its beds feed.
"$dembuf" sweep "${small[@]}" --vary bed.thickness_m=0.0099,0.01 --seeds 2 --local --no-bed-cache \
  --dry-run --plan-cpus 16 > "$work/plan16.txt" 2>&1 || { cat "$work/plan16.txt"; fail "dry run, 16 CPUs"; }
grep -q "^plan: 4 runs, 16 at once (--jobs 16, 16 usable CPUs)" "$work/plan16.txt" &&
  grep -q "^predicted wall time: about .* on 16 usable CPUs" "$work/plan16.txt" &&
  [ "$(grep -c '^  source bed .*: prepared by .* on [0-9]* threads\?, while' "$work/plan16.txt")" = 2 ] ||
  { cat "$work/plan16.txt"; fail "the plan for 16 CPUs"; }
if "$dembuf" sweep "${small[@]}" --vary bed.thickness_m=0.01 --local --plan-cpus 16 \
  > "$work/refused.txt" 2>&1 || [ $? != 2 ]; then
  cat "$work/refused.txt"; fail "--plan-cpus without --dry-run was not refused with exit 2"
fi
grep -q -- "--plan-cpus.*add --dry-run" "$work/refused.txt" || fail "$(cat "$work/refused.txt")"
# With a server configured, a dry run still plans here and submits nothing (it went to the
# server, which ran the sweep).
DEMBUF_SERVER=127.0.0.1:1 "$dembuf" sweep "${small[@]}" --vary bed.thickness_m=0.01 \
  --no-bed-cache --dry-run > "$work/served.txt" 2>&1 || { cat "$work/served.txt"; fail "served dry run"; }
grep -q "^predicted wall time" "$work/served.txt" &&
  grep -q "a dry run is planned here, not on the server" "$work/served.txt" ||
  { cat "$work/served.txt"; fail "the dry run with a server configured"; }
echo "1 passed, 0 failed"
