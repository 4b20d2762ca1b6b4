#!/usr/bin/env bash
# Clients that trust no server: `dembuf fetch` against a server that speaks the API but sends
# what a compromised daemon could (tests/robustness/hostile_server.py). It wrote any plain name:
# .git/config with core.fsmonitor (run by the next `git status`), .envrc, a file `a` then `a/b`
# (a raw C++ message), and sized a sweep by jobs_total = -1 or 2e9 (a multi-GB allocation,
# "cannot create std::vector larger than max_size()"). Now only the result names the API
# defines are written, counts are bounded before anything is sized by them, and each refusal
# is one sentence naming the server and the file.
# Usage: hostile_server_test.sh DEMBUF DEMBUFD
. "$(dirname "$0")/lib.sh" "$1" "$2"

python_package=$(dirname "$dembuf")/../python
/usr/bin/python3 "$(dirname "$0")/hostile_server.py" "$python_package" > "$work/port" 2> "$work/server.log" &
server_pid=$!
trap 'rc=$?; kill "$server_pid" 2>/dev/null || true; rm -rf "$work"; exit $rc' EXIT
for _ in $(seq 100); do [ -s "$work/port" ] && break; sleep 0.1; done
[ -s "$work/port" ] || fail "the hostile server did not start: $(cat "$work/server.log")"
export DEMBUF_SERVER=127.0.0.1:$(cat "$work/port")

# refused_file JOB NAME: fetch fails naming the server and the file; nothing outside the
# files a fetch always writes is left in the folder.
refused_file() {
  local out=$work/job$1
  expect_exit 1 "the server at $DEMBUF_SERVER sent a bad result file \"$2\" for job $1: not a name the API defines" \
    "$dembuf" fetch "$1" --out "$out" --no-plots
  [ "$(wc -l < "$work/err")" = 1 ] || fail "job $1: more than one line: $(cat "$work/err")"
  local extra
  extra=$(cd "$out" && find . -mindepth 1 ! -name summary.json ! -name plate_force.csv \
    ! -name scene.toml ! -name job.json)
  [ -z "$extra" ] || fail "job $1: fetch wrote $extra"
}
refused_file 1 ".git/config"
refused_file 2 ".envrc"
refused_file 3 "a"
refused_file 4 "snapshots/.git/config"
refused_file 5 "run.sh"
[ ! -e PWNED ] && [ ! -e "$work/PWNED" ] || fail "a planted file ran"
# What the API defines is written.
"$dembuf" fetch 6 --out "$work/job6" --no-plots > /dev/null || fail "the allowed files: $(cat "$work/err")"
[ -s "$work/job6/snapshots/peak/beads.vtp" ] && [ -s "$work/job6/snapshots.pvd" ] ||
  fail "the allowed files were not written"

# Counts from a server are bounded before anything is sized by them.
expect_exit 1 "the server at $DEMBUF_SERVER sent a bad sweep 1: jobs_total = -1, with 0 jobs listed" \
  "$dembuf" fetch --sweep 1 --out "$work/sweep1" --no-plots
expect_exit 1 "the server at $DEMBUF_SERVER sent a bad sweep 2: jobs_total = 2000000000" \
  "$dembuf" fetch --sweep 2 --out "$work/sweep2" --no-plots
if grep -q "max_size\|bad_alloc" "$work/err"; then fail "a raw C++ message: $(cat "$work/err")"; fi
echo "hostile server test passed"
