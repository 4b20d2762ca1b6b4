#!/usr/bin/env bash
# One run, three callers, one folder: `dembuf run` of a scene, the same point as a run of a
# local sweep, and the same scene as a daemon job fetched back hold the same files (the series,
# the bare-plate series, the snapshots, the animation frames and their .pvd collections), and
# every file but summary.json holds the same bytes; the summaries agree in every number but the
# wall time and the provenance.
# Usage: run_folders_test.sh SOURCE_DIR DEMBUF DEMBUFD
set -eu
source_dir=$1
. "$source_dir/tests/server/lib.sh" "$2" "$3"
export OMP_NUM_THREADS=1

small_scene "$work/scene.toml"
cat >> "$work/scene.toml" <<'TOML'
[output]
snapshot_after_contact_s = [0.0005, 0.001]
snapshot_at_peak = true
animation_interval_s = 0.001
[time]
impact_window_s = 0.004
TOML

"$dembuf" run "$work/scene.toml" --bed-cache "$work/beds" --no-plots --out "$work/run" \
  > "$work/run.log" 2>&1 || { cat "$work/run.log"; fail "dembuf run"; }
"$dembuf" sweep "$work/scene.toml" --local --vary projectile.speed_m_s=2 --bed-cache "$work/beds" \
  --out "$work/sweep" > "$work/sweep.log" 2>&1 || { cat "$work/sweep.log"; fail "dembuf sweep"; }
sweep_run=$(find "$work/sweep/runs" -mindepth 1 -maxdepth 1 -type d)
[ "$(echo "$sweep_run" | wc -l)" = 1 ] || fail "the sweep made other than one run: $sweep_run"

start_daemon "$work/jobs.db" "$work/daemon.log" --workers 1 --threads-per-job 1
job=$("$dembuf" submit "$work/scene.toml")
wait_state "$job" "done failed" 300
[ "$(job_state "$job")" = done ] || fail "the daemon's job ended $(job_state "$job")"
"$dembuf" fetch "$job" --no-plots --out "$work/fetched" > /dev/null || fail "fetch"
stop_daemon

# What a run folder holds, plots apart (a client draws them from these files), and a fetched
# job's record of itself (job.json: its owner, state and times) apart.
files_of() { (cd "$1" && find . -type f ! -name '*.png' ! -name '*.svg' ! -name '*.gp' ! -path ./job.json | sort); }
[ -f "$work/fetched/job.json" ] || fail "the fetched folder has no job.json"
files_of "$work/run" > "$work/run.files"
for required in ./plate_force.csv ./plate_force_bare.csv ./summary.json ./log.txt ./scene.toml \
                ./snapshots.pvd ./frames.pvd ./snapshots/peak/contacts.csv; do
  grep -qx "$required" "$work/run.files" || fail "dembuf run wrote no $required"
done
for other in "$sweep_run" "$work/fetched"; do
  files_of "$other" > "$work/other.files"
  diff "$work/run.files" "$work/other.files" ||
    fail "$other holds other files than dembuf run's folder (< run, > $other)"
  # log.txt: the provenance (where and when it ran) differs; the warnings are the same.
  warnings_of() { grep '^warning: \|^no warnings$' "$1/log.txt"; }
  diff <(warnings_of "$work/run") <(warnings_of "$other") ||
    fail "log.txt's warnings differ between dembuf run and $other"
  # And what the run did, with times: the same events wherever it ran (the times differ).
  events_of() { sed -n '/^what the run did (UTC):$/,$p' "$1/log.txt" | cut -d' ' -f2- | sed -e 's/, [0-9]* beads$//' -e 's/, the bed from the cache$//'; }
  [ -n "$(events_of "$other")" ] || fail "$other's log.txt has no timeline: $(cat "$other/log.txt")"
  grep -q '^20[0-9-]*T[0-9:]*Z ended at .* ms' "$other/log.txt" || fail "$other's log.txt has no end"
  diff <(events_of "$work/run" | grep -v '^bed: ') <(events_of "$other" | grep -v '^bed: ') ||
    fail "log.txt's events differ between dembuf run and $other"
  while read -r file; do
    [ "$file" = ./summary.json ] || [ "$file" = ./log.txt ] && continue
    cmp -s "$work/run/$file" "$other/$file" || fail "$file differs between dembuf run and $other"
  done < "$work/run.files"
  python3 - "$work/run/summary.json" "$other/summary.json" <<'PY' || fail "summary.json of $other"
import json, sys
a, b = (json.load(open(f)) for f in sys.argv[1:])
for s in (a, b):
    s.pop("provenance"); s.pop("wall_time_s")
diff = sorted(k for k in a.keys() | b.keys() if a.get(k) != b.get(k))
assert not diff, f"the summaries differ in {diff}"
PY
done
echo "dembuf run, a sweep's run and a daemon job: $(wc -l < "$work/run.files") files, the same"
