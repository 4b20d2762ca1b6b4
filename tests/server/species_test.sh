#!/usr/bin/env bash
# Beds of several species through the doors. A two-layer bed (steel shot under glass beads)
# and a 30% steel mixture run locally and on the daemon: the job's series is the local run's,
# both summaries give each layer with its beads of each species, and the animation frames and
# snapshots carry the species array (read back from the VTK files). A bed file of two atom
# types goes with a job as two species, and `scene --list fields` lists the species' fields.
# Usage: species_test.sh DEMBUF DEMBUFD
. "$(dirname "$0")/lib.sh" "$1" "$2"
here=$(dirname "$0")
small_scene "$work/small.toml"
start_daemon "$work/dembuf.db" "$work/dembufd.log" --workers 1
frames=(--set output.animation_interval_s=0.001 --set time.impact_window_s=0.003
        --set output.snapshot_after_contact_s=0.001)
layered=(--set bed.thickness_m=0.012 --set layer1.thickness_m=0.005 --set layer1.fraction2=1)
mixed=(--set layer1.fraction2=0.3)

check_run() {  # check_run FOLDER LAYERS: its summary's layers, its frames' species
  /usr/bin/python3 - "$1" "$2" "$here/../cli" <<'PY'
import glob, json, sys
sys.path.insert(0, sys.argv[3])
import vtk_check
folder, layers = sys.argv[1], int(sys.argv[2])
summary = json.load(open(f"{folder}/summary.json"))
got = summary["bed"]["layers"]
assert len(got) == layers, got
steel = sum(layer["beads"]["steel"] for layer in got)
glass = sum(layer["beads"]["beads"] for layer in got)
assert steel > 20 and glass > 20, got
if layers == 2:
    assert got[0]["beads"]["beads"] == 0 and got[1]["beads"]["steel"] == 0, got
    assert abs(got[0]["top_m"] - 0.005) < 0.005, got
files = sorted(glob.glob(f"{folder}/frames/*.vtp")) + glob.glob(f"{folder}/snapshots/*/beads.vtp")
assert len(files) >= 3, files
for path in files:
    vtp = vtk_check.read_vtp(path)
    species = vtp["PointData"]["species"]
    assert len(species) == vtp["n_points"], path
    # the beads of species 1 and 2, the projectile (the last point) 0
    assert species[-1] == 0 and set(species[:-1]) == {1, 2}, (path, set(species))
    assert sum(1 for s in species if s == 2) == steel, (path, steel)
print(f"{folder}: {layers} layer(s), {steel} steel and {glass} glass beads, species in "
      f"{len(files)} VTK files")
PY
}

for case in layered mixed; do
  eval "sets=(\"\${${case}[@]}\")"
  "$dembuf" run "$work/small.toml" "${sets[@]}" "${frames[@]}" --bed-cache "$work/beds" \
    --no-plots --out "$work/$case-local" > "$work/$case.log" 2>&1 ||
    fail "local run of the $case bed: $(tail -5 "$work/$case.log")"
  check_run "$work/$case-local" "$([ "$case" = layered ] && echo 2 || echo 1)" ||
    fail "the local run of the $case bed"
  job=$("$dembuf" submit "$work/small.toml" "${sets[@]}" "${frames[@]}")
  wait_state "$job" "done failed" 300
  [ "$(job_state "$job")" = done ] || fail "job $job ($case): $("$dembuf" status "$job")"
  "$dembuf" fetch "$job" --out "$work/$case-job" --no-plots > /dev/null ||
    fail "fetch of job $job"
  cmp "$work/$case-local/plate_force.csv" "$work/$case-job/plate_force.csv" ||
    fail "the $case job's series differs from the local run's"
  check_run "$work/$case-job" "$([ "$case" = layered ] && echo 2 || echo 1)" ||
    fail "the fetched job of the $case bed"
done

# The Python package reads the species as a column of the frames.
PYTHONPATH="$(dirname "$dembuf")/../python" /usr/bin/python3 - "$work/layered-job" <<'PY' ||
import glob, sys
import dembuf
frame = dembuf.read_vtp(sorted(glob.glob(f"{sys.argv[1]}/frames/*.vtp"))[0])
assert set(frame["species"]) == {0, 1, 2}, set(frame["species"])
assert (frame.loc[frame["id"] == -1, "species"] == 0).all()
print(f"read_vtp: species {sorted(set(frame['species']))} over {len(frame)} bodies")
PY
  fail "the Python reader of the species"

# A bed file of two atom types, sent with a job: two species, named in the bed's note.
"$dembuf" bed export "$work/small.toml" "${mixed[@]}" --bed-cache "$work/beds" --format lammps \
  --out "$work/mixed.data" > /dev/null || fail "bed export of the mixture"
grep -q "atom types 1 beads, 2 steel" "$work/mixed.data" || fail "the data file's title: $(head -1 "$work/mixed.data")"
job=$("$dembuf" submit "$work/small.toml" --set bed.import="$work/mixed.data" \
  --set bed.import_types=2 --set bed.import_overlaps=relax)
wait_state "$job" "done failed" 300
[ "$(job_state "$job")" = done ] || fail "job $job on the data file: $("$dembuf" status "$job")"
"$dembuf" fetch "$job" --out "$work/imported" --no-plots > /dev/null || fail "fetch of job $job"
grep -q '"imported": ".*atom types as species: type 1 species 1 ([0-9]* beads), type 2 species 2' \
  "$work/imported/summary.json" || fail "the imported bed's note: $(grep imported "$work/imported/summary.json")"

# The fields are in the table every door reads.
"$dembuf" scene --list fields > "$work/fields"
for field in species2.density_kg_m3 layer1.fraction2 layer3.fraction3 pairs.friction_1_2 \
  bed.import_types; do
  grep -q "^$field" "$work/fields" || fail "scene --list fields lacks $field"
done
echo "species through every door: local and daemon runs agree, frames carry the species"
