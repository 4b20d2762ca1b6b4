#!/usr/bin/env bash
# Item 4 of the robustness suite (docs/robustness.md): parsers with limits. A TOML file
# nested 20,000 deep crashed `dembuf run`, `dembufd --config` and a submitted scene (the TOML
# parser recurses); a long flat array took quadratic time. Each is now refused with exit code
# 2 and a message naming the file, the line and the limit, the daemon keeps serving, and a
# big file is refused in well under a second.
# Usage: parsers_test.sh DEMBUF DEMBUFD
. "$(dirname "$0")/lib.sh" "$1" "$2"

python3 -c "print('[output]\nsnapshot_times_s = ' + '[' * 20000 + ']' * 20000)" > "$work/deep.toml"
python3 -c "print('listen = ' + '[' * 20000 + ']' * 20000)" > "$work/deep-config.toml"
python3 -c "print('[output]\nsnapshot_times_s = [' + ', '.join(['0.001'] * 100000) + ']')" \
  > "$work/long-array.toml"

# The CLI, locally: exit 2, nothing written.
expect_exit 2 'deep.toml": line 2: arrays and tables nested more than 8 deep; at most 8' \
  "$dembuf" run "$work/deep.toml" --out "$work/run"
[ ! -e "$work/run" ] || fail "a refused scene created its output folder"
# Refused before the parser (the quadratic parse took 4 s for 40,000 elements, minutes for
# this one); expect_exit's 60 s kill is the only clock: the refusal's text shows where it was.
expect_exit 2 'more than 1024 elements; at most 1024' "$dembuf" scene --print "$work/long-array.toml"

# The daemon's configuration: refused at start.
expect_exit 2 'line 1: arrays and tables nested more than 8 deep' \
  "$dembufd" --config "$work/deep-config.toml" --db "$work/config.db"

# A submitted scene: INVALID_ARGUMENT from the daemon, which keeps serving.
start_daemon "$work/dembuf.db" "$work/dembufd.log"
expect_exit 2 'refused the request: scene_toml: line 2: arrays and tables nested more than 8' \
  "$dembuf" submit "$work/deep.toml"
expect_exit 2 'refused the request: .*more than 1024 elements' \
  "$dembuf" sweep "$work/long-array.toml" --vary projectile.speed_m_s=1,2
"$dembuf" server-info > /dev/null || fail "the daemon died on a deep scene"
stop_daemon
echo "parsers test passed"
