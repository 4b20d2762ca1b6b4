# Shared by the robustness scripts: the service tests' helpers (tests/server/lib.sh: a daemon
# on a free port, job states, a small scene) and expect_exit.
# Sourced as `. lib.sh DEMBUF DEMBUFD`.
. "$(dirname "${BASH_SOURCE[0]}")/../server/lib.sh" "$1" "$2"

# expect_exit CODE PATTERN COMMAND...: the command exits with CODE (killed after 60 s: a
# hang is a failure too) and says PATTERN, a grep pattern, on stdout or stderr.
expect_exit() {
  local want=$1 pattern=$2
  shift 2
  local code=0
  timeout -s KILL 60 "$@" > "$work/out" 2> "$work/err" || code=$?
  [ "$code" = "$want" ] || fail "'$*' exited $code, not $want: $(head -c 400 "$work/err")"
  grep -q -- "$pattern" "$work/out" "$work/err" ||
    fail "'$*' did not say '$pattern': $(head -c 400 "$work/err")"
}
