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
echo "sweep folders test passed"
