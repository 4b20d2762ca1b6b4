#!/usr/bin/env bash
# A sweep folder belongs to one sweep (docs/results.md, "Sweep folders"): `dembuf sweep --out s` run again with
# another scene (projectile.mass_kg 0.3 -> 0.5) re-ran and overwrote the earlier runs without
# --force, and where the run names differed left the other scene's runs beside the new ones,
# sweep.csv listing only some. Now the folder records the sweep's scene: another is refused
# naming the field, --force removes the old runs first, the same sweep with points added
# resumes (a run kept whatever its folder's name), and sweep.csv lists every run folder.
# Usage: sweep_folders_test.sh DEMBUF
set -eu
dembuf=$1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
export OMP_NUM_THREADS=1
unset DEMBUF_SERVER
bare=(--local --no-bed-cache --set bed.thickness_m=0 --set projectile.height_m=0.05
      --set time.output_interval_s=1e-4)
sweep() { "$dembuf" sweep "${bare[@]}" --out "$work/s" "$@" > "$work/out" 2> "$work/err"; }
rows() { tail -n +2 "$work/s/sweep.csv" | wc -l; }

sweep --set projectile.mass_kg=0.3 --vary projectile.speed_m_s=1,2 || fail "the first sweep: $(cat "$work/err")"
[ "$(rows)" = 2 ] || fail "sweep.csv: $(cat "$work/s/sweep.csv")"
before=$(md5sum "$work"/s/runs/*/summary.json)

# Another scene into the same folder: refused, naming the field and both values; nothing run.
rc=0
sweep --set projectile.mass_kg=0.5 --vary projectile.speed_m_s=1,2 || rc=$?
[ "$rc" = 2 ] || fail "another scene into the folder: exit $rc, $(cat "$work/err")"
grep -q "holds a sweep of another scene: projectile.mass_kg = 0.3 there, 0.5 here" "$work/err" ||
  fail "the refusal does not name the field: $(cat "$work/err")"
grep -q -- "--force" "$work/err" || fail "the refusal does not say how to go on: $(cat "$work/err")"
[ "$(md5sum "$work"/s/runs/*/summary.json)" = "$before" ] || fail "the earlier runs were touched"
# ... and a sweep that varies another field.
rc=0
sweep --set projectile.mass_kg=0.3 --vary projectile.height_m=0.05,0.06 || rc=$?
[ "$rc" = 2 ] && grep -q "varies" "$work/err" || fail "another axis: exit $rc, $(cat "$work/err")"

# A folder of an older dembuf (no sweep_scene.json): the same sweep resumes, its runs' own
# scenes saying it is the same.
rm "$work/s/sweep_scene.json"
sweep --set projectile.mass_kg=0.3 --vary projectile.speed_m_s=1,2 || fail "an older folder: $(cat "$work/err")"
[ "$(grep -c "done earlier, kept" "$work/out")" = 2 ] || fail "the older folder's runs were not kept: $(cat "$work/out")"

# --force: the old runs go first; a folder in runs/ that no run wrote stays.
mkdir "$work/s/runs/notes" && echo "mine" > "$work/s/runs/notes/todo.txt"
sweep --set projectile.mass_kg=0.5 --vary projectile.speed_m_s=3 --force || fail "--force: $(cat "$work/err")"
[ -f "$work/s/runs/notes/todo.txt" ] || fail "--force removed a folder no run wrote"
rm -r "$work/s/runs/notes"
[ "$(ls "$work/s/runs")" = "000_speed_m_s=3_seed=1" ] || fail "--force left: $(ls "$work/s/runs")"
# ... a run an older dembuf left open to its group too.
chmod 0775 "$work/s/runs/000_speed_m_s=3_seed=1"
sweep --set projectile.mass_kg=0.3 --vary projectile.speed_m_s=4 --force || fail "--force: $(cat "$work/err")"
[ "$(ls "$work/s/runs")" = "000_speed_m_s=4_seed=1" ] || fail "--force left an open run: $(ls "$work/s/runs")"
sweep --set projectile.mass_kg=0.5 --vary projectile.speed_m_s=3 --force || fail "--force: $(cat "$work/err")"
[ "$(rows)" = 1 ] || fail "sweep.csv after --force: $(cat "$work/s/sweep.csv")"

# The same sweep with points added resumes: speed 3 is kept though it is now the second run.
sweep --set projectile.mass_kg=0.5 --vary projectile.speed_m_s=2,3 || fail "points added: $(cat "$work/err")"
grep -q "done earlier, kept in 000_speed_m_s=3_seed=1" "$work/out" || fail "the earlier run was not kept: $(cat "$work/out")"
[ ! -e "$work/s/runs/001_speed_m_s=3_seed=1" ] || fail "the kept point was run again"
# A later invocation of fewer points: sweep.csv still lists every run folder there is.
sweep --set projectile.mass_kg=0.5 --vary projectile.speed_m_s=2 || fail "fewer points: $(cat "$work/err")"
[ "$(rows)" = "$(ls "$work/s/runs" | wc -l)" ] && [ "$(rows)" = 2 ] ||
  fail "sweep.csv lists $(rows) runs of $(ls "$work/s/runs" | wc -l): $(cat "$work/s/sweep.csv")"
grep -q "speed_m_s=3" "$work/s/sweep.csv" || fail "the earlier point is not listed: $(cat "$work/s/sweep.csv")"

# A run kept from an earlier invocation must be what this dembuf would make of the same scene
# and bed: one whose summary names another build is run again (a folder mixed two engines'
# results), and so is one whose imported bed file has changed since (its path is the same).
one=(--set projectile.mass_kg=0.5 --vary projectile.speed_m_s=2)
summary=$(ls "$work"/s/runs/*speed_m_s=2*/summary.json)
python3 - "$summary" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
s["provenance"]["build_commit"] = "0123456789ab"
s["P_N"] = 12345.0
json.dump(s, open(sys.argv[1], "w"))
PY
sweep "${one[@]}" || fail "a run of another build: $(cat "$work/err")"
grep -q "is not kept (made by another build of dembuf): running it again" "$work/out" ||
  fail "a run of another build was kept: $(cat "$work/out")"
grep -q "12345" "$work/s/sweep.csv" && fail "sweep.csv lists the other build's result"
printf '0 0 0.002 0.002\n0.005 0 0.002 0.002\n' > "$work/bed.txt"
imported=(--set bed.import="$work/bed.txt" --vary projectile.speed_m_s=1)
importing() { "$dembuf" sweep --local --no-bed-cache --set projectile.height_m=0.05 \
  --set time.output_interval_s=1e-4 "${imported[@]}" --out "$work/i" > "$work/out" 2> "$work/err"; }
importing || fail "a sweep of an imported bed: $(cat "$work/err")"
importing && grep -q "done earlier, kept" "$work/out" || fail "the imported bed's run was not kept: $(cat "$work/out")"
printf '0 0 0.002 0.002\n0.006 0 0.002 0.002\n' > "$work/bed.txt"
importing || fail "the changed bed: $(cat "$work/err")"
grep -q "is not kept (its bed is another)" "$work/out" ||
  fail "a run of the bed file as it was was kept: $(cat "$work/out")"

# Another build's run of a point the command leaves out is not listed beside this build's
# runs, nor counted as failed: it is left out, saying so.
importing || fail "importing again"
imported=(--set bed.import="$work/bed.txt" --vary projectile.speed_m_s=1,2)
importing || fail "two points: $(cat "$work/err")"
python3 - "$(ls "$work"/i/runs/*speed_m_s=2*/summary.json)" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
s["provenance"]["dembuf_version"] = "0.0.1"
json.dump(s, open(sys.argv[1], "w"))
PY
imported=(--set bed.import="$work/bed.txt" --vary projectile.speed_m_s=1)
importing || fail "another build's earlier point failed the sweep: $(cat "$work/out")"
grep -q "is left out of the report (made by another build of dembuf)" "$work/out" ||
  fail "another build's earlier point was not told of: $(cat "$work/out")"
[ "$(tail -n +2 "$work/i/sweep.csv" | wc -l)" = 1 ] || fail "sweep.csv lists another build's run: $(cat "$work/i/sweep.csv")"

# A sweep writes its folder closed to others' writing whatever the umask (with 002 its own
# runs were refused when it resumed), and keeps its runs.
(umask 002 && importing) || fail "under umask 002: $(cat "$work/err")"
run=$(ls -d "$work"/i/runs/*speed_m_s=1*/)
[ "$(stat -c %a "$run")" = 755 ] && [ "$(stat -c %a "$run/summary.json")" = 644 ] ||
  fail "under umask 002: $(stat -c '%a %n' "$run" "$run/summary.json")"
(umask 002 && importing && grep -q "done earlier, kept" "$work/out") ||
  fail "under umask 002 the run was not kept: $(cat "$work/out")"

# What another account could leave where it may write is never taken for a run of the
# sweep's, nor written through: a sweep folder or runs/ others may write (where they could swap
# a run for a link between a check and a write), a runs/ that is a link, a record that is a
# FIFO; a summary or a run folder that is a link.
for mode in 0775 0777 1777; do
  chmod "$mode" "$work/i"
  rc=0
  importing || rc=$?
  [ "$rc" = 2 ] && grep -q "is writable by .*: another account could change the sweep's results there" "$work/err" ||
    fail "a sweep folder of mode $mode: exit $rc, $(cat "$work/err")"
  chmod 0755 "$work/i"
done
chmod 0777 "$work/i/runs"
rc=0
importing || rc=$?
[ "$rc" = 2 ] && grep -q "runs is writable by every account" "$work/err" || fail "runs/ of mode 0777: exit $rc, $(cat "$work/err")"
chmod 0755 "$work/i/runs"
mv "$work/i/runs" "$work/elsewhere" && ln -s "$work/elsewhere" "$work/i/runs"
rc=0
importing || rc=$?
[ "$rc" = 2 ] && grep -q "runs is a link" "$work/err" || fail "runs/ a link: exit $rc, $(cat "$work/err")"
rm "$work/i/runs" && mv "$work/elsewhere" "$work/i/runs"
mv "$work/i/sweep_scene.json" "$work/record.json" && mkfifo "$work/i/sweep_scene.json"
rc=0
timeout 60 bash -c "$(declare -f importing); $(declare -p imported work dembuf); importing" || rc=$?
[ "$rc" = 2 ] && grep -q "sweep_scene.json is not a regular file" "$work/err" || fail "a FIFO for the record: exit $rc, $(cat "$work/err")"
rm "$work/i/sweep_scene.json" && mv "$work/record.json" "$work/i/sweep_scene.json"
# A folder above the sweep's that others may write without the sticky bit lets them move the
# sweep's folder away and put a link in its place while it runs: refused; with +t, taken.
mkdir -m 0775 "$work/project"
proj() { "$dembuf" sweep --local --no-bed-cache --set projectile.height_m=0.05 \
  --set time.output_interval_s=1e-4 "${imported[@]}" --out "$work/project/s" > "$work/out" 2> "$work/err"; }
rc=0
proj || rc=$?
[ "$rc" = 2 ] && grep -q "project is writable by its group without the sticky bit" "$work/err" ||
  fail "a group-writable folder above: exit $rc, $(cat "$work/err")"
chmod +t "$work/project"
proj || fail "a sticky group folder above: $(cat "$work/err")"
# Every file a sweep writes is closed to others' writing, its gnuplot scripts too (one another
# account could edit ran as the user): one left open is written anew.
scripts=$(ls "$work"/project/s/*.gp 2> /dev/null | head -1)
if [ -n "$scripts" ]; then
  chmod 0666 "$scripts"
  (umask 002 && proj) || fail "sweeping again: $(cat "$work/err")"
  [ "$(stat -c %a "$scripts")" = 644 ] || fail "a gnuplot script left open: $(stat -c '%a %n' "$scripts")"
fi
for f in "$work"/project/s/*.csv "$work"/project/s/*.json; do
  [ "$(( $(stat -c %a "$f") % 100 / 10 & 2 ))" = 0 ] || fail "$f is open to its group: $(stat -c %a "$f")"
done
mv "$run/summary.json" "$work/real.json"
python3 - "$work/real.json" "$work/forged.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1])); s["P_N"] = 1e5
json.dump(s, open(sys.argv[2], "w"))
PY
ln -s "$work/forged.json" "$run/summary.json"
importing || fail "a summary that is a link: $(cat "$work/err")"
grep -q "done earlier, kept" "$work/out" && fail "a summary that is a link was kept: $(cat "$work/out")"
grep -q "1e+05\|100000" "$work/i/sweep.csv" && fail "sweep.csv lists the linked summary's result"
[ -L "$run/summary.json" ] && fail "the link was not replaced by the run's own summary"
# A run folder open to others (an older dembuf's, umask 002) is made anew, closed.
chmod 0775 "$run"
importing || fail "a run folder open to its group: $(cat "$work/out")"
grep -q "done earlier, kept" "$work/out" && fail "a run folder open to its group was kept"
[ "$(stat -c %a "$run")" = 755 ] || fail "the run folder was not made anew: $(stat -c %a "$run")"
mkdir "$work/victim" && echo precious > "$work/victim/plate_force.csv"
rm -r "$run" && ln -s "$work/victim" "${run%/}"
rc=0
importing || rc=$?
[ "$rc" != 0 ] && grep -q "is a link: not written into" "$work/out" ||
  fail "a run folder that is a link: exit $rc, $(cat "$work/out")"
[ "$(cat "$work/victim/plate_force.csv")" = precious ] && [ "$(ls "$work/victim")" = plate_force.csv ] ||
  fail "the sweep wrote through a linked run folder: $(ls "$work/victim")"
if [ "$(id -u)" = 0 ] && id nobody > /dev/null 2>&1; then
  rm "${run%/}" && importing > /dev/null || fail "importing once more"
  chown -R nobody "$run"
  rc=0
  importing || rc=$?
  grep -q "done earlier, kept" "$work/out" && fail "another account's run folder was kept"
  [ "$rc" != 0 ] && grep -q "another account's" "$work/out" ||
    fail "another account's run folder: exit $rc, $(cat "$work/out")"
fi
echo "sweep folders test passed"
