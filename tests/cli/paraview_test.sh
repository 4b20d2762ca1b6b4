#!/usr/bin/env bash
# ParaView files, read back: a run's snapshots (beads.vtp, contacts.vtp) and animation frames
# (frames/*.vtp) are valid VTK XML whose counts, arrays and times agree with each other and
# with the run's other files (tests/cli/vtk_check.py; through VTK itself when python3-vtk9 is
# installed); `dembuf bed export` writes a text bed and a LAMMPS data file that import back to
# the same beads, a .vtp, and (when `lmp` is installed) a data file LAMMPS reads, whose dump by
# LAMMPS imports too.
# Usage: paraview_test.sh DEMBUF_BINARY
set -eu
dembuf=$1
here=$(dirname "$0")
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }

small=(--set cylinder.radius_m=0.02 --set bed.thickness_m=0.01 --set bed.source_thickness_m=0.015
       --set projectile.diameter_m=0.012 --set projectile.mass_kg=0.01
       --set projectile.speed_m_s=2 --set projectile.height_m=0.02)
"$dembuf" run "${small[@]}" --set output.snapshot_after_contact_s=0.0005,0.001 \
  --set output.animation_interval_s=0.0005 --set time.impact_window_s=0.004 \
  --bed-cache "$work/beds" --no-plots --out "$work/run" > "$work/run.log" 2>&1 ||
  { cat "$work/run.log"; fail "run with snapshots and frames"; }
/usr/bin/python3 "$here/vtk_check.py" run "$work/run" 0.0005 || fail "the run's VTK files"
# The Python package reads a contacts.vtp's lines and their forces (read_vtp gave the points).
PYTHONPATH="$(dirname "$dembuf")/../python" /usr/bin/python3 - "$work/run" <<'PY' ||
import glob, re, sys
import numpy as np
import dembuf
for path in glob.glob(f"{sys.argv[1]}/snapshots/*/contacts.vtp"):
    contacts = dembuf.read_contacts_vtp(path)
    lines = int(re.search(rb'NumberOfLines="(\d+)"', open(path, "rb").read(2000)).group(1))
    assert len(contacts) == lines > 0, (path, len(contacts), lines)
    points = dembuf.read_vtp(path)[["x_m", "y_m", "z_m"]].to_numpy()
    assert np.isin(contacts[["x1_m", "x2_m"]].to_numpy(), points[:, 0]).all(), path
    assert (contacts.normal_force_N >= 0).all() and contacts.normal_force_N.max() > 0, path
print("contacts.vtp read with its lines and forces")
PY
  fail "the Python reader of contacts.vtp"

# bed export: text reads back as an import to the same beads (radii bit for bit).
"$dembuf" bed export "${small[@]}" --bed-cache "$work/beds" --format text --out "$work/bed.txt" \
  > /dev/null || fail "bed export text"
"$dembuf" bed export "${small[@]}" --bed-cache "$work/beds" --format text --out "$work/bed.txt" \
  > /dev/null 2>&1 && fail "bed export replaced a file without --force"
# A bad scene is named as such, whether or not --out exists; an empty --out is refused.
for out in "$work/bed.txt" "$work/new.txt" ""; do
  status=0
  message=$("$dembuf" bed export "${small[@]}" --set beads.no_such_field=1 --bed-cache "$work/beds" \
    --format text --out "$out" 2>&1 > /dev/null) || status=$?
  [ "$status" = 2 ] && grep -q "no_such_field" <<<"$message" ||
    fail "bed export of a bad scene to '$out': exit $status, $message"
done
status=0
message=$("$dembuf" bed export "${small[@]}" --bed-cache "$work/beds" --format text --out "" \
  2>&1 > /dev/null) || status=$?
[ "$status" = 2 ] && grep -q -- "--out" <<<"$message" || fail "an empty --out: exit $status, $message"
# A file that cannot be written is refused before the bed is prepared (an empty cache stays so).
for out in "$work/no-folder/bed.txt" "$work"; do
  status=0
  message=$("$dembuf" bed export "${small[@]}" --bed-cache "$work/empty-cache" --format text \
    --out "$out" --force 2>&1 > /dev/null) || status=$?
  [ "$status" = 2 ] && grep -q -- "--out" <<<"$message" || fail "--out $out: exit $status, $message"
  [ -z "$(ls -A "$work/empty-cache" 2> /dev/null)" ] || fail "--out $out: a bed was prepared first"
done
"$dembuf" bed export "${small[@]}" --set bed.import="$work/bed.txt" --bed-cache "$work/beds" \
  --format text --out "$work/again.txt" > /dev/null || fail "bed export of the imported bed"
# (The imported bed relaxes before it is used: a settled bed's beads move by micrometres.)
python3 - "$work/bed.txt" "$work/again.txt" <<'PY' || fail "an exported bed does not import to the same beads"
import math, sys
a, b = ([list(map(float, l.split())) for l in open(f) if not l.startswith("#")] for f in sys.argv[1:])
assert len(a) == len(b) > 100, (len(a), len(b))
assert all(x[3] == y[3] for x, y in zip(a, b)), "radii differ"
moved = max(math.dist(x[:3], y[:3]) for x, y in zip(a, b))
assert moved < 1e-5, f"a bead moved {moved} m"
print(f"{len(a)} beads imported back; the relaxation moved them at most {moved:.2g} m")
PY
"$dembuf" bed export "${small[@]}" --bed-cache "$work/beds" --format vtp --out "$work/bed.vtp" \
  > /dev/null || fail "bed export vtp"
"$dembuf" bed export "${small[@]}" --bed-cache "$work/beds" --format lammps \
  --out "$work/bed.data" > /dev/null || fail "bed export lammps"
/usr/bin/python3 "$here/vtk_check.py" bed "$work/bed.vtp" "$work/bed.txt" "$work/bed.data" ||
  fail "the exported bed's files"
# The LAMMPS data file imports to the same beads as the text: the same bed after relaxing.
"$dembuf" bed export "${small[@]}" --set bed.import="$work/bed.data" --bed-cache "$work/beds" \
  --format text --out "$work/again_data.txt" > /dev/null || fail "import of the LAMMPS data file"
cmp <(grep -v '^#' "$work/again.txt") <(grep -v '^#' "$work/again_data.txt") ||
  fail "the LAMMPS data file imported to other beads than the text file"
if command -v lmp > /dev/null; then
  printf 'units si\natom_style sphere\nboundary f f f\nread_data %s\nrun 0\n' "$work/bed.data" \
    > "$work/in.read"
  (cd "$work" && lmp -in in.read -log none > lammps.out 2>&1) ||
    { tail -5 "$work/lammps.out"; fail "LAMMPS does not read the exported bed"; }
  beads=$(grep -vc '^#' "$work/bed.txt")
  grep -q "reading atoms" "$work/lammps.out" && grep -Eq "^ +$beads atoms" "$work/lammps.out" ||
    { cat "$work/lammps.out"; fail "LAMMPS read another number of atoms than $beads"; }
  echo "LAMMPS read the exported bed: $beads atoms"
  # LAMMPS's own dump of that bed imports too (6 digits: the beads as LAMMPS printed them).
  printf 'units si\natom_style sphere\nboundary f f f\nread_data %s\n%s\nrun 0\n' \
    "$work/bed.data" "dump d all custom 1 bed.dump id type x y z radius" > "$work/in.dump"
  (cd "$work" && lmp -in in.dump -log none > lammps_dump.out 2>&1) ||
    { tail -5 "$work/lammps_dump.out"; fail "LAMMPS could not dump the bed"; }
  "$dembuf" bed export "${small[@]}" --set bed.import="$work/bed.dump" \
    --set bed.import_overlaps=relax --bed-cache "$work/beds" --format text \
    --out "$work/from_dump.txt" > /dev/null || fail "import of LAMMPS's dump"
  [ "$(grep -vc '^#' "$work/from_dump.txt")" = "$beads" ] || fail "the dump imported to another count"
  echo "LAMMPS's dump of it imported: $beads beads"
else
  echo "LAMMPS (lmp) not installed: its reading of the exported bed not checked"
fi
# The same frames as LAMMPS dumps (output.frame_format, for OVITO): one a frame, of the VTK
# frame's atoms (the beads and the projectile) at its time; the last imports as a bed (the
# project's reader of LAMMPS dumps: TIME before TIMESTEP, the projectile as the atom of type 4).
"$dembuf" run "${small[@]}" --set output.animation_interval_s=0.0005 --set time.impact_window_s=0.004 \
  --set output.frame_format=lammps --bed-cache "$work/beds" --no-plots --out "$work/dumps" \
  > "$work/dumps.log" 2>&1 || { cat "$work/dumps.log"; fail "run with frame_format lammps"; }
[ ! -e "$work/dumps/frames.pvd" ] || fail "frame_format lammps wrote frames.pvd"
vtps=$(cd "$work/run/frames" && ls ./*.vtp | sed 's/\.vtp$//')
[ "$vtps" = "$(cd "$work/dumps/frames" && ls ./*.dump | sed 's/\.dump$//')" ] ||
  fail "the dumps are not the VTK frames: $(ls "$work/dumps/frames")"
for frame in $vtps; do
  points=$(grep -a -o 'NumberOfPoints="[0-9]*"' "$work/run/frames/$frame.vtp" | head -1 | tr -dc 0-9)
  atoms=$(sed -n '/^ITEM: NUMBER OF ATOMS/{n;p;}' "$work/dumps/frames/$frame.dump")
  [ "$points" = "$atoms" ] || fail "$frame: $atoms atoms, $points VTK points"
  [ "$(grep -c . "$work/dumps/frames/$frame.dump")" = $((atoms + 9 + 2)) ] || fail "$frame's lines"
done
last=$(ls "$work/dumps/frames/"*.dump | tail -1)
"$dembuf" bed export "${small[@]}" --set bed.import="$last" --set bed.import_overlaps=relax \
  --bed-cache "$work/beds" --format text --out "$work/frame_bed.txt" > "$work/import.log" 2>&1 ||
  fail "the last dump does not import as a bed: $(cat "$work/import.log")"

echo "1 passed, 0 failed"
