#!/usr/bin/env bash
# A hostile node of the Slurm executor's cluster (docs/robustness.md): the test plays the node
# with a fake Slurm (fake_slurm/) and leaves in a job's folder what a compromised node, or
# another account that could write there, could.
# - summary.json was taken as the job's result once it existed: a result planted in the folder
#   became another user's. Now a result counts only with the nonce the daemon put into the
#   job's script, and failure.json likewise (a planted failure does not end a job).
# - a summary.json nested 10,000 deep (58 KB) became 200 MB in the store (re-indented): now
#   refused past 64 levels, the job failing with the reason.
# - samples.bin as a link to the database was followed and stored as the job's samples: now
#   no link is followed; the job fails saying so.
# - a real run on the fake cluster (which runs the job's script) ends done: the nonce goes from
#   the script through `dembuf run` to the daemon.
# Usage: hostile_node_test.sh DEMBUF DEMBUFD
. "$(dirname "$0")/lib.sh" "$1" "$2"
here=$(cd "$(dirname "$0")" && pwd)
fake=$work/fake-slurm
mkdir -p "$fake/bin"
for command in sbatch squeue scontrol scancel; do ln -s "$here/fake_slurm/fake_slurm.sh" "$fake/bin/$command"; done
export FAKE_SLURM_DIR=$fake/state PATH=$fake/bin:$PATH
printf 'access = "local"\nexecutor = "slurm"\n[slurm]\nwork_dir = "%s"\ndembuf = "%s"\npoll_s = 0.2\n' \
  "$work/shared" "$dembuf" > "$work/slurm.toml"
start_daemon "$work/dembuf.db" "$work/dembufd.log" --config "$work/slurm.toml"

# A bare-plate job: no bed job before it.
bare=(--set projectile.height_m=0.05 --set time.output_interval_s=1e-4)
# node JOB: waits for the job's Slurm submission; sets slurm_id and folder.
node() {
  slurm_id="" folder=""
  for _ in $(seq 100); do
    slurm_id=$(grep -l "dembuf-.*-$1\$" "$FAKE_SLURM_DIR"/jobs/*/name 2> /dev/null | head -1 | xargs -r dirname | xargs -r basename)
    [ -n "$slurm_id" ] && break
    sleep 0.1
  done
  [ -n "$slurm_id" ] || fail "job $1 was not submitted to the fake Slurm"
  folder=$(cat "$FAKE_SLURM_DIR/jobs/$slurm_id/chdir")
  mkdir -p "$folder/out"
}
nonce_of() { sed -n "s/^export DEMBUF_RESULT_NONCE='\([0-9a-f]*\)'.*/\1/p" "$FAKE_SLURM_DIR/jobs/$1/wrap"; }
ends() { echo COMPLETED > "$FAKE_SLURM_DIR/jobs/$slurm_id/state"; wait_state "$1" "done failed" 60; }
note() { "$dembuf" status "$1" | sed -n 's/^note: //p'; }

# 1. A result without the script's nonce.
job=$("$dembuf" submit "${bare[@]}")
node "$job"
printf '{"P_N": 1e9, "provenance": {"forged": true}}\n' > "$folder/out/summary.json"
ends "$job"
[ "$(job_state "$job")" = failed ] || fail "a planted summary.json was taken: $("$dembuf" status "$job")"
note "$job" | grep -q "summary.json was not written by the run this daemon started" ||
  fail "the refusal does not say why: $(note "$job")"
# ... and a failure without it.
job=$("$dembuf" submit "${bare[@]}")
node "$job"
printf '{"error": "planted", "phase": "impact"}\n' > "$folder/out/failure.json"
ends "$job"
note "$job" | grep -q "failure.json was not written by the run" || fail "a planted failure was taken: $(note "$job")"

# 2. A summary nested 10,000 deep, with the nonce.
job=$("$dembuf" submit "${bare[@]}")
node "$job"
python3 -c "import sys; n=10000; sys.stdout.write('{\"result_nonce\": \"$(nonce_of "$slurm_id")\", \"x\": ' + '['*n + ']'*n + '}\n')" \
  > "$folder/summary.json.new"
mv "$folder/summary.json.new" "$folder/out/summary.json"  # whole, as a run writes it
ends "$job"
[ "$(job_state "$job")" = failed ] || fail "a summary 10,000 deep was taken"
note "$job" | grep -q "nested deeper than 64 levels" || fail "deep summary: $(note "$job")"
[ "$(stat -c %s "$work/dembuf.db")" -lt 20000000 ] || fail "the store grew: $(stat -c %s "$work/dembuf.db")"

# 3. samples.bin as a link to the database.
job=$("$dembuf" submit "${bare[@]}")
node "$job"
ln -s "$work/dembuf.db" "$folder/samples.bin"
echo RUNNING > "$FAKE_SLURM_DIR/jobs/$slurm_id/state"
sleep 1
ends "$job"
[ "$(job_state "$job")" = failed ] || fail "a linked samples.bin was followed"
note "$job" | grep -q "symbolic link" || fail "linked samples: $(note "$job")"
"$dembuf" fetch "$job" --out "$work/linked" --no-plots > /dev/null 2>&1 || true
[ "$(wc -l < "$work/linked/plate_force.csv")" -le 1 ] || fail "the database was stored as samples"

# 4. A real run on the fake cluster ends done.
export FAKE_SLURM_RUN=1
stop_daemon
start_daemon "$work/dembuf.db" "$work/dembufd.log" --config "$work/slurm.toml"
job=$("$dembuf" submit "${bare[@]}")
wait_state "$job" "done failed" 120
[ "$(job_state "$job")" = done ] || fail "a real run on the fake cluster: $("$dembuf" status "$job")"
"$dembuf" status "$job" --json | grep -q result_nonce && fail "the nonce was stored with the result"
echo "hostile node test passed"
