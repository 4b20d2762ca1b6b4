#!/usr/bin/env bash
# Items 1 and 2 of the robustness suite (docs/robustness.md): know the cost before paying it,
# and free fall costs nothing.
# - A projectile that never arrives (no gravity, 1e-300 m/s) ran until memory ran out, and
#   Ctrl-C could not stop it: now refused at once, locally and by the daemon.
# - Beads of 1 um allocated until memory ran out: refused with the estimate (3e15 beads),
#   naming the field, by the CLI and by the daemon's limits.
# - A 5 s fixed end kept every step in memory: now the memory of a run does not grow with
#   its length, and a 100 m drop sampled every 0.15 us writes no free-fall samples.
# - `--dry-run` prints the estimate and says which beds are cached; a run past this machine's
#   limits asks for --yes.
# Usage: costs_test.sh DEMBUF DEMBUFD
. "$(dirname "$0")/lib.sh" "$1" "$2"

# Peak memory (kB) of a command, from the kernel's account of the finished child.
peak_kb() {
  python3 -c 'import resource, subprocess, sys
subprocess.run(sys.argv[1:], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)' "$@"
}

# --- the endless free fall: refused at once -----------------------------------------------
expect_exit 2 "projectile.speed_m_s: 1e-300 m/s with gravity_m_s2 = 0: the projectile reaches the bed after" \
  "$dembuf" run --set gravity_m_s2=0 --set projectile.speed_m_s=1e-300 --out "$work/endless"
[ ! -e "$work/endless" ] || fail "a refused run created its folder"
expect_exit 2 "never reaches the bed" "$dembuf" run --set gravity_m_s2=0 --set projectile.speed_m_s=0

# --- beads of 1 um: refused with the estimate (the old binary is held to 4 GB here) --------
tiny=(--set bed.thickness_m=0.02 --set beads.diameter_min_m=1e-6 --set beads.diameter_max_m=1e-6)
(ulimit -v 4000000; expect_exit 2 "beads.diameter_min_m: the bed would hold about 3.22e+15 beads" \
  "$dembuf" run "${tiny[@]}" --out "$work/tiny") || exit 1
[ ! -e "$work/tiny" ] || fail "a refused run created its folder"
# Past half this machine's memory (4.5e8 beads of 1 mm): refused unless --yes.
expect_exit 2 "of memory; this machine's limit is .* (half its memory; pass --yes to run it anyway)" \
  "$dembuf" run --set cylinder.radius_m=0.5 --set cylinder.height_m=2 --set bed.thickness_m=0.45 \
  --set beads.diameter_min_m=0.001 --set beads.diameter_max_m=0.001 --out "$work/huge"
[ ! -e "$work/huge" ] || fail "a refused run created its folder"

# --- the memory of a run does not grow with its length --------------------------------------
short=$(peak_kb "$dembuf" run --set time.end_s=0.5 --set time.output_interval_s=0.1 --out "$work/short")
long=$(peak_kb "$dembuf" run --set time.end_s=5 --set time.output_interval_s=0.1 --out "$work/long")
echo "peak memory: $((short / 1024)) MB for 0.5 s, $((long / 1024)) MB for 5 s"
[ $((long - short)) -lt 20000 ] || fail "a 5 s run took $(((long - short) / 1024)) MB more than a 0.5 s one"

# --- a 100 m drop sampled every 0.15 us: the record starts at the impact ------------------
"$dembuf" run --set projectile.height_m=100 --set time.output_interval_s=1.5e-7 \
  --out "$work/drop" > /dev/null 2>&1 || fail "the 100 m drop failed"
rows=$(($(wc -l < "$work/drop/plate_force.csv") - 1))
flight=$(sed -n 's/.*"free_flight_s": \([0-9.e+-]*\).*/\1/p' "$work/drop/summary.json")
first=$(sed -n '2s/,.*//p' "$work/drop/plate_force.csv")
awk -v f="$flight" -v t="$first" 'BEGIN { exit !(f > 4.4 && t >= f) }' ||
  fail "the record starts at $first s, the flight took $flight s"
[ "$rows" -lt 5000 ] || fail "$rows samples for a bare-plate impact"

# --- --dry-run: the estimate, the cache, and nothing run -----------------------------------
small_scene "$work/small.toml"
"$dembuf" run "$work/small.toml" --bed-cache "$work/beds" --dry-run --out "$work/dry" > "$work/dry.txt"
[ ! -e "$work/dry" ] || fail "--dry-run created the output folder"
grep -q "^bed source [0-9a-f]*: to prepare, about [0-9.e+]* beads" "$work/dry.txt" || fail "dry run: $(cat "$work/dry.txt")"
grep -q "^memory: at most" "$work/dry.txt" || fail "dry run: $(cat "$work/dry.txt")"
grep -q "^predicted wall time: about" "$work/dry.txt" || fail "dry run: $(cat "$work/dry.txt")"
"$dembuf" run "$work/small.toml" --bed-cache "$work/beds" --out "$work/small" > /dev/null 2>&1 || fail "small run"
"$dembuf" run "$work/small.toml" --bed-cache "$work/beds" --dry-run > "$work/dry.txt"
[ "$(grep -c ': in the cache$' "$work/dry.txt")" = 2 ] || fail "dry run after: $(cat "$work/dry.txt")"
"$dembuf" sweep "$work/small.toml" --vary bed.thickness_m=0.008,0.01 --seeds 2 --bed-cache "$work/beds" \
  --dry-run --out "$work/drysweep" > "$work/drysweep.txt"
grep -q "^4 runs$" "$work/drysweep.txt" || fail "sweep dry run: $(cat "$work/drysweep.txt")"
grep -q "^beds to prepare: 1 source$" "$work/drysweep.txt" || fail "sweep dry run: $(cat "$work/drysweep.txt")"
grep -q "^beds in the cache: 1 cut$" "$work/drysweep.txt" || fail "sweep dry run: $(cat "$work/drysweep.txt")"
[ ! -e "$work/drysweep" ] || fail "--dry-run created the sweep folder"

# --- the daemon: the same refusals, and it keeps serving -----------------------------------
start_daemon "$work/dembuf.db" "$work/dembufd.log"
expect_exit 2 "refused the request: projectile.speed_m_s: 1e-300 m/s" \
  "$dembuf" submit --set gravity_m_s2=0 --set projectile.speed_m_s=1e-300
expect_exit 2 "refused by the server's limits: beads.diameter_min_m: the bed would hold about 3.22e+15 beads; this server's limit is 1e+06" \
  "$dembuf" submit "${tiny[@]}"
expect_exit 2 "refused by the server.s limits: time.end_s: the run would take up to 1.28e+10 time steps" \
  "$dembuf" submit --set time.end_s=1000 --set time.alpha=0.01
"$dembuf" server-info > /dev/null || fail "the daemon died"
[ -z "$("$dembuf" list | tail -n +2)" ] || fail "a refused job was stored"
stop_daemon
echo "costs test passed"
