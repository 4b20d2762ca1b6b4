#!/usr/bin/env bash
# Item 6 of the robustness suite (docs/robustness.md): one daemon per database and per port.
# - A second dembufd on the same port started too (gRPC shares ports with SO_REUSEPORT) and
#   the two split the requests; two daemons on one database both ran the same jobs. Now the
#   second is refused at start, naming the first (its process id).
# - A read-only database aborted the daemon at its first job: now refused at start with the
#   reason (a read-only tmpfs when run as root, else a file without write permission).
# - A port of 99999 silently became another port: now refused with the allowed range.
# Usage: instances_test.sh DEMBUF DEMBUFD
. "$(dirname "$0")/lib.sh" "$1" "$2"

start_daemon "$work/one.db" "$work/one.log"
port=${DEMBUF_SERVER##*:}
expect_exit 1 "127.0.0.1:$port is in use by process $daemon_pid" "$dembufd" --listen "127.0.0.1:$port" --db "$work/two.db"
expect_exit 1 "one.db is in use by another dembufd: process $daemon_pid, listening on 127.0.0.1:$port" \
  "$dembufd" --listen 127.0.0.1:0 --db "$work/one.db"
"$dembuf" server-info | grep -q "database $work/one.db" || fail "the first daemon stopped serving"
job=$("$dembuf" submit 2>/dev/null)
wait_state "$job" done 60
# The lock is the database file's, not its name's: a second daemon through a symlink or a hard
# link to the same file was started and ran the first one's jobs again. A link is not followed
# at all now (docs/robustness.md, the daemon owns its state); a hard link meets the lock.
ln -s "$work/one.db" "$work/symlink.db"
ln "$work/one.db" "$work/hardlink.db"
expect_exit 1 "symlink.db is a symbolic link: dembufd follows no link to its own files" \
  "$dembufd" --listen 127.0.0.1:0 --db "$work/symlink.db"
expect_exit 1 "hardlink.db is in use by another dembufd: process $daemon_pid" \
  "$dembufd" --listen 127.0.0.1:0 --db "$work/hardlink.db"
stop_daemon
# Its lock goes with it: the database is free again.
start_daemon "$work/one.db" "$work/one.log"
stop_daemon

expect_exit 2 "listen: port 99999 is out of range: must be 0 to 65535" "$dembufd" --listen 127.0.0.1:99999 --db "$work/p.db"
expect_exit 2 "listen: \"localhost\" must be HOST:PORT" "$dembufd" --listen localhost --db "$work/p.db"

# TLS files that cannot serve were reported as "cannot listen on ...: in use": each is named
# as a TLS problem, with the file and what is wrong with it.
for name in a b; do
  openssl req -x509 -newkey rsa:2048 -nodes -days 1 -subj "/CN=localhost" \
    -keyout "$work/$name.key" -out "$work/$name.pem" 2> /dev/null || fail "openssl"
done
: > "$work/empty.pem"
mkdir "$work/folder.key"
tls() { expect_exit 1 "$1" "$dembufd" --listen 127.0.0.1:0 --db "$work/tls.db" --config "$2"; }
tls_config() { printf 'access = "local"\ntls_cert = "%s"\ntls_key = "%s"\n' "$1" "$2" > "$work/tls.toml"; }
tls_config "$work/a.pem" "$work/b.key"
tls "tls: tls_key $work/b.key is not the key of tls_cert $work/a.pem" "$work/tls.toml"
tls_config "$work/empty.pem" "$work/a.key"
tls "tls: tls_cert $work/empty.pem: empty" "$work/tls.toml"
tls_config "$work/a.pem" "$work/folder.key"
tls "tls: tls_key $work/folder.key: a folder, not a PEM file" "$work/tls.toml"
tls_config "$work/a.key" "$work/a.key"
tls "tls: tls_cert $work/a.key: holds no PEM certificate" "$work/tls.toml"
tls_config "$work/a.pem" "$work/missing.key"
tls "tls: tls_key $work/missing.key: no such file" "$work/tls.toml"
if grep -q "in use" "$work/err"; then fail "a TLS problem reported as a port in use"; fi

# A database dembufd cannot write.
if [ "$(id -u)" = 0 ] && mkdir "$work/ro" && mount -t tmpfs -o size=4m,mode=0700 tmpfs "$work/ro" 2> /dev/null; then
  trap 'rc=$?; [ -z "$daemon_pid" ] || kill -9 "$daemon_pid" 2>/dev/null || true
        umount "$work/ro" 2>/dev/null || true; rm -rf "$work"; exit $rc' EXIT
  cp "$work/one.db" "$work/ro/ro.db"
  mount -o remount,ro "$work/ro"
  expect_exit 1 "ro.db cannot be used: it cannot be written" "$dembufd" --listen 127.0.0.1:0 --db "$work/ro/ro.db"
  umount "$work/ro"
else
  cp "$work/one.db" "$work/ro.db"
  chmod 444 "$work/ro.db"
  expect_exit 1 "ro.db cannot be used: it cannot be written" "$dembufd" --listen 127.0.0.1:0 --db "$work/ro.db"
fi
echo "instances test passed"
