#!/usr/bin/env bash
# The web pages in a real browser (headless Chromium, from deploy/browser.sh): a job opened as
# it starts shows its force samples arriving live and its chart drawn, its final peak equals
# summary.json's, the list shows it done, a sweep's page draws its points; and on a daemon
# whose pages are served beyond loopback, no page or API answer without a token.
# Usage: browser_test.sh DEMBUF DEMBUFD   (DEMBUF_SCREENSHOTS=DIR keeps the pages' pictures)
here=$(cd "$(dirname "$0")" && pwd)
. "$here/../server/lib.sh" "$1" "$2"
chromium=$(bash "$here/../../deploy/browser.sh") || fail "no browser: deploy/browser.sh failed"
small_scene "$work/small.toml"

# --- the pages on loopback: a job and a sweep, watched as they run ---------------------------
start_daemon "$work/dembuf.db" "$work/dembufd.log" --workers 1 --http 127.0.0.1:0
base=$(web_base "$work/dembufd.log")
[ -n "$base" ] || fail "dembufd did not say where its web pages are"
# The one worker is held by a long job until the watched job's page is open (then cancelled),
# so that the watched job runs while the page watches however slowly the browser starts; it
# is a longer impact, so that samples flow for a few seconds. Then a sweep of three speeds
# over two seeds (three points, each of two runs), the first seed on the same bed.
holder=$("$dembuf" submit "$work/small.toml" --set time.end_s=5)
job=$("$dembuf" submit "$work/small.toml" --set time.end_s=0.12)
sweep=$("$dembuf" sweep "$work/small.toml" --vary projectile.speed_m_s=1,2,3 --seeds 2 2>/dev/null)
node "$here/pages_test.mjs" --browser "$chromium" --base "$base" --job "$job" --sweep "$sweep" \
  --points 3 --min-live 200 --summary "$work/fetched/summary.json" \
  ${DEMBUF_SCREENSHOTS:+--screenshots "$DEMBUF_SCREENSHOTS"} > "$work/pages.log" 2>&1 &
pages=$!
for _ in $(seq 1200); do
  grep -q "job page open" "$work/pages.log" 2>/dev/null && break
  kill -0 "$pages" 2>/dev/null || break
  sleep 0.1
done
grep -q "job page open" "$work/pages.log" || { cat "$work/pages.log"; fail "the job page did not open"; }
[ "$(job_state "$job")" = queued ] || fail "job $job started before its page was open"
"$dembuf" cancel "$holder" > /dev/null || fail "cancel of the holding job $holder"
wait_state "$job" "done failed cancelled" 300
"$dembuf" fetch "$job" --out "$work/fetched" --no-plots > /dev/null || fail "fetch of job $job"
wait "$pages" || { cat "$work/pages.log"; fail "the pages on loopback"; }
cat "$work/pages.log"
stop_daemon

# --- beyond loopback: a token, or nothing -------------------------------------------------------
"$dembufd" --db "$work/open.db" token-create alice > "$work/alice.token" 2> /dev/null
start_daemon "$work/open.db" "$work/open.log" --access tokens --http 0.0.0.0:0
port=$(web_base "$work/open.log" | sed 's|.*:||')
[ -n "$port" ] || fail "no web port"
code=$(curl -s -o /dev/null -w '%{http_code}' "http://127.0.0.1:$port/api/jobs")
[ "$code" = 401 ] || fail "the API without a token answered $code, not 401"
code=$(curl -s -o /dev/null -w '%{http_code}' -H "Authorization: Bearer $(cat "$work/alice.token")" \
       "http://127.0.0.1:$port/api/jobs")
[ "$code" = 200 ] || fail "the API with alice's token answered $code, not 200"
node "$here/pages_test.mjs" --browser "$chromium" --protected "http://127.0.0.1:$port" \
  --token "$(cat "$work/alice.token")" > "$work/protected.log" 2>&1 ||
  { cat "$work/protected.log"; fail "the pages beyond loopback"; }
cat "$work/protected.log"
stop_daemon
echo "browser test passed"
