#!/usr/bin/env bash
# The Debian package (CPack, cmake/Packaging.cmake) installs with apt, works from /usr/bin (a
# first run, the Python package, the manual pages, the completion), its daemon starts and
# stops by its installed unit's command (where systemd is not running, as in a container), and
# it is removed without a file left behind. Skipped (77) where it cannot install: not root,
# or dembuf already installed on this machine.
# Usage: deb_test.sh BUILD_DIR
set -euo pipefail
build=$1
[ "$(id -u)" = 0 ] || { echo "SKIP: installing a package needs root"; exit 77; }
if dpkg-query -W -f='${Status}' dembuf 2> /dev/null | grep -q "install ok installed"; then
  echo "SKIP: a dembuf package is installed on this machine; the test would replace it"
  exit 77
fi
# apt as deploy/install-deps.sh runs it, waiting for dpkg's lock (the tests run in parallel,
# and another may be installing what it needs).
apt=(apt-get -o DPkg::Lock::Timeout=600)
work=$(mktemp -d)
chmod 0755 "$work"
had_user=$(getent passwd dembuf > /dev/null && echo yes || echo no)
daemon=""
cleanup() {
  [ -z "$daemon" ] || kill -9 "$daemon" 2> /dev/null || true
  "${apt[@]}" remove --purge -y -qq dembuf > /dev/null 2>&1 || true
  if [ "$had_user" = no ]; then
    userdel dembuf 2> /dev/null || true
    rm -rf /var/lib/dembuf /var/log/dembuf
  fi
  rm -rf "$work"
}
trap cleanup EXIT
fail() { echo "FAIL: $*"; [ ! -f /var/log/dembuf/dembufd.log ] || tail -5 /var/log/dembuf/dembufd.log; exit 1; }

(cd "$work" && cpack -G DEB --config "$build/CPackConfig.cmake" > cpack.log 2>&1) ||
  { cat "$work/cpack.log"; fail "cpack"; }
deb=$(ls "$work"/dembuf_*.deb)
contents=$(dpkg-deb -c "$deb")
for path in ./usr/bin/dembuf ./usr/bin/dembufd ./usr/share/man/man1/dembuf.1 \
  ./usr/share/man/man1/dembufd.1 ./usr/share/bash-completion/completions/dembuf \
  ./usr/share/bash-completion/completions/dembufd ./usr/lib/systemd/system/dembufd.service \
  ./etc/dembuf/dembufd.toml /dembuf/__init__.py /dembuf/v1/dembuf_pb2.py; do
  grep -q -- "$path" <<< "$contents" || fail "the package lacks $path"
done
depends=$(dpkg-deb -f "$deb" Depends)
for needed in libgrpc python3-pandas libsqlite3; do
  grep -q "$needed" <<< "$depends" || fail "Depends lacks $needed: $depends"
done
# (Listed whole, then searched: grep -q stopping early would fail tar's write under pipefail.)
control=$(dpkg-deb --ctrl-tarfile "$deb" | tar -t)
grep -q conffiles <<< "$control" || fail "no conffiles: $control"

# Installed by apt, its dependencies already on this machine (no download).
"${apt[@]}" install -y -qq --no-install-recommends "$deb" > "$work/apt.log" 2>&1 ||
  { cat "$work/apt.log"; fail "apt install"; }
dpkg-query -L dembuf > "$work/files"
[ "$(/usr/bin/dembuf --version)" = "$("$build/client/dembuf" --version)" ] || fail "dembuf --version"
getent passwd dembuf > /dev/null || fail "postinst made no user dembuf"
MANPATH=/usr/share/man man -w dembuf > /dev/null || fail "man dembuf"
bash -c '. /usr/share/bash-completion/completions/dembuf && complete -p dembuf' > /dev/null ||
  fail "the completion"

# A first run, from /usr/bin, and its folder read by the installed Python package.
cd "$work"
env -u PYTHONPATH /usr/bin/dembuf run --preset e2 --set bed.thickness_m=0 --no-plots --out "$work/first" > "$work/run.log" 2>&1 || { cat "$work/run.log"; fail "dembuf run"; }
env -u PYTHONPATH /usr/bin/python3 -c "
import dembuf, sys
assert dembuf.__file__.startswith('/usr/lib/'), dembuf.__file__
samples = len(dembuf.read_run('$work/first').series)
assert samples > 10, samples
print(samples, 'samples read by', dembuf.__file__)" ||
  fail "the installed Python package"

# The daemon by its unit's command (ExecStart), as the unit's user, in the unit's folders.
exec_start=$(sed -n 's/^ExecStart=//p' /usr/lib/systemd/system/dembufd.service)
read -r -a command <<< "$exec_start"
# As the unit's User and Group (setpriv execs the program: started in the background by its
# own name, not through this function, $! is the daemon).
as_dembuf() { setpriv --reuid dembuf --regid dembuf --init-groups "$@"; }
[ "${command[0]}" = /usr/bin/dembufd ] || fail "ExecStart names ${command[0]}"
[ "$(stat -c %U /var/lib/dembuf)" = dembuf ] || fail "postinst made no /var/lib/dembuf of dembuf's"
as_dembuf "${command[@]}" --check-config > "$work/config.txt" || fail "--check-config"
grep -q '^db = "/var/lib/dembuf/dembuf.db"' "$work/config.txt" || fail "the installed configuration"
token=$(as_dembuf "${command[@]}" token-create alice 2> /dev/null) || fail "token-create"
log=/var/log/dembuf/dembufd.log
before=$( (wc -l < "$log" || echo 0) 2> /dev/null)  # (a log of an earlier start names its port)
setpriv --reuid dembuf --regid dembuf --init-groups "${command[@]}" --listen 127.0.0.1:0 \
  2> "$work/daemon.err" &
daemon=$!
port=""
for _ in $(seq 600); do  # (up to a minute: a loaded machine starts it slowly)
  kill -0 "$daemon" 2> /dev/null || fail "the daemon exited: $(cat "$work/daemon.err")"
  port=$( (tail -n +$((before + 1)) "$log" || true) 2> /dev/null |
    sed -n 's/.*listening on .* (port \([0-9]*\)).*/\1/p')
  [ -n "$port" ] && break
  sleep 0.1
done
[ -n "$port" ] || fail "the daemon did not start: $(cat "$work/daemon.err")"
DEMBUF_TOKEN=$token timeout 60 /usr/bin/dembuf --server "127.0.0.1:$port" server-info > "$work/info.txt" ||
  fail "server-info"
kill -TERM "$daemon"  # the unit's KillSignal
for _ in $(seq 300); do kill -0 "$daemon" 2> /dev/null || break; sleep 0.1; done
kill -0 "$daemon" 2> /dev/null && fail "the daemon did not stop within 30 s of SIGTERM"
wait "$daemon" || fail "the daemon did not stop cleanly on SIGTERM"
daemon=""

# Removed: not a file of the package left (the data folders are the lab's, and stay).
"${apt[@]}" remove --purge -y -qq dembuf > "$work/apt.log" 2>&1 ||
  { cat "$work/apt.log"; fail "apt remove"; }
while read -r path; do
  [ -d "$path" ] || [ ! -e "$path" ] || fail "$path is left after the purge"
done < "$work/files"
echo "deb: built, installed by apt, ran from /usr/bin, daemon started and stopped, removed"
