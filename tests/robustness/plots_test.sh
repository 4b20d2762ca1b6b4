#!/usr/bin/env bash
# Item 5 of the robustness suite (docs/robustness.md): plots as data, never code.
# - A snapshot folder named  x'; system "touch PWNED"; set title 'y  ran the command when
#   `dembuf plot` wrote its name into a gnuplot script; so did a CSV header and a peak's label
#   in summary.json. Now every string reaches gnuplot as a quoted literal and gnuplot runs
#   without a shell: the plots are drawn and nothing else runs.
# - A server's names are checked: a sweep whose axis is no scene field is refused by fetch.
# - The scripts named their files by dembuf's working folder: now by their own, so they run
#   again from it, drawing each figure as PNG and SVG.
# - fetch does not overwrite a folder without --force; a failed `run --force` leaves no
#   summary.json of the run before; a bare-plate run with snapshots plots without error.
# Usage: plots_test.sh DEMBUF DEMBUFD
. "$(dirname "$0")/lib.sh" "$1" "$2"
command -v gnuplot > /dev/null || { echo "plots test skipped: no gnuplot"; exit 0; }
cd "$work"  # a command run by gnuplot would write PWNED here
hostile="x'; system \"touch PWNED\"; set title 'y"
pwned() { [ ! -e "$work/PWNED" ] || fail "a command in $1 ran"; }

# --- a snapshot folder's name --------------------------------------------------------------
small_scene "$work/small.toml"
"$dembuf" run "$work/small.toml" --set output.snapshot_at_peak=true --no-bed-cache --out "$work/run" \
  > "$work/run.log" 2>&1 || fail "the run with a snapshot: $(tail -3 "$work/run.log")"
# F(t)'s title says the bed and P as the report rounds them (it said "0.999 cm" where the
# report said 1.00 cm).
reported_h=$(sed -n 's/^bed H = \([0-9.]*\) cm.*/\1/p' "$work/run.log")
reported_p=$(sed -n 's/^P = \([0-9.e+]*\) N.*/\1/p' "$work/run.log")
title_p=$(awk -v p="$reported_p" 'BEGIN { printf "%.4g", p / 1000 }')
grep -q "^set title 'impact on a $reported_h cm bed: P = $title_p kN" "$work/run/plate_force.gp" ||
  fail "F(t)'s title (H $reported_h cm, P $title_p kN in the report): $(grep '^set title' "$work/run/plate_force.gp")"
# The projectile in the bed: its speed and depth, the peaks' times marked.
[ -s "$work/run/projectile.png" ] && grep -q "set label 'Pa'" "$work/run/projectile.gp" ||
  fail "no projectile plot with the peaks: $(ls "$work/run")"
mv "$work/run/snapshots/peak" "$work/run/snapshots/$hostile"
"$dembuf" plot "$work/run" > "$work/plot.txt" 2>&1 || fail "plot: $(cat "$work/plot.txt")"
pwned "a snapshot folder's name"
[ -s "$work/run/snapshots/$hostile/force_chains.png" ] || fail "no force chains drawn"
[ -s "$work/run/snapshots/$hostile/plate_map.png" ] || fail "no plate map drawn"
grep -q "set logscale xy" "$work/run/snapshots/$hostile/force_pdf.gp" || fail "the force PDF is not log-log"
# (The name reaches gnuplot as the folder it runs in: the script names its files from there.)
grep -q "^set output 'force_chains.png'" "$work/run/snapshots/$hostile/force_chains.gp" ||
  fail "the script does not name its files from its own folder"

# --- a peak's label in summary.json --------------------------------------------------------
sed -i "s/\"kind\": \"Pa\"/\"kind\": \"$(printf '%s' "$hostile" | sed 's/"/\\\\"/g')\\\\n!touch PWNED\"/" \
  "$work/run/summary.json"
grep -q 'touch PWNED' "$work/run/summary.json" || fail "the test did not plant the label"
"$dembuf" plot "$work/run" > "$work/plot.txt" 2>&1 || fail "plot: $(cat "$work/plot.txt")"
pwned "a peak's label"

# --- a CSV header -------------------------------------------------------------------------
"$dembuf" sweep --set bed.thickness_m=0 --vary projectile.speed_m_s=1,2 --no-bed-cache \
  --out "$work/sweep" > /dev/null 2>&1 || fail "the sweep"
sed -i "1s/^projectile.speed_m_s/$hostile/" "$work/sweep/points.csv"
mv "$work/sweep/runs/000_speed_m_s=1_seed=1" "$work/sweep/runs/000_$hostile"
"$dembuf" plot "$work/sweep" > "$work/plot.txt" 2>&1 || fail "plot: $(cat "$work/plot.txt")"
pwned "a CSV header or a run folder's name"
[ -s "$work/sweep/sweep_peaks.png" ] || fail "no sweep plot drawn"

# --- the scripts draw again from their own folder (they named files by dembuf's working
# folder: "cannot open file"), each figure as PNG and SVG ----------------------------------
rm "$work/sweep/sweep_peaks.png" "$work/sweep/sweep_peaks.svg"
(cd "$work/sweep" && gnuplot sweep.gp) > "$work/again.txt" 2>&1 || fail "sweep.gp: $(cat "$work/again.txt")"
[ -s "$work/sweep/sweep_peaks.png" ] && grep -q "<svg" "$work/sweep/sweep_peaks.svg" ||
  fail "sweep.gp run again drew no PNG and SVG"
(cd "$work/run/snapshots/$hostile" && gnuplot force_chains.gp) > "$work/again.txt" 2>&1 ||
  fail "force_chains.gp: $(cat "$work/again.txt")"
pwned "a script run again from its folder"

# --- a bare-plate run with a snapshot: no bead contacts, still plotted --------------------
"$dembuf" run --set output.snapshot_at_peak=true --out "$work/bare" > "$work/bare.log" 2>&1 ||
  fail "bare-plate run: $(cat "$work/bare.log")"
grep -q "^plots: [0-9]* PNG files" "$work/bare.log" || fail "bare-plate plots: $(cat "$work/bare.log")"
"$dembuf" plot "$work/bare" > /dev/null || fail "dembuf plot of a bare-plate run"

# --- a failed run --force leaves no results of the run before ---------------------------
[ -e "$work/run/summary.json" ] || fail "no run to replace"
code=0
"$dembuf" run "$work/small.toml" --set bed.max_settle_s=0.001 --no-bed-cache --force \
  --out "$work/run" > /dev/null 2> "$work/err" || code=$?
[ "$code" = 3 ] || fail "a bed that cannot settle exited $code: $(cat "$work/err")"
[ -e "$work/run/failure.json" ] || fail "no failure.json"
for f in summary.json plate_force.csv plate_force.png plate_force.svg snapshots; do
  [ ! -e "$work/run/$f" ] || fail "the failed run left $f of the run before"
done

# --- fetch: a tampered server's names; no overwrite without --force -------------------------
start_daemon "$work/dembuf.db" "$work/dembufd.log"
job=$("$dembuf" submit 2>/dev/null)
sweep=$("$dembuf" sweep --vary projectile.speed_m_s=1,2 2>/dev/null)
wait_state "$job" done 60
for _ in $(seq 300); do "$dembuf" status --sweep "$sweep" | grep -q "done 2$" && break; sleep 0.1; done
"$dembuf" fetch "$job" --out "$work/fetched" --no-plots > /dev/null || fail "fetch"
if "$dembuf" fetch "$job" --out "$work/fetched" --no-plots > /dev/null 2> "$work/err"; then
  fail "fetch overwrote a folder"
fi
grep -q "already exists.*--force" "$work/err" || fail "overwrite: $(cat "$work/err")"
"$dembuf" fetch "$job" --out "$work/fetched" --force --no-plots > /dev/null || fail "fetch --force"
stop_daemon
python3 - "$work/dembuf.db" "$hostile" <<'PY'
import json, sqlite3, sys
db = sqlite3.connect(sys.argv[1])
db.execute("UPDATE sweeps SET axes_json = ?", (json.dumps([{"field": sys.argv[2], "values": ["1", "2"]}]),))
db.commit()
PY
start_daemon "$work/dembuf.db" "$work/dembufd.log"
if "$dembuf" fetch --sweep "$sweep" --out "$work/tampered" > "$work/out" 2> "$work/err"; then
  fail "fetched a sweep whose axis is no scene field"
fi
grep -q "the server sent a sweep axis that is no scene field" "$work/err" || fail "tampered: $(cat "$work/err")"
pwned "a server's axis name"
stop_daemon
echo "plots test passed"
