#!/usr/bin/env bash
# A stand-in for Slurm's commands, for tests of dembufd's Slurm executor that play the cluster
# themselves: sbatch, squeue, scontrol and scancel (this script under each name, in PATH).
# It keeps its jobs in $FAKE_SLURM_DIR/jobs/ID/ (name, state, chdir, wrap, args, and the
# DEMBUF_RESULT_NONCE of the environment it was submitted with) and runs
# nothing unless FAKE_SLURM_RUN=1, when sbatch runs the job's --wrap script in its folder in
# the background (after the jobs of its --dependency=afterok have COMPLETED). Otherwise a test
# is the node: it writes what a job would leave and sets the job's state with
#   fake_slurm_state ID STATE      (FAKE_SLURM_DIR/jobs/ID/state)
set -euo pipefail
dir=${FAKE_SLURM_DIR:?FAKE_SLURM_DIR must name the fake cluster folder}
mkdir -p "$dir/jobs"
line() {  # id|name|state|reason|node
  local j=$dir/jobs/$1
  printf '%s|%s|%s|None|fakenode\n' "$1" "$(cat "$j/name")" "$(cat "$j/state")"
}
case $(basename "$0") in
  sbatch)
    name="" chdir="" output="" wrap="" after=""
    for arg in "$@"; do
      case $arg in
        --job-name=*) name=${arg#*=} ;;
        --chdir=*) chdir=${arg#*=} ;;
        --output=*) output=${arg#*=} ;;
        --wrap=*) wrap=${arg#*=} ;;
        --dependency=afterok:*) after=${arg#*afterok:} ;;
      esac
    done
    exec 9> "$dir/lock"
    flock 9
    id=$(( $(cat "$dir/next" 2> /dev/null || echo 100) + 1 ))
    echo "$id" > "$dir/next"
    mkdir "$dir/jobs/$id"
    printf '%s' "$name" > "$dir/jobs/$id/name"
    printf '%s' "$chdir" > "$dir/jobs/$id/chdir"
    printf '%s' "$wrap" > "$dir/jobs/$id/wrap"
    printf '%s\n' "$@" > "$dir/jobs/$id/args"
    printf '%s' "${DEMBUF_RESULT_NONCE:-}" > "$dir/jobs/$id/nonce"  # as the job's environment has it
    echo PENDING > "$dir/jobs/$id/state"
    flock -u 9
    if [ "${FAKE_SLURM_RUN:-0}" = 1 ]; then
      (
        for a in ${after//:/ }; do
          until [ "$(cat "$dir/jobs/$a/state")" != PENDING ] && [ "$(cat "$dir/jobs/$a/state")" != RUNNING ]; do sleep 0.1; done
          [ "$(cat "$dir/jobs/$a/state")" = COMPLETED ] || { echo CANCELLED > "$dir/jobs/$id/state"; exit 0; }
        done
        echo RUNNING > "$dir/jobs/$id/state"
        rc=0
        (cd "$chdir" && exec bash -c "$wrap") >> "$output" 2>&1 || rc=$?
        [ "$(cat "$dir/jobs/$id/state")" = CANCELLED ] && exit 0
        if [ "$rc" = 0 ]; then echo COMPLETED; else echo FAILED; fi > "$dir/jobs/$id/state"
      ) > /dev/null 2>&1 &
      echo $! > "$dir/jobs/$id/pid"
    fi
    echo "$id"
    ;;
  squeue)
    ids="" mine=0
    while [ $# -gt 0 ]; do
      case $1 in
        -j) ids=${2//,/ }; shift ;;
        --me) mine=1 ;;
      esac
      shift
    done
    if [ "$mine" = 1 ]; then ids=$(ls "$dir/jobs"); fi
    for id in $ids; do [ -d "$dir/jobs/$id" ] && line "$id"; done
    exit 0
    ;;
  scontrol)  # scontrol show job -o ID
    id=${4:-}
    [ -n "$id" ] && [ -d "$dir/jobs/$id" ] || { echo "slurm_load_jobs error: Invalid job id specified" >&2; exit 1; }
    printf 'JobId=%s JobName=%s JobState=%s Reason=None NodeList=fakenode\n' "$id" \
      "$(cat "$dir/jobs/$id/name")" "$(cat "$dir/jobs/$id/state")"
    ;;
  scancel)
    id=$1
    [ -d "$dir/jobs/$id" ] || exit 0
    echo CANCELLED > "$dir/jobs/$id/state"
    if [ -f "$dir/jobs/$id/pid" ]; then pkill -TERM -P "$(cat "$dir/jobs/$id/pid")" 2> /dev/null || true; fi
    ;;
  *)
    echo "fake_slurm.sh: run me as sbatch, squeue, scontrol or scancel" >&2
    exit 2
    ;;
esac
