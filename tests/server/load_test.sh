#!/usr/bin/env bash
# Bounded load on loopback: 200 queued jobs and 20 clients watching at once. Every watcher
# receives every sample of its job, and the daemon's peak memory stays bounded.
# Usage: load_test.sh DEMBUF DEMBUFD
. "$(dirname "$0")/lib.sh" "$1" "$2"
start_daemon "$work/dembuf.db" "$work/dembufd.log" --workers 2

# 200 bare-plate impacts (quick, about 1000 samples each), queued at once.
sweep=$("$dembuf" sweep --set bed.thickness_m=0 --set time.output_interval_s=1e-6 \
        --vary projectile.speed_m_s=1:5:0.04 --vary projectile.mass_kg=0.1,0.2 --seeds 1 2>/dev/null)
"$dembuf" list --sweep "$sweep" --limit 1000 | awk 'NR > 1 { print $1 }' | sort -n > "$work/jobs"
[ "$(wc -l < "$work/jobs")" -ge 200 ] || fail "$(wc -l < "$work/jobs") jobs queued"
# 20 watchers on jobs spread over the queue: most join before their job starts.
awk 'NR % 10 == 0' "$work/jobs" | head -20 > "$work/watched"
while read -r id; do
  "$dembuf" watch "$id" --csv > "$work/watch.$id" 2> /dev/null &
done < "$work/watched"
wait $(jobs -p | grep -v "^$daemon_pid$") 2>/dev/null || true
for _ in $(seq 600); do
  "$dembuf" status --sweep "$sweep" | grep -q "done $(wc -l < "$work/jobs")$" && break
  sleep 0.2
done
while read -r id; do
  "$dembuf" fetch "$id" --out "$work/fetched.$id" --no-plots > /dev/null
  stored=$(($(wc -l < "$work/fetched.$id/plate_force.csv") - 1))
  watched=$(($(wc -l < "$work/watch.$id") - 1))
  [ "$stored" -gt 0 ] && [ "$watched" = "$stored" ] || fail "job $id: watched $watched of $stored samples"
done < "$work/watched"
peak_kb=$(awk '/VmHWM/ { print $2 }' "/proc/$daemon_pid/status")
echo "daemon peak memory: $((peak_kb / 1024)) MB for $(wc -l < "$work/jobs") jobs and 20 watchers"
[ "$peak_kb" -lt 400000 ] || fail "peak memory $peak_kb kB"
stop_daemon
echo "load test passed"
