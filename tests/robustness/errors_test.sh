#!/usr/bin/env bash
# Item 11 of the robustness suite (docs/robustness.md): clear errors everywhere.
# - Exit codes as documented: 0 done, 1 a runtime failure, 2 bad input, 3 a failed run,
#   130/143 interrupted. A value the command line could not convert exited 104 (CLI11's own
#   code); every command-line mistake now exits 2.
# - A server's refusals name what was wrong in words ("server error (5): ..." before).
# - Legal but physically absurd input runs with a warning (restitution 1e-9 gave a 12.8 MN
#   peak without a word): on the terminal and in summary.json, and from the daemon too.
# Usage: errors_test.sh DEMBUF DEMBUFD
. "$(dirname "$0")/lib.sh" "$1" "$2"

expect_exit 2 "Could not convert" "$dembuf" sweep --seeds x
expect_exit 2 "not expected" "$dembuf" run --seeds 3
expect_exit 2 "unknown field" "$dembuf" run --set no.field=1 --out "$work/x"
# A misspelt field is named with the field meant; a value given as a word of its own (it was
# read as the scene file "0.01") with the form meant.
expect_exit 2 "bed.thicknes_m: unknown field; did you mean bed.thickness_m?" \
  "$dembuf" run --set bed.thicknes_m=0.01 --dry-run
expect_exit 2 'as in --set bed.thickness_m=0.01' "$dembuf" run --set bed.thickness_m 0.01 --dry-run
expect_exit 2 'as in --vary bed.thickness_m=0.01,0.02' \
  "$dembuf" sweep --vary bed.thickness_m 0.01,0.02 --dry-run
expect_exit 2 'as in --set bed.thickness_m=0.01' "$dembuf" submit --set bed.thickness_m 0.01
expect_exit 0 "Usage" "$dembuf" --help
expect_exit 2 "Could not convert\|not a number\|Invalid" "$dembufd" --workers x
expect_exit 0 "Exit codes: 0" "$dembuf" --help

# Legal but absurd: a warning, and the run goes on.
expect_exit 0 "warning: material.restitution: 1e-09 is below 0.05" \
  "$dembuf" run --set material.restitution=1e-9 --out "$work/absurd"
grep -q '"warnings": \[' "$work/absurd/summary.json" || fail "no warnings in summary.json"
grep -q 'material.restitution: 1e-09 is below 0.05' "$work/absurd/summary.json" || fail "warning text"
expect_exit 0 "warning: projectile.mass_kg: the projectile's density would be 1.53e+06 kg/m" \
  "$dembuf" scene --print --set projectile.mass_kg=100
expect_exit 0 "warning: projectile.speed_m_s: the projectile hits at 100 m/s" \
  "$dembuf" scene --print --set projectile.speed_m_s=100
# An ordinary scene says nothing.
"$dembuf" scene --print --preset e2 > /dev/null 2> "$work/err"
[ ! -s "$work/err" ] || fail "a warning for the paper's scene: $(cat "$work/err")"

start_daemon "$work/dembuf.db" "$work/dembufd.log"
expect_exit 2 "not found: id: no job 999" "$dembuf" status 999
expect_exit 0 "warning: material.restitution: 1e-09 is below 0.05" \
  "$dembuf" submit --set material.restitution=1e-9
stop_daemon
expect_exit 1 "cannot reach dembufd" "$dembuf" server-info
echo "errors test passed"
