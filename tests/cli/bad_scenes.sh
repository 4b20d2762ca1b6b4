#!/usr/bin/env bash
# Every file in the folder is a bad scene whose first line says "# expect: TEXT". The CLI must
# refuse it with exit code 2, an error message containing TEXT (the field), and no output
# folder. Usage: bad_scenes.sh DEMBUF_BINARY FOLDER
set -u
dembuf=$1
folder=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
failures=0
count=0
for scene in "$folder"/*.toml; do
  count=$((count + 1))
  expect=$(head -1 "$scene" | sed 's/^# expect: //')
  out="$work/out-$(basename "$scene" .toml)"
  "$dembuf" run "$scene" --out "$out" >"$work/stdout" 2>"$work/stderr"
  code=$?
  if [ "$code" -ne 2 ]; then
    echo "FAIL $scene: exit code $code, expected 2"; failures=$((failures + 1))
  elif ! grep -qF "$expect" "$work/stderr"; then
    echo "FAIL $scene: message does not name '$expect': $(cat "$work/stderr")"
    failures=$((failures + 1))
  elif [ -e "$out" ]; then
    echo "FAIL $scene: output folder was created"; failures=$((failures + 1))
  else
    echo "ok   $(basename "$scene"): $(cat "$work/stderr")"
  fi
done
# Bad overrides on the command line are refused the same way.
"$dembuf" run --set projectile.mass_kg=-1 --out "$work/out-set" 2>"$work/stderr"
code=$?
count=$((count + 1))
if [ "$code" -ne 2 ] || ! grep -qF "projectile.mass_kg" "$work/stderr" || [ -e "$work/out-set" ]; then
  echo "FAIL --set projectile.mass_kg=-1: exit $code, $(cat "$work/stderr")"; failures=$((failures + 1))
else
  echo "ok   --set projectile.mass_kg=-1: $(cat "$work/stderr")"
fi
echo "$((count - failures)) passed, $failures failed"
[ "$failures" -eq 0 ]
