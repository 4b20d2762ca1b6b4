#!/usr/bin/env bash
# The local run's files and options: plate_force.csv and summary.json with the contracted
# names, no silent overwrite, and `scene --print` output that reads back.
# Usage: local_run.sh DEMBUF_BINARY
set -eu
dembuf=$1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }

e2=(--set projectile.mass_kg=0.3 --set projectile.speed_m_s=5 --set projectile.height_m=0.3)
"$dembuf" run "${e2[@]}" --out "$work/run" > "$work/stdout"
[ -f "$work/run/plate_force.csv" ] || fail "no plate_force.csv"
[ -f "$work/run/summary.json" ] || fail "no summary.json"
[ ! -e "$work/run/plate_force.csv.partial" ] || fail "partial file left behind"
head -1 "$work/run/plate_force.csv" | grep -q '^t_s,plate_force_N,' || fail "CSV header"
for key in peak_plate_force_N peak_plate_force_time_s beads dt_s steps wall_time_s A_s e_at_vref; do
  grep -q "\"$key\"" "$work/run/summary.json" || fail "summary.json lacks $key"
done
# The peak in the summary is the paper's 13.46 kN within 2%.
peak=$(sed -n 's/.*"peak_plate_force_N": \([0-9.e+-]*\).*/\1/p' "$work/run/summary.json")
awk -v p="$peak" 'BEGIN { exit !(p > 13190.8 && p < 13729.2) }' || fail "peak $peak N"
# The largest sample in the CSV is close to the peak (samples every 10 us over a 450 us pulse).
csv_peak=$(awk -F, 'NR > 1 && $2 > m { m = $2 } END { print m }' "$work/run/plate_force.csv")
awk -v c="$csv_peak" -v p="$peak" 'BEGIN { exit !(c <= p && c > 0.98 * p) }' || fail "CSV peak $csv_peak vs $peak"

# Progress to a log file (stderr not a terminal): plain lines, none redrawn in place, of the
# bed's settling and of the impact with the percentage, the rate and the time left, then a
# last line (here every 0.1 s; the engine tests' small bed from an empty cache, and a fine
# step so that the impact lasts about a second).
small_bed=(--set cylinder.radius_m=0.02 --set bed.thickness_m=0.01 --set bed.source_thickness_m=0.015
           --set projectile.diameter_m=0.012 --set projectile.mass_kg=0.01
           --set projectile.speed_m_s=2 --set projectile.height_m=0.02 --set time.alpha=0.05)
DEMBUF_PROGRESS_S=0.1 "$dembuf" run "${small_bed[@]}" --bed-cache "$work/beds" --no-plots \
  --out "$work/logged" > /dev/null 2> "$work/progress.log" || fail "logged run"
if grep -q $'\r' "$work/progress.log"; then fail "progress redrawn in a log file"; fi
grep -Eq '^settling( \([a-z ]+\))*: [0-9]+ beads, t = [0-9.]+ ms, kinetic' "$work/progress.log" ||
  { cat "$work/progress.log"; fail "no settling line in the log"; }
# (A line before the end, below 100%; the time left is known after half a second.)
grep -Eq '^impact: +[0-9]{1,2}%, [0-9.]+ of [0-9.]+ ms \(at most\), [0-9]+ steps, [0-9.e+]+ steps/s, ([0-9]+:[0-9]{2}|--:--) left' \
  "$work/progress.log" || { cat "$work/progress.log"; fail "no impact line in the log"; }
tail -1 "$work/progress.log" | grep -Eq '^impact: ended at [0-9.]+ ms, [0-9]+ steps in [0-9]+:[0-9]{2}$' ||
  { cat "$work/progress.log"; fail "no last progress line"; }

# Provenance: the run's folder holds its resolved scene (which reads back, and whose SHA-256
# the summary gives), and summary.json says what built the program, what it ran on (the
# bed's SHA-256: the same for a second run on the cached bed), where, when, on how many
# threads, and the command, which the shell reads back into the same arguments.
"$dembuf" scene --print "$work/logged/scene.toml" | cmp -s - "$work/logged/scene.toml" ||
  fail "scene.toml does not read back"
odd_out="$work/it's a "$'folder\twith a tab'
"$dembuf" run "${small_bed[@]}" --bed-cache "$work/beds" --no-plots --out "$odd_out" \
  > /dev/null 2>&1 || fail "second run on the cached bed"
python3 - "$work/logged" "$odd_out" "$(hostname)" <<'PY' || fail "provenance"
import hashlib, json, re, sys
first, second, host = sys.argv[1:]
p = json.load(open(f"{first}/summary.json"))["provenance"]
q = json.load(open(f"{second}/summary.json"))["provenance"]
scene = open(f"{first}/scene.toml", "rb").read()
assert p["scene_sha256"] == hashlib.sha256(scene).hexdigest(), p
assert re.fullmatch(r"[0-9a-f]{64}", p["bed_sha256"]) and p["bed_sha256"] == q["bed_sha256"], (p, q)
assert re.fullmatch(r"([0-9a-f]{40}(-dirty-[0-9a-f]{12})?|unknown)", p["build_commit"]), p
assert p["build_type"] and p["dembuf_version"] and p["threads"] >= 1 and p["seed"] == 1, p
assert p["host"] == host, (p["host"], host)
iso = r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ"
assert re.fullmatch(iso, p["started_at"]) and p["started_at"] <= p["finished_at"], p
assert "--out " in p["command_line"] and "time.alpha=0.05" in p["command_line"], p
open(f"{second}/../command_line", "w").write(q["command_line"])
PY
eval "words=($(cat "$work/command_line"))"
[ "${words[-1]}" = "$odd_out" ] && [ "${words[1]}" = run ] || fail "command line does not read back: ${words[*]}"

# A second run into the same folder is refused unless --force.
if "$dembuf" run "${e2[@]}" --out "$work/run" 2>/dev/null; then fail "overwrote without --force"; fi
"$dembuf" run "${e2[@]}" --out "$work/run" --force > /dev/null || fail "--force"

# An accuracy level sets its knobs; --set still wins.
"$dembuf" scene --print --accuracy reference | grep -q '^alpha = 0.05 ' || fail "accuracy reference"
"$dembuf" scene --print --accuracy draft --set time.alpha=0.3 | grep -q '^alpha = 0.3 ' || fail "--set after --accuracy"

# scene --print gives the whole scene, and reads back to the same text.
"$dembuf" scene --print "${e2[@]}" > "$work/scene.toml"
grep -q '^mass_kg = 0.3 ' "$work/scene.toml" || fail "printed scene lacks the override"
"$dembuf" scene --print "$work/scene.toml" > "$work/again.toml"
cmp -s "$work/scene.toml" "$work/again.toml" || fail "printed scene does not read back"
# Each field's line ends with what it shapes, the earliest stage a change of it computes again.
"$dembuf" scene --list fields > "$work/fields"
shapes() { awk -F'\t' -v f="$1" '$1 == f { print $5 }' "$work/fields"; }
[ "$(shapes material.density_kg_m3)" = "source bed" ] || fail "density shapes '$(shapes material.density_kg_m3)'"
[ "$(shapes bed.thickness_m)" = "cut bed" ] || fail "thickness shapes '$(shapes bed.thickness_m)'"
[ "$(shapes bed.cut)" = "every cut" ] || fail "bed.cut shapes '$(shapes bed.cut)'"
[ "$(shapes projectile.speed_m_s)" = "impact" ] || fail "speed shapes '$(shapes projectile.speed_m_s)'"
awk -F'\t' 'NF != 5 { print; bad = 1 } END { exit bad }' "$work/fields" || fail "a field's line lacks a column"
# A preset gives the paper's scene; an unknown one is refused naming the preset field.
"$dembuf" scene --print --preset e2 | grep -q '^speed_m_s = 5.0 ' || fail "preset e2 speed"
if "$dembuf" scene --preset e9 2>"$work/err"; then fail "unknown preset accepted"; fi
grep -q 'preset: unknown preset' "$work/err" || fail "unknown preset message: $(cat "$work/err")"

# A sweep over two projectile speeds on the bare plate (no bed to prepare): one CSV row per
# run, a point per speed, and a second invocation keeps the finished runs.
"$dembuf" sweep --preset e2 --set bed.thickness_m=0 --vary projectile.speed_m_s=2,5 \
  --out "$work/sweep" --no-bed-cache > "$work/sweep.log" || fail "sweep: $(cat "$work/sweep.log")"
[ "$(wc -l < "$work/sweep/sweep.csv")" -eq 3 ] || fail "sweep.csv rows"
[ "$(wc -l < "$work/sweep/points.csv")" -eq 3 ] || fail "points.csv rows"
grep -q '"points"' "$work/sweep/summary.json" || fail "sweep summary"
# The faster impact hits harder: P at 5 m/s above P at 2 m/s.
awk -F, 'NR == 2 { p2 = $6 } NR == 3 { p5 = $6 } END { exit !(p5 > p2) }' "$work/sweep/sweep.csv" \
  || fail "P does not grow with speed: $(cat "$work/sweep/sweep.csv")"
"$dembuf" sweep --preset e2 --set bed.thickness_m=0 --vary projectile.speed_m_s=2,5 \
  --out "$work/sweep" --no-bed-cache > "$work/again.log"
[ "$(grep -c 'done earlier, kept' "$work/again.log")" -eq 2 ] || fail "resume: $(cat "$work/again.log")"
# The plots of a thickness sweep in which no run has two peaks (here the bare plate alone):
# the plots without data are left out instead of failing the plotting.
if command -v gnuplot > /dev/null; then
  "$dembuf" sweep --preset e2 --vary bed.thickness_m=0 --out "$work/bare" --no-bed-cache \
    > "$work/bare.log" || fail "bare-plate sweep: $(cat "$work/bare.log")"
  grep -q '^plots: 4 PNG files' "$work/bare.log" || fail "bare-plate plots: $(cat "$work/bare.log")"
  [ ! -e "$work/bare/sweep_ds_dt.png" ] || fail "a dS and dt plot without data"
fi
# dembuf compare: E2 on the bare plate beside the paper's Pa0 = 13.46 kN (dembuf: 13.38 kN),
# and the speed sweep, which is not the paper's scene, with no paper numbers.
"$dembuf" run --preset e2 --set bed.thickness_m=0 --no-plots --out "$work/e2-bare" > /dev/null 2>&1
"$dembuf" compare "$work/e2-bare" --no-plots > "$work/compare.log" || fail "compare"
awk -F, '$1 == "P_N" && $2 == 0 { found = 1; dev = $10 < 0 ? -$10 : $10 }
         END { exit !(found && dev < 0.02) }' "$work/e2-bare/compare.csv" \
  || fail "bare-plate Pa0 against the paper: $(cat "$work/e2-bare/compare.csv")"
# The points compare.png draws carry what lies between the peaks (dS, dt, Pb), for the panels
# beside the paper's fits; a bare plate has none of them (empty, not 0).
head -1 "$work/e2-bare/compare_points.csv" | grep -q "^H_m,P_N,P_N_sd,lambda,lambda_sd,dS_m,dS_m_sd,dt_peaks_s,dt_peaks_s_sd,Pb_N,Pb_N_sd,n$" ||
  fail "compare_points.csv: $(head -1 "$work/e2-bare/compare_points.csv")"
grep -q "^0,[0-9.]*,,0.000000,,,,,,,,1$" "$work/e2-bare/compare_points.csv" ||
  fail "a bare plate's points: $(tail -1 "$work/e2-bare/compare_points.csv")"
# A variant of E2 (here the bare plate with local damping, which a bare plate does not feel) is
# compared with the paper, named in the table and in the figure's title.
"$dembuf" run --preset e2-local-damping --set bed.thickness_m=0 --no-plots --out "$work/e2-variant" \
  > /dev/null 2>&1 || fail "the variant preset"
"$dembuf" compare "$work/e2-variant" > "$work/compare.log" || fail "compare of a variant"
grep -q "^E2 with what the paper does not state: damping.local_alpha = 0.12$" "$work/compare.log" ||
  fail "a variant of E2: $(cat "$work/compare.log")"
if command -v gnuplot > /dev/null; then
  grep -q "title 'dembuf, E2 with damping.local_alpha = 0.12 (not the paper''s stated model)" \
    "$work/e2-variant/compare.gp" || fail "the variant's figure: $(grep multiplot "$work/e2-variant/compare.gp")"
fi
# The same run in two folders (given twice here) counts once, and says so.
"$dembuf" compare "$work/e2-bare" "$work/e2-bare" --no-plots --out "$work/twice" \
  > "$work/compare.log" || fail "compare twice"
grep -q "^1 runs beside the paper (1 more found twice, the same scene and bed, counted once" \
  "$work/compare.log" || fail "a run given twice: $(cat "$work/compare.log")"
"$dembuf" compare "$work/sweep" --no-plots > "$work/compare.log" || fail "compare of a sweep"
grep -q "no paper numbers.*projectile.speed_m_s" "$work/compare.log" \
  || fail "a sweep of another scene: $(cat "$work/compare.log")"
# A bad --vary is refused before anything runs.
if "$dembuf" sweep --vary projectile.mass_kg=1:0:1 --out "$work/bad" 2>"$work/err"; then
  fail "bad range accepted"
fi
grep -q 'projectile.mass_kg' "$work/err" || fail "bad range message: $(cat "$work/err")"
[ ! -e "$work/bad" ] || fail "bad sweep created its folder"
# A snapshot's contact-force PDF (bead pairs, f over the mean force): it integrates to 1 and
# its last bin holds the largest bead-pair force of contacts.csv (no tail folded into an edge
# bin; contacts with the projectile, plate or wall are named and left out).
"$dembuf" run --set cylinder.radius_m=0.02 --set bed.thickness_m=0.01 \
  --set bed.source_thickness_m=0.015 --set projectile.diameter_m=0.012 \
  --set projectile.mass_kg=0.01 --set projectile.height_m=0.02 --set output.snapshot_at_peak=true \
  --no-bed-cache --out "$work/snap" > /dev/null || fail "snapshot run"
snap=$work/snap/snapshots/peak
awk -F, 'NR > 1 { area += $2 * 0.1 } END { exit !(area > 0.999 && area < 1.001) }' \
  "$snap/force_pdf.csv" || fail "the force PDF does not integrate to 1"
awk -F, 'NR == FNR { if (FNR > 1 && $1 ~ /^[0-9]+$/ && $2 ~ /^[0-9]+$/ && $9 > 0) { n++; sum += $9; if ($9 > max) max = $9 }; next }
         FNR > 1 { last = $1; count = $3 }
         END { x = max / (sum / n); exit !(count > 0 && x >= last - 0.05 && x < last + 0.05) }' \
  "$snap/contacts.csv" "$snap/force_pdf.csv" || fail "the PDF's last bin is not the largest force"
# Hc by bisection on the small bed (one seed): the search's runs are a sweep's, and
# summary.json gives Hc inside the final bracket, with the steps taken, where P levels off (the
# upper half's start within 10% of the plateau), else no Hc and the note, as the grid rule.
small=(--set cylinder.radius_m=0.02 --set bed.source_thickness_m=0.015
       --set projectile.diameter_m=0.012 --set projectile.mass_kg=0.01 --set projectile.height_m=0.02
       --set projectile.speed_m_s=2)
"$dembuf" sweep "${small[@]}" --find-hc 0.004:0.01:0.002 --bed-cache "$work/beds" \
  --out "$work/hc" > "$work/hc.log" 2>&1 || fail "find-hc: $(tail -5 "$work/hc.log")"
python3 - "$work/hc/summary.json" > "$work/hc.check" <<'PY' || fail "find-hc summary"
import json, sys
hc = json.load(open(sys.argv[1]))["critical_thickness"]
low, high = hc["bracket_m"]
assert hc["method"] == "bisection" and low <= hc["search_ended_m"] <= high, hc
assert high - low <= 0.002 and (hc["Hc_sd_m"] > 0 if hc["reached"] else hc["Hc_sd_m"] is None), hc
assert len(hc["steps"]) == 2 + 2, hc["steps"]  # the ends, then 6 mm halved twice
upper_start = hc["steps"][2]["mean_P_N"] / hc["plateau_P_N"] - 1  # the first midpoint, 7 mm
assert hc["reached"] == (abs(upper_start) <= 0.10), hc
assert abs(hc["upper_half_change"] + upper_start) < 1e-12, hc  # signed: negative, P falls
assert hc["Hc_m"] == (hc["search_ended_m"] if hc["reached"] else None), hc
assert hc["reached"] or hc["note"].startswith("Hc not reached in 0.4-1 cm (P still falls"), hc
print("reached" if hc["reached"] else "not reached")
PY
# The terminal says the same: Hc where it was reached, else why not.
if [ "$(cat "$work/hc.check")" = reached ]; then
  grep -q "^Hc = " "$work/hc.log" || fail "find-hc printed no Hc"
else
  grep -q "^Hc not reached in 0.4-1 cm" "$work/hc.log" || fail "find-hc printed no reason"
fi
if "$dembuf" sweep --find-hc 0.004:0.01 --vary projectile.mass_kg=1,2 2> "$work/err"; then
  fail "--find-hc with --vary"
fi
grep -q -- "--find-hc" "$work/err" || fail "find-hc with vary: $(cat "$work/err")"
echo "1 passed, 0 failed"
