#!/usr/bin/env bash
# Regenerates docs/gallery: dembuf's figure for each figure of the paper, from the runs and
# sweeps that make them, with the model as written (no preset variant). One seed, the default
# accuracy. Runs go to RUNS (default runs/gallery) and are kept: a second call draws again
# from them and runs only what is missing. Beds come from the bed cache as any run's do.
#
#   bash docs/gallery/make_gallery.sh [--runs RUNS] [--dembuf PATH] [--all]
#
# Without --all: the paper's E1 (Figs. 2-3), E2 (Figs. 1, 4-8) and E5 (Figs. 13-14, 16 at
# H = 7 cm): about 15 minutes on 2 cores from an empty bed cache. --all adds E3 and E4
# (Figs. 9-12, 15, 16), whose beds take hours: every bead friction of E3 and every packing
# of E4 settles a bed of its own (docs/reproduction.md gives the times).
set -eu
here=$(cd "$(dirname "$0")" && pwd)
runs=runs/gallery
dembuf=${DEMBUF:-dembuf}
all=0
while [ $# -gt 0 ]; do
  case $1 in
    --runs) runs=$2; shift 2 ;;
    --dembuf) dembuf=$2; shift 2 ;;
    --all) all=1; shift ;;
    *) echo "usage: make_gallery.sh [--runs RUNS] [--dembuf PATH] [--all]" >&2; exit 2 ;;
  esac
done
command -v "$dembuf" > /dev/null || { echo "make_gallery.sh: no $dembuf (give --dembuf)" >&2; exit 2; }
mkdir -p "$runs"

# sweep NAME ARGS...: a local sweep into RUNS/NAME, unless it finished there before.
sweep() {
  local name=$1
  shift
  [ -f "$runs/$name/sweep.csv" ] && return 0
  echo "== $name: dembuf sweep $*" >&2
  rm -rf "${runs:?}/$name"  # an unfinished sweep starts afresh
  "$dembuf" sweep --local --yes "$@" --out "$runs/$name" > /dev/null
}
# run NAME ARGS...: one run into RUNS/NAME, unless it finished there before.
run() {
  local name=$1
  shift
  [ -f "$runs/$name/summary.json" ] && return 0
  echo "== $name: dembuf run $*" >&2
  "$dembuf" run --yes "$@" --out "$runs/$name" --force > /dev/null
}
# figure SOURCE NAME: copies a drawn figure into the gallery under its paper figure's name.
figure() {
  [ -f "$1" ] || { echo "make_gallery.sh: $1 was not drawn" >&2; exit 1; }
  cp "$1" "$here/$2"
}
# run_of SWEEP NAME=VALUE: the folder of the sweep's run at that point (seed 1), its figures
# drawn; NAME is the field's last part, as the run folders are named.
run_of() {
  local found
  found=$(find "$runs/$1/runs" -maxdepth 1 -type d -name "*_$2_seed=1" | head -1)
  [ -n "$found" ] || { echo "make_gallery.sh: no run $2 in $runs/$1" >&2; exit 1; }
  # A sweep draws its own figures, not its runs': those are drawn here.
  "$dembuf" plot "$found" > /dev/null
  echo "$found"
}

# E1: Table 1's projectile (0.167 kg from 0.5 m) on 0 to 4 cm (the paper's Figs. 2-3 compare
# its test with its DEM there).
sweep e1 --preset e1 --vary bed.thickness_m=0,0.005,0.01,0.02,0.04
# E2: the thickness study, 0 to 8 cm.
sweep e2 --preset e2 --vary bed.thickness_m=0:0.08:0.005
"$dembuf" compare "$runs/e2" > "$runs/e2-compare.txt"
# E5: force chains on 7 cm (snapshots after contact and at the peak), and at the peak on 3 and
# 5 cm (the paper's Fig. 14), the bed at rest at t = 0 (Fig. 1).
run e5 --preset e5
sweep e5-thickness --preset e2 --set output.snapshot_at_peak=true \
  --vary bed.thickness_m=0.03,0.05
run bed-at-rest --preset e2 --set output.snapshot_times_s=0

# Drawn again by this dembuf, so that the gallery shows how it draws now.
for folder in e1 e2 e5 e5-thickness bed-at-rest; do "$dembuf" plot "$runs/$folder" > /dev/null; done
figure "$runs/bed-at-rest/snapshots/t_0ms/force_chains.png" fig01_bed_at_rest.png
figure "$(run_of e1 thickness_m=0.005)/plate_force.png" fig02a_e1_H0.5cm.png
figure "$(run_of e1 thickness_m=0.04)/plate_force.png" fig02b_e1_H4cm.png
figure "$runs/e1/sweep_peaks.png" fig03_e1_peaks.png
figure "$(run_of e2 thickness_m=0)/plate_force.png" fig04_e2_bare_plate.png
figure "$(run_of e2 thickness_m=0.01)/plate_force.png" fig05b_e2_H1cm.png
figure "$(run_of e2 thickness_m=0.03)/plate_force.png" fig05c_e2_H3cm.png
figure "$runs/e2/sweep_peaks.png" fig06a_e2_peaks.png
figure "$runs/e2/compare.png" fig06b_e2_beside_the_paper.png
figure "$runs/e2/sweep_ds_dt.png" fig07_e2_ds_dt.png
figure "$runs/e2/sweep_curves.png" fig08_e2_curves.png
for t in 0.5 1 3 6; do
  figure "$runs/e5/snapshots/after_contact_${t}ms/force_chains.png" "fig13_e5_chains_${t}ms.png"
done
figure "$runs/e5/snapshots/peak/force_chains.png" fig14c_e5_chains_peak_H7cm.png
figure "$runs/e5/snapshots/peak/plate_map.png" fig14c_e5_plate_map_H7cm.png
for h in 3 5; do
  folder=$(run_of e5-thickness "thickness_m=0.0$h")
  figure "$folder/snapshots/peak/force_chains.png" "fig14_e2_chains_peak_H${h}cm.png"
  figure "$folder/snapshots/peak/plate_map.png" "fig14_e2_plate_map_H${h}cm.png"
done
figure "$runs/e5/snapshots/peak/force_pdf.png" fig16_e5_force_pdf.png

if [ "$all" = 1 ]; then
  # E3: bead friction changed after settling; E4: packing through the settling friction.
  sweep e3 --preset e3 --set bed.friction_settle_tolerance=1e-3 --set output.snapshot_at_peak=true \
    --vary material.friction_bead_bead=0,0.5,1.0
  sweep e4 --preset e4 --set output.snapshot_at_peak=true --vary bed.prep_friction=1.0,0.5,0.1
  figure "$runs/e3/sweep_peaks.png" fig09a_e3_peaks.png
  figure "$runs/e3/sweep_crater.png" fig09b_e3_crater.png
  figure "$runs/e3/sweep_curves.png" fig10_e3_curves.png
  figure "$runs/e4/sweep_peaks.png" fig11a_e4_peaks.png
  figure "$runs/e4/sweep_crater.png" fig11b_e4_crater.png
  figure "$runs/e4/sweep_curves.png" fig12_e4_curves.png
  for mu in 0 0.5 1.0; do
    folder=$(run_of e3 "friction_bead_bead=$mu")
    figure "$folder/snapshots/peak/force_chains.png" "fig15a_e3_chains_mu$mu.png"
    figure "$folder/snapshots/peak/force_pdf.png" "fig16a_e3_force_pdf_mu$mu.png"
  done
fi
echo "docs/gallery: figures from $runs" >&2
