#!/usr/bin/env bash
# Item 10 of the robustness suite (docs/robustness.md): sweeps and tokens.
# - A field varied twice ran, labelling the results of one axis with the other's values: now
#   refused, locally and by the daemon. A value given twice (1 and 1.0) is refused too.
# - Range values were rounded to 12 digits, which made distinct points one: now each value
#   keeps the digits that tell it from its neighbours.
# - Token names of no character or of thousands were accepted: now 1 to 64 of [A-Za-z0-9._-].
# - An admin's jobs were filed under the $USER of the admin's machine: now under the token's
#   user, unless the admin names another owner.
# - A sweep's progress went to stdout every 30 s whatever DEMBUF_PROGRESS_S said: now stderr.
# Usage: sweeps_test.sh DEMBUF DEMBUFD
. "$(dirname "$0")/lib.sh" "$1" "$2"

bare=(--set bed.thickness_m=0)
expect_exit 2 "projectile.speed_m_s: varied twice" "$dembuf" sweep "${bare[@]}" \
  --vary projectile.speed_m_s=1,2 --vary projectile.speed_m_s=3,4 --out "$work/twice"
[ ! -e "$work/twice" ] || fail "a refused sweep created its folder"
# The seeds rule, one for every door (SweepSeedsProblem): here, and the daemon's below.
expect_exit 2 "\-\-seeds: 1001 is out of range: 1 to 1000" "$dembuf" sweep "${bare[@]}" \
  --vary projectile.speed_m_s=1,2 --seeds 1001 --out "$work/seeds"
expect_exit 2 "projectile.speed_m_s: the value 1.0 is given twice" "$dembuf" sweep "${bare[@]}" \
  --vary projectile.speed_m_s=1,1.0 --out "$work/same"

# Masses 2e-14 kg apart: one point per run (12 digits made them all "1", one point).
"$dembuf" sweep "${bare[@]}" --vary projectile.mass_kg=1:1.0000000000001:0.00000000000002 \
  --no-bed-cache --out "$work/fine" > /dev/null 2>&1 || fail "the fine sweep"
runs=$(($(wc -l < "$work/fine/sweep.csv") - 1))
points=$(tail -n +2 "$work/fine/points.csv" | cut -d, -f1 | sort -u | wc -l)
[ "$runs" -ge 5 ] && [ "$points" = "$runs" ] ||
  fail "$runs runs, $points points: $(cut -d, -f1 "$work/fine/points.csv" | tr '\n' ' ')"
# An ordinary range keeps its short values (and its runs' names).
"$dembuf" sweep "${bare[@]}" --vary projectile.speed_m_s=0.1:0.3:0.1 --no-bed-cache \
  --out "$work/plain" > /dev/null 2>&1 || fail "the plain sweep"
[ "$(tail -n +2 "$work/plain/points.csv" | cut -d, -f1 | tr '\n' ' ')" = "0.1 0.2 0.3 " ] ||
  fail "plain values: $(cut -d, -f1 "$work/plain/points.csv" | tr '\n' ' ')"
# Progress: a line on stderr at the DEMBUF_PROGRESS_S interval with the runs done and what
# each running run does; stdout keeps the results alone.
DEMBUF_PROGRESS_S=0.1 "$dembuf" sweep "${bare[@]}" --vary projectile.speed_m_s=0.5:2:0.1 \
  --set time.end_s=0.2 --no-bed-cache --out "$work/progress" > "$work/progress.out" \
  2> "$work/progress.err" || fail "the progress sweep: $(cat "$work/progress.err")"
grep -q "^sweep: [0-9]* of 16 runs done; run [0-9]*: impact, [0-9.]* of [0-9.]* ms" \
  "$work/progress.err" || fail "no progress on stderr: $(head -c 600 "$work/progress.err")"
! grep -q "runs done" "$work/progress.out" || fail "progress went to stdout"

# Tokens: names of 1 to 64 characters of [A-Za-z0-9._-].
expect_exit 2 "name: \"\" must be 1 to 64 characters" "$dembufd" --db "$work/dembuf.db" token-create ""
expect_exit 2 "must be 1 to 64 characters" "$dembufd" --db "$work/dembuf.db" token-create "$(printf 'a%.0s' $(seq 10000))"
expect_exit 2 "may hold only letters, digits" "$dembufd" --db "$work/dembuf.db" token-create "bad name"
"$dembufd" --db "$work/dembuf.db" token-create "$(printf 'a%.0s' $(seq 64))" > /dev/null 2>&1 ||
  fail "a 64-character name was refused"
root=$("$dembufd" --db "$work/dembuf.db" token-create root --admin 2>/dev/null)

# The daemon: the same sweep refusal; an admin's job is filed under the admin.
start_daemon "$work/dembuf.db" "$work/dembufd.log"
expect_exit 2 "refused the request: projectile.speed_m_s: varied twice" "$dembuf" --token "$root" \
  sweep "${bare[@]}" --vary projectile.speed_m_s=1,2 --vary projectile.speed_m_s=3,4
job=$(USER=alice "$dembuf" --token "$root" submit "${bare[@]}" 2>/dev/null)
"$dembuf" --token "$root" status "$job" | grep -q "owner root," || fail "$("$dembuf" --token "$root" status "$job")"
job=$(USER=alice "$dembuf" --token "$root" --owner bob submit "${bare[@]}" 2>/dev/null)
"$dembuf" --token "$root" status "$job" | grep -q "owner bob," || fail "an admin's named owner"
# Names with C1 controls (U+009B starts a terminal escape) or bidirectional overrides (U+202E)
# were accepted and printed raw, so that `list` could be spoofed.
expect_exit 2 "\-\-name: holds the control character U+009B (byte 4)" \
  "$dembuf" --token "$root" submit "${bare[@]}" --name "$(printf 'job\xc2\x9b31m')"
expect_exit 2 "\-\-name: holds the bidirectional control U+202E (byte 5)" \
  "$dembuf" --token "$root" sweep "${bare[@]}" --vary projectile.speed_m_s=1,2 \
  --name "$(printf 'run_\xe2\x80\xaefdp.exe')"
expect_exit 2 "\-\-name: is not UTF-8 (byte 4)" \
  "$dembuf" --token "$root" submit "${bare[@]}" --name "$(printf 'caf\xc3')"
# The daemon refuses them whatever the client (here the Python package, which sends them).
PYTHONPATH="$(dirname "$dembuf")/../python" DEMBUF_TOKEN=$root /usr/bin/python3 - <<'PY' ||
import dembuf
with dembuf.connect() as daemon:
    for name, why in [("job\x9b31m", "name: holds the control character U+009B (byte 4)"),
                      ("run_\u202efdp.exe", "name: holds the bidirectional control U+202E (byte 5)")]:
        try:
            daemon.submit(set=["bed.thickness_m=0"], name=name)
        except dembuf.DembufError as e:
            assert e.code == "INVALID_ARGUMENT" and why in e.message, (name, e)
        else:
            raise SystemExit(f"the daemon took the name {name!r}")
    for seeds in (-3, 1001):
        try:
            daemon.submit_sweep({"projectile.speed_m_s": [1, 2]}, seeds=seeds,
                                set=["bed.thickness_m=0"])
        except dembuf.DembufError as e:
            assert e.code == "INVALID_ARGUMENT" and \
                f"seeds: {seeds} is out of range: 1 to 1000" in e.message, (seeds, e)
        else:
            raise SystemExit(f"the daemon took {seeds} seeds")
PY
  fail "the daemon's name checks"
stop_daemon
echo "sweeps test passed"
