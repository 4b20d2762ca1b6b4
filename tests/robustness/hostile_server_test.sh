#!/usr/bin/env bash
# Clients that trust no server: `dembuf fetch` against a server that speaks the API but sends
# what a compromised daemon could (tests/robustness/hostile_server.py). It wrote any plain name:
# .git/config with core.fsmonitor (run by the next `git status`), .envrc, a file `a` then `a/b`
# (a raw C++ message), and sized a sweep by jobs_total = -1 or 2e9 (a multi-GB allocation,
# "cannot create std::vector larger than max_size()"). Now only the result names the API
# defines are written, counts are bounded before anything is sized by them, and each refusal
# is one sentence naming the server and the file. A job's fields and the server's refusals
# reached the terminal with their escape sequences; now every server string is shown with
# control characters as '?'.
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
    ! -name scene.toml ! -name job.json ! -name log.txt)
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

# A summary nested 100,000 deep: status --json died with SIGSEGV (the JSON library recursed).
expect_exit 1 "the server at $DEMBUF_SERVER sent job 7's summary_json: nested deeper than 64 levels" \
  "$dembuf" status 7 --json
expect_exit 1 "job 7's summary_json: nested deeper than 64 levels" "$dembuf" status 7
# A sweep's aggregates (its points and Hc) are bounded and printed as text.
expect_exit 1 "the server at $DEMBUF_SERVER sent sweep 4's aggregates_json: nested deeper than 64 levels" \
  "$dembuf" status --sweep 4 --json
expect_exit 1 "the server at $DEMBUF_SERVER sent sweep 4's aggregates_json: nested deeper than 64 levels" \
  "$dembuf" status --sweep 4
"$dembuf" status --sweep 5 > "$work/sweep5" 2>&1 || fail "status --sweep 5: $(cat -v "$work/sweep5")"
grep -q "^Hc ?\[2J?\]0;owned? not reached$" "$work/sweep5" || fail "the Hc note: $(cat -v "$work/sweep5")"
# An Hc said reached without its value, and one whose "reached" is no boolean: no Hc printed,
# no crash (a missing key was read past the end of its map).
for sweep in 7 8; do
  "$dembuf" status --sweep $sweep > "$work/sweep$sweep" 2>&1 || fail "status --sweep $sweep: $(cat "$work/sweep$sweep")"
  if grep -q "critical thickness" "$work/sweep$sweep"; then fail "sweep $sweep: $(cat "$work/sweep$sweep")"; fi
done
# A watch of 20 million samples: the client kept every one (1.2 GB in 15 s from a fast server).
"$dembuf" watch 8 > /dev/null 2> "$work/err" &
watcher=$!
peak=0
while kill -0 "$watcher" 2> /dev/null; do
  rss=$(sed -n 's/^VmHWM:[[:space:]]*\([0-9]*\).*/\1/p' "/proc/$watcher/status" 2> /dev/null || echo 0)
  [ "${rss:-0}" -gt "$peak" ] && peak=$rss
  sleep 0.2
done
wait "$watcher" || fail "watch of a long stream: $(cat "$work/err")"
echo "watch of 20 million samples: the client's peak memory was $((peak / 1024)) MB"
[ "$peak" -lt $((100 * 1024)) ] || fail "watch kept the samples: $((peak / 1024)) MB"
# A series announced as 2^62 samples, streamed without end: fetch wrote until the disk was full.
expect_exit 1 "the server at $DEMBUF_SERVER announced 4611686018427387904 samples for job 9; a client takes at most" \
  timeout 60 "$dembuf" fetch 9 --out "$work/job9" --no-plots
# An answer in gzip that inflates to 300 MB: blamed on the request ("larger than this server
# accepts"). Compressed answers are not taken.
expect_exit 1 "the server at $DEMBUF_SERVER sent a compressed answer" "$dembuf" server-info
if grep -q "max_request_kb" "$work/err"; then fail "blamed on the request: $(cat "$work/err")"; fi
# Text from a server is printed, never obeyed: escape sequences (clear the screen, set the
# title, write the clipboard) in a job's fields and in a refusal reached the terminal whole.
"$dembuf" status 10 > "$work/out" 2> "$work/err" || true
"$dembuf" cancel 10 >> "$work/out" 2>> "$work/err" || true
grep -q "no job" "$work/err" && grep -q "Slurm job 1 on" "$work/out" ||
  fail "status and cancel of job 10: $(cat "$work/out" "$work/err")"
if LC_ALL=C grep -q $'[\x01-\x08\x0b-\x1f\x7f]\|\xc2[\x80-\x9f]' "$work/out" "$work/err"; then
  fail "control characters from the server reached the terminal: $(cat -v "$work/out" "$work/err")"
fi
# A fetched run's log.txt and a fetched sweep's files take the server's text as text: a job's
# provenance and warnings with escapes and a forged line, a sweep job's value that is none of
# its axis's.
"$dembuf" fetch 11 --out "$work/job11" --no-plots > /dev/null 2>&1 || fail "fetch 11: $(cat "$work/err")"
[ "$(grep -c '^warning: ' "$work/job11/log.txt")" = 1 ] || fail "log.txt: $(cat -v "$work/job11/log.txt")"
if LC_ALL=C grep -q $'[\x01-\x08\x0b-\x1f\x7f]' "$work/job11/log.txt"; then
  fail "control characters from the server reached log.txt: $(cat -v "$work/job11/log.txt")"
fi
expect_exit 1 "the server at $DEMBUF_SERVER sent job 30 of sweep 3 with values that are not its sweep's" \
  "$dembuf" fetch --sweep 3 --out "$work/sweep3" --no-plots
# --no-reuse asks for a run: a server that answers with a stored result anyway is named, and
# the command fails (it said the job was answered from another, as if asked for).
expect_exit 1 "the server at $DEMBUF_SERVER answered job 40 with job 1's stored result, though --no-reuse asked for a run" \
  "$dembuf" submit --set bed.thickness_m=0 --no-reuse
# The Python package likewise.
/usr/bin/python3 - "$python_package" "$DEMBUF_SERVER" <<'PY' || fail "the Python package trusted the server"
import sys
sys.path.insert(0, sys.argv[1])
import dembuf
client = dembuf.Client(sys.argv[2], owner="me")
for call, words in [(lambda: client.job(7), "nested deeper than 64 levels"),
                    (lambda: client.sweep_points(4), "nested deeper than 64 levels"),
                    (lambda: client.sweep_points(6), "not a table of numbers"),
                    (lambda: client.series(9), "announced 4611686018427387904 samples"),
                    (lambda: client.server_info(), "compressed answer")]:
    try:
        call()
        raise AssertionError(f"taken: {words}")
    except dembuf.DembufError as e:
        assert words in str(e), str(e)
PY
echo "hostile server test passed"
