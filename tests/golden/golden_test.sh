#!/usr/bin/env bash
# Golden outputs: short runs of the five paper presets, at 1 and at 2 threads, must give the
# stored summary.json, plate_force.csv and snapshot files bit for bit. They freeze what users
# get, so that moving code around changes nothing unnoticed.
#
# The runs are the presets on a small cylinder (9 cm across, a 2.5 cm source bed cut to
# 1.8 cm: over a thousand beads, so the parallel force pass runs) hit by a smaller sphere; e3
# changes the friction after settling, e4 settles with another friction, e5 writes snapshots
# (one after contact and one at the peak).
# Only the computing time, the version and where, when and how the run was made are left out
# of the comparison.
#
# Usage: golden_test.sh DEMBUF_BINARY GOLDEN_DIR [THREADS [PRESET...]]
#   (THREADS default 1, PRESET default all five)
# With DEMBUF_UPDATE_GOLDEN=1 and one thread it writes GOLDEN_DIR instead; say why in the
# commit.
set -eu
dembuf=$1
golden=$2
threads=${3:-1}
shift $(($# < 3 ? $# : 3))
presets=("$@")
[ ${#presets[@]} -gt 0 ] || presets=(e1 e2 e3 e4 e5)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }

small=(--set cylinder.radius_m=0.045 --set bed.source_thickness_m=0.025
       --set bed.thickness_m=0.018 --set projectile.diameter_m=0.025
       --set projectile.mass_kg=0.03 --set projectile.height_m=0.05
       --set time.impact_window_s=0.01 --set time.output_interval_s=2e-5)
declare -A extra=(
  [e1]=""
  [e2]=""
  [e3]="--set material.friction_bead_bead=0.2"
  [e4]="--set bed.prep_friction=0.2"
  [e5]="--set output.snapshot_after_contact_s=0.001"
)

# The files compared: every output but the plots; summary.json without the fields that
# differ from run to run.
comparable() {
  # plots aside, and log.txt (where and when it ran; its warnings are summary.json's)
  (cd "$1" && find . -type f ! -name '*.png' ! -name '*.svg' ! -name '*.gp' ! -name log.txt | LC_ALL=C sort)
}
normalise_summary() {
  python3 -c '
import json, sys
summary = json.load(open(sys.argv[1]))
for key in ("wall_time_s", "dembuf_version"):
    summary.pop(key, None)
# Of the provenance, what names the contents of the run (scene, bed and seed) stays.
for key in ("dembuf_version", "build_commit", "build_config", "libc", "threads", "host", "started_at", "finished_at",
            "command_line", "timeline"):
    summary["provenance"].pop(key, None)
json.dump(summary, sys.stdout, indent=1, sort_keys=True)
print()' "$1"
}

cache="$work/beds"
for preset in "${presets[@]}"; do
  out="$work/$threads/$preset"
  # shellcheck disable=SC2086  # extra holds whole arguments
  OMP_NUM_THREADS=$threads "$dembuf" run --preset "$preset" "${small[@]}" ${extra[$preset]} \
    --bed-cache "$cache" --out "$out" > "$work/log" 2>&1 || { cat "$work/log"; fail "$preset"; }
  normalise_summary "$out/summary.json" > "$out/summary.normal.json"
  rm "$out/summary.json"
  if [ "${DEMBUF_UPDATE_GOLDEN:-0}" = 1 ]; then
    [ "$threads" = 1 ] || fail "the golden outputs are written from one thread"
    rm -rf "${golden:?}/$preset"
    mkdir -p "$golden/$preset"
    comparable "$out" | while read -r file; do
      mkdir -p "$golden/$preset/$(dirname "$file")"
      cp "$out/$file" "$golden/$preset/$file"
    done
    continue
  fi
  [ -d "$golden/$preset" ] || fail "no golden outputs for $preset in $golden"
  if [ "$(comparable "$out")" != "$(comparable "$golden/$preset")" ]; then
    diff <(comparable "$golden/$preset") <(comparable "$out") || true
    fail "$preset at $threads threads: other files than the golden ones"
  fi
  while read -r file; do
    cmp -s "$golden/$preset/$file" "$out/$file" || {
      diff "$golden/$preset/$file" "$out/$file" | head -20
      fail "$preset at $threads threads: $file differs from the golden one"
    }
  done < <(comparable "$out")
  echo "$preset at $threads threads: $(comparable "$out" | wc -l) files identical"
done
if [ "${DEMBUF_UPDATE_GOLDEN:-0}" = 1 ]; then echo "wrote $golden"; fi
