#!/usr/bin/env bash
# Never the same run twice: a job whose scene (seed included), bed file and engine match a
# stored result is filed done with it, at once, marked reused, with the original's provenance:
#   1. a second submission of a sweep, by another user, runs nothing and gives the same results
#      byte for byte; a changed field or seed runs again; --no-reuse runs everything;
#   2. a stored result that fails its checksum is not reused (the job runs);
#   3. with tokens, a user reuses only what they may read: their own results, not another's;
#      an admin filing for bob reuses only what bob may read.
# Usage: reuse_test.sh DEMBUF DEMBUFD PYTHON_DIR
. "$(dirname "$0")/lib.sh" "$1" "$2"
python_dir=$3
export OMP_NUM_THREADS=1
bare=(--preset e2 --set bed.thickness_m=0 --set time.output_interval_s=1e-4)
# ran ID: whether a worker took the job (the log says "job ID starts").
ran() { grep -q "worker [0-9]*: job $1 starts" "$daemon_log"; }
# sweep_jobs SWEEP: its job ids.
sweep_jobs() { "$dembuf" list --sweep "$1" --json | python3 -c 'import json, sys; print(*sorted(j["id"] for j in json.load(sys.stdin)["jobs"]))'; }

echo "== 1. the same sweep again, by another user: answered from the store"
start_daemon "$work/r.db" "$work/r.log"
first=$("$dembuf" --owner alice sweep "${bare[@]}" --vary projectile.speed_m_s=1,2,3)
timeout 120 "$dembuf" watch --sweep "$first" > /dev/null || fail "sweep $first"
again=$("$dembuf" --owner bob sweep "${bare[@]}" --vary projectile.speed_m_s=1,2,3)
timeout 120 "$dembuf" watch --sweep "$again" > "$work/watch" || fail "sweep $again: $(cat "$work/watch")"
read -r -a originals < <(sweep_jobs "$first")
read -r -a reused < <(sweep_jobs "$again")
for i in 0 1 2; do
  ! ran "${reused[$i]}" || fail "job ${reused[$i]} ran, though job ${originals[$i]} had its result"
  "$dembuf" status "${reused[$i]}" | grep -q "^reused: job ${originals[$i]}'s stored result" ||
    fail "status ${reused[$i]}: $("$dembuf" status "${reused[$i]}")"
done
"$dembuf" fetch --sweep "$first" --long --no-plots --out "$work/first" > /dev/null
"$dembuf" fetch --sweep "$again" --long --no-plots --out "$work/again" > /dev/null
cmp "$work/first/sweep_long.csv" "$work/again/sweep_long.csv" || fail "the reused results differ"
# (sweep.csv's second column is the job's id: the rest is the same)
cmp <(cut -d, -f1,3- "$work/first/sweep.csv") <(cut -d, -f1,3- "$work/again/sweep.csv") ||
  fail "the reused sweep tables differ"
# The summary is the original's, provenance and all.
for run in "$work"/first/runs/*/; do
  cmp "$run/summary.json" "$work/again/runs/$(basename "$run")/summary.json" ||
    fail "the summaries of $(basename "$run") differ"
done
PYTHONPATH="$python_dir" /usr/bin/python3 - "${reused[0]}" "${originals[0]}" <<'PY' || fail "Python"
import sys
import dembuf
job, original = map(int, sys.argv[1:])
with dembuf.connect() as daemon:
    assert daemon.job(job)["reused_from"] == original, daemon.job(job)
    fresh = daemon.submit(preset="e2", set={"bed.thickness_m": 0, "time.output_interval_s": 1e-4,
                                            "projectile.speed_m_s": 1}, reuse=False)
    assert daemon.job(fresh)["reused_from"] is None
print(f"Python: job {job} reused job {original}'s result; reuse=False filed job {fresh} to run")
PY
echo "sweep $again: 3 jobs reused, none run; the fetched tables are sweep $first's, byte for byte"

changed=$("$dembuf" --owner bob sweep "${bare[@]}" --vary projectile.speed_m_s=1,2,4)
timeout 120 "$dembuf" watch --sweep "$changed" > /dev/null || fail "sweep $changed"
read -r -a jobs < <(sweep_jobs "$changed")
! ran "${jobs[0]}" && ! ran "${jobs[1]}" || fail "the unchanged points of sweep $changed ran"
ran "${jobs[2]}" || fail "the changed point (speed 4) of sweep $changed did not run"
seed=$("$dembuf" --owner bob submit "${bare[@]}" --set projectile.speed_m_s=1 --set bed.seed=9)
wait_state "$seed" done 60
ran "$seed" || fail "job $seed of another seed did not run"
forced=$("$dembuf" --owner bob sweep "${bare[@]}" --vary projectile.speed_m_s=1,2,3 --no-reuse)
timeout 120 "$dembuf" watch --sweep "$forced" > /dev/null || fail "sweep $forced"
for id in $(sweep_jobs "$forced"); do ran "$id" || fail "job $id of a --no-reuse sweep did not run"; done
echo "a changed speed and a changed seed ran; --no-reuse ran all three"

echo "== 2. a damaged result, or one of another build, is not reused"
lone=$("$dembuf" --owner alice submit "${bare[@]}" --set projectile.speed_m_s=7)
other=$("$dembuf" --owner alice submit "${bare[@]}" --set projectile.speed_m_s=6)
wait_state "$lone" done 60
wait_state "$other" done 60
stop_daemon
python3 - "$work/r.db" "$lone" "$other" <<'PY'
import hashlib, json, sqlite3, sys
db = sqlite3.connect(sys.argv[1])
db.execute("UPDATE results SET summary_json = replace(summary_json, '\"P_N\"', '\"P_N\" ') "
           "WHERE job_id = ?", (int(sys.argv[2]),))
# Job `other` as another build's (its compile flags), with a checksum that matches.
(text,) = db.execute("SELECT summary_json FROM results WHERE job_id = ?", (int(sys.argv[3]),)).fetchone()
summary = json.loads(text)
summary["provenance"]["build_config"] += " -ffast-math"
text = json.dumps(summary) + "\n"
db.execute("UPDATE results SET summary_json = ?, summary_sha256 = ? WHERE job_id = ?",
           (text, hashlib.sha256(text.encode()).hexdigest(), int(sys.argv[3])))
db.commit()
PY
start_daemon "$work/r.db" "$work/r.log"
retry=$("$dembuf" --owner alice submit "${bare[@]}" --set projectile.speed_m_s=7)
rebuilt=$("$dembuf" --owner alice submit "${bare[@]}" --set projectile.speed_m_s=6)
wait_state "$retry" done 60
wait_state "$rebuilt" done 60
ran "$retry" || fail "job $retry reused a result that fails its checksum"
grep -q "job $lone's result is not reused" "$daemon_log" || fail "the damaged result was not logged"
ran "$rebuilt" || fail "job $rebuilt reused job $other's result, made with other compile flags"
stop_daemon
echo "job $lone's damaged result and job $other's of other flags were passed over: they ran"

echo "== 3. with tokens: only what the user may read"
alice=$("$dembufd" --db "$work/r.db" token-create alice2 2> /dev/null)
bob=$("$dembufd" --db "$work/r.db" token-create bob2 2> /dev/null)
root=$("$dembufd" --db "$work/r.db" token-create root --admin 2> /dev/null)
start_daemon "$work/r.db" "$work/r.log" --access tokens
mine=$(DEMBUF_TOKEN=$alice "$dembuf" submit "${bare[@]}" --set projectile.speed_m_s=8)
DEMBUF_TOKEN=$alice wait_state "$mine" done 60
theirs=$(DEMBUF_TOKEN=$bob "$dembuf" submit "${bare[@]}" --set projectile.speed_m_s=8)
own=$(DEMBUF_TOKEN=$alice "$dembuf" submit "${bare[@]}" --set projectile.speed_m_s=8)
DEMBUF_TOKEN=$bob wait_state "$theirs" done 60
DEMBUF_TOKEN=$alice wait_state "$own" done 60
ran "$theirs" || fail "bob's job $theirs reused alice's result, which he may not read"
! ran "$own" || fail "alice's job $own ran, though her job $mine had its result"
# An admin filing for bob gives bob's job bob's rights, not the admin's: alice's result at
# speed 9 is not his to read.
hers=$(DEMBUF_TOKEN=$alice "$dembuf" submit "${bare[@]}" --set projectile.speed_m_s=9)
DEMBUF_TOKEN=$alice wait_state "$hers" done 60
for_bob=$(DEMBUF_TOKEN=$root "$dembuf" --owner bob2 submit "${bare[@]}" --set projectile.speed_m_s=9)
admins=$(DEMBUF_TOKEN=$root "$dembuf" submit "${bare[@]}" --set projectile.speed_m_s=9)
DEMBUF_TOKEN=$root wait_state "$for_bob" done 60
DEMBUF_TOKEN=$root wait_state "$admins" done 60
ran "$for_bob" || fail "job $for_bob, filed by an admin for bob, reused alice's result"
! ran "$admins" || fail "the admin's own job $admins ran, though it may read alice's result"
stop_daemon
echo "bob's job ran; alice's second was answered from her first; the admin's job for bob ran"
echo "PASS"
