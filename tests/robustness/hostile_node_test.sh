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
#   no link is followed; the job is cancelled and fails saying so. (While it ran, the error
#   stopped the following of every other job: one beside it that ended was not taken.)
# - a samples.bin of 100,000 samples from a run that writes at most 502 was read whole, a few
#   MB a look: now the job is cancelled on Slurm at the first sample past its estimate, and
#   fails saying so.
# - a pushed bed was written to the cluster's bed cache as HASH.bed.tmp, through a link of
#   that name: now under a name of its own, made exclusively, and renamed into place.
# - result files of any size up to twice the output quota were taken from a node: now up to
#   the job's estimate of its files.
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
# The nonce a job was submitted with (in sbatch's environment, never on its command line).
nonce_of() { cat "$FAKE_SLURM_DIR/jobs/$1/nonce"; }
ends() { echo COMPLETED > "$FAKE_SLURM_DIR/jobs/$slurm_id/state"; wait_state "$1" "done failed" 60; }
note() { "$dembuf" status "$1" | sed -n 's/^note: //p'; }

# 1. A result without the script's nonce.
job=$("$dembuf" submit "${bare[@]}")
node "$job"
grep -q "$(nonce_of "$slurm_id")" "$FAKE_SLURM_DIR/jobs/$slurm_id/args" && fail "the nonce is on sbatch's command line"
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

# 3. samples.bin as a link to the database, while another job ends beside it.
job=$("$dembuf" submit "${bare[@]}")
node "$job"
linked_slurm=$slurm_id
ln -s "$work/dembuf.db" "$folder/samples.bin"
other=$("$dembuf" submit "${bare[@]}")
node "$other"
printf '{"result_nonce": "%s"}\n' "$(nonce_of "$slurm_id")" > "$folder/summary.new"
mv "$folder/summary.new" "$folder/out/summary.json"
echo RUNNING > "$FAKE_SLURM_DIR/jobs/$linked_slurm/state"
echo COMPLETED > "$FAKE_SLURM_DIR/jobs/$slurm_id/state"
wait_state "$other" "done failed" 30
[ "$(job_state "$other")" = done ] || fail "the job beside: $(note "$other")"
wait_state "$job" "failed" 30
note "$job" | grep -q "symbolic link" || fail "linked samples: $(note "$job")"
[ "$(cat "$FAKE_SLURM_DIR/jobs/$linked_slurm/state")" = CANCELLED ] ||
  fail "the job whose samples.bin is a link was left running on Slurm"
"$dembuf" fetch "$job" --out "$work/linked" --no-plots > /dev/null 2>&1 || true
[ "$(wc -l < "$work/linked/plate_force.csv")" -le 1 ] || fail "the database was stored as samples"

# 3b. samples.bin far longer than its run may write (the bare plate's estimate: 502 samples):
#   it was read to the end, a few MB a look, into the store; now the job is cancelled on
#   Slurm and fails saying so, and no more than its estimate is kept.
job=$("$dembuf" submit "${bare[@]}")
node "$job"
head -c $((100000 * 48)) /dev/zero > "$folder/samples.new"
mv "$folder/samples.new" "$folder/samples.bin"
echo RUNNING > "$FAKE_SLURM_DIR/jobs/$slurm_id/state"
wait_state "$job" "done failed" 60
[ "$(job_state "$job")" = failed ] || fail "100,000 samples were taken from a run that writes 502"
note "$job" | grep -q "holds more samples than its run may write" || fail "long samples: $(note "$job")"
[ "$(cat "$FAKE_SLURM_DIR/jobs/$slurm_id/state")" = CANCELLED ] || fail "the Slurm job was left running"
"$dembuf" fetch "$job" --out "$work/long" --no-plots > /dev/null 2>&1 || true
[ "$(cat "$work/long/plate_force.csv" 2> /dev/null | wc -l)" -le 504 ] || fail "more samples than the estimate were stored"

# 3d. Result files far larger than the run writes (20 MB of snapshots from a bare-plate run
#   whose estimate is a few kB): they were taken up to twice the output quota (2 GB); now up
#   to the job's estimate, the job failing with the reason.
job=$("$dembuf" submit "${bare[@]}")
node "$job"
mkdir -p "$folder/out/snapshots/peak"
head -c $((20 << 20)) /dev/zero > "$folder/out/snapshots/peak/beads.vtp"
printf '{"result_nonce": "%s"}\n' "$(nonce_of "$slurm_id")" > "$folder/summary.new"
mv "$folder/summary.new" "$folder/out/summary.json"
ends "$job"
[ "$(job_state "$job")" = failed ] || fail "20 MB of result files were taken from a bare-plate run"
note "$job" | grep -q "the result files pass" || fail "large result files: $(note "$job")"

# 3c. Links where a pushed bed goes in the cluster's bed cache, and where it was written first
#   (HASH.bed.tmp, a name anyone could foresee): neither is written through.
small_scene "$work/small.toml"
"$dembuf" prepare-bed "$work/small.toml" --bed-cache "$work/local-beds" > "$work/prepared" 2>&1 ||
  fail "prepare-bed: $(cat "$work/prepared")"
cut=$(sed -n 's/^cut bed \([0-9a-f]*\).*/\1/p' "$work/prepared")
echo "the daemon's own file" > "$work/victim"
for name in "$cut.bed" "$cut.bed.tmp"; do
  ln -s "$work/victim" "$work/shared/beds/$name" || fail "cannot plant the link $name"
done
"$dembuf" bed push "$work/small.toml" --bed-cache "$work/local-beds" > "$work/push" 2>&1 ||
  fail "push: $(cat "$work/push")"
[ "$(cat "$work/victim")" = "the daemon's own file" ] || fail "the pushed bed was written through a link"
[ -f "$work/shared/beds/$cut.bed" ] && [ ! -L "$work/shared/beds/$cut.bed" ] ||
  fail "the link was left in the bed cache"
cmp -s "$work/shared/beds/$cut.bed" "$work/local-beds/$cut.bed" || fail "the pushed bed differs"

# 4. A real run on the fake cluster ends done.
export FAKE_SLURM_RUN=1
stop_daemon
start_daemon "$work/dembuf.db" "$work/dembufd.log" --config "$work/slurm.toml"
job=$("$dembuf" submit "${bare[@]}")
wait_state "$job" "done failed" 120
[ "$(job_state "$job")" = done ] || fail "a real run on the fake cluster: $("$dembuf" status "$job")"
"$dembuf" status "$job" --json | grep -q result_nonce && fail "the nonce was stored with the result"
echo "hostile node test passed"
