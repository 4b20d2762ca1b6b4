#!/usr/bin/env bash
# Item 9 of the robustness suite (docs/robustness.md): imported beds through the CLI. A bead
# at z = 1e8 m crashed the neighbour list: now refused with its line (exit 2, nothing
# written). A bed settled by LAMMPS (tests/data/), whose beads rest on the plate, the wall and
# each other with overlaps of 0.1 to 0.3 um, was refused: now accepted, its overlaps reported
# on the terminal and in summary.json (also a lattice with exactly 0.3 um). Larger overlaps are refused naming the worst bead, or moved
# apart with bed.import_overlaps = "relax".
# Usage: imports_test.sh DEMBUF DEMBUFD
. "$(dirname "$0")/lib.sh" "$1" "$2"
scene=(--set cylinder.radius_m=0.025 --set projectile.diameter_m=0.01 --set projectile.height_m=0.02)

python3 - "$work" <<'PY'
import math, sys
work = sys.argv[1]
r = 0.002
def layer(gap, sink):
    rows = []
    s = 2 * r + gap
    for i in range(-5, 6):
        for j in range(-5, 6):
            x, y = s * i, s * j
            if math.hypot(x, y) <= 0.025 - 2 * r:
                rows.append(f"{x!r} {y!r} {r - sink!r} {r!r}")
    return rows
with open(f"{work}/far.txt", "w") as f:
    f.write("# x y z radius\n0 0 0.002 0.002\n0 0 1e8 0.002\n")
with open(f"{work}/resting.txt", "w") as f:
    f.write("\n".join(layer(-0.3e-6, 0.3e-6)) + "\n")
with open(f"{work}/sunk.txt", "w") as f:
    f.write("\n".join(layer(0.0, 0.0002)) + "\n")
PY

code=0
timeout -s KILL 20 "$dembuf" run "${scene[@]}" --set bed.import="$work/far.txt" --out "$work/far" \
  > /dev/null 2> "$work/err" || code=$?
[ "$code" = 2 ] || fail "a bead at 1e8 m: exit $code: $(cat "$work/err")"
grep -q "far.txt:3: bead reaches above the side wall" "$work/err" || fail "$(cat "$work/err")"
[ ! -e "$work/far" ] || fail "a refused bed created the output folder"

# Tiny beads. One of 1e-12 m with --yes segfaulted (a neighbour grid of 1e33 cells): refused
# below the model's floor of 1 um, naming the line. Beads of 1e-5 m passed the memory check
# (370 MB estimated) and died of bad_alloc at 16 GB: the estimate counts the grid's cells. For
# this bed of 2,000 such beads, 0.14 mm deep, `dembuf run --yes` peaked at 2.53 GB resident
# (/usr/bin/time -v, 2-core machine); the estimate says 2.65 GB.
printf '0 0 0.002 0.002\n0.005 0 1e-3 1e-12\n' > "$work/atomic.txt"
expect_exit 2 "bed.import: .*atomic.txt:2: radius 1e-12 m is below 1e-06 m, the smallest bead this model covers" \
  "$dembuf" run --set bed.import="$work/atomic.txt" --yes --out "$work/atomic"
python3 - "$work/tiny.txt" <<'PY'
import sys
with open(sys.argv[1], "w") as f:
    for i in range(20):
        for j in range(20):
            for k in range(5):
                f.write(f"{i * 3e-5:.6e} {j * 3e-5:.6e} {1.1e-5 + k * 3e-5:.6e} 1e-5\n")
PY
"$dembuf" run --set bed.import="$work/tiny.txt" --set projectile.enabled=false --set time.end_s=1e-5 \
  --dry-run > "$work/dry.txt" 2>&1
memory=$(sed -n 's/^memory: at most \([0-9.]*\) GB$/\1/p' "$work/dry.txt")
[ -n "$memory" ] && python3 -c "import sys; sys.exit(not 2.53 / 2 <= $memory <= 2.53 * 2)" ||
  fail "the estimate for 1e-5 m beads is not within 2x of the 2.53 GB measured: $(grep memory "$work/dry.txt")"

# A bed settled by LAMMPS (tests/data/lammps/in.settle).
lammps_bed=$(cd "$(dirname "$0")/../data" && pwd)/lammps_settled_bed.txt
"$dembuf" run "${scene[@]}" --set bed.import="$lammps_bed" --no-bed-cache --out "$work/lammps" \
  > /dev/null 2> "$work/err" || fail "the bed settled by LAMMPS: $(cat "$work/err")"
grep -q "imported bed: 690 beads (text file); resting on the plate: [0-9]* beads, overlap at most 0.01" \
  "$work/err" || fail "LAMMPS bed report: $(cat "$work/err")"

"$dembuf" run "${scene[@]}" --set bed.import="$work/resting.txt" --no-bed-cache --out "$work/resting" \
  > /dev/null 2> "$work/err" || fail "the resting bed: $(cat "$work/err")"
grep -q "imported bed: 89 beads (text file); resting on the plate: 89 beads, overlap at most 0.015% of a radius" \
  "$work/err" || fail "no overlap report: $(cat "$work/err")"
grep -q '"imported": "89 beads (text file); resting on the plate: 89 beads' "$work/resting/summary.json" ||
  fail "no overlap report in summary.json"

code=0
"$dembuf" run "${scene[@]}" --set bed.import="$work/sunk.txt" --no-bed-cache --out "$work/sunk" \
  > /dev/null 2> "$work/err" || code=$?
[ "$code" = 2 ] || fail "a bed 10% into the plate: exit $code: $(cat "$work/err")"
grep -q "sunk.txt:1: the bead sinks into the plate by 10% of its radius" "$work/err" || fail "$(cat "$work/err")"
"$dembuf" run "${scene[@]}" --set bed.import="$work/sunk.txt" --set bed.import_overlaps=relax \
  --no-bed-cache --out "$work/relaxed" > /dev/null 2> "$work/err" || fail "relax: $(cat "$work/err")"
grep -q "separated: 89 beads moved" "$work/err" || fail "no separation report: $(cat "$work/err")"
echo "imports test passed"
