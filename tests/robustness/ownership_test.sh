#!/usr/bin/env bash
# The daemon owns its state (docs/robustness.md): tried as another local account would. The
# daemon runs as an account of its own and a second account attacks its folders; both are made
# here (CI runs as root; elsewhere the test is skipped, exit 77).
# - A database that the other account created first (0666, in a shared folder), or an empty
#   -wal she left beside the daemon's database, was adopted without a word: she read every job
#   and could add an admin. Now the daemon refuses to start, naming the path, owner, mode and fix.
# - The lock note and the log were opened through links: a file of the daemon's account was
#   overwritten, and log lines with a job's name were appended to its .bashrc. Now no link is
#   followed: the log is refused, the note replaced.
# - A Slurm work_dir the other account made first was used; one that could not be made aborted
#   the daemon with an uncaught exception after its port was bound. Now both are refused before
#   anything is served, with the reason.
# - A folder others may write (the database's, or work_dir) is refused with chmod's fix.
# Usage: ownership_test.sh DEMBUF DEMBUFD
. "$(dirname "$0")/lib.sh" "$1" "$2"
if [ "$(id -u)" != 0 ]; then
  echo "ownership test skipped: it needs root to make a second account"
  exit 77
fi
daemon_user=dembuf-test-daemon
other=dembuf-test-other
for account in "$daemon_user" "$other"; do
  id "$account" > /dev/null 2>&1 || useradd --system --no-create-home --shell /usr/sbin/nologin "$account"
done
chmod 0711 "$work"   # the accounts pass through the test's folder to their own
# as ACCOUNT COMMAND...: runs it as that account (setpriv execs it: a signal reaches it).
as() { local who=$1; shift; setpriv --reuid="$who" --regid="$who" --init-groups -- "$@"; }
# A shared folder, as /tmp is.
shared=$work/shared
mkdir -m 1777 "$shared"
# The daemon's own folder.
home=$work/daemon
install -d -m 0711 -o "$daemon_user" "$home"
# daemon_refused PATTERN FLAGS...: dembufd, as its account, exits 1 saying PATTERN, before it
# listens.
daemon_refused() {
  local pattern=$1
  shift
  local code=0
  as "$daemon_user" timeout -s KILL 60 "$dembufd" --listen 127.0.0.1:0 --access local "$@" \
    > "$work/out" 2>&1 || code=$?
  [ "$code" = 1 ] || fail "dembufd $*: exit $code, not 1: $(tail -3 "$work/out")"
  grep -q -- "$pattern" "$work/out" || fail "dembufd $*: did not say '$pattern': $(tail -3 "$work/out")"
  if grep -q "listening on" "$work/out"; then fail "dembufd $*: it listened first"; fi
}

# 1. A database the other account made first, in a shared folder.
as "$other" sh -c "umask 0; : > '$shared/dembuf.db'"
daemon_refused "the database folder $shared is shared with other accounts" --db "$shared/dembuf.db"
# ... or in a folder that is the daemon's now, but was open when she made it.
install -d -m 0777 -o "$daemon_user" "$home/db"
as "$other" sh -c "umask 0; : > '$home/db/dembuf.db'"
chmod 0700 "$home/db"
daemon_refused "$home/db/dembuf.db belongs to another account (owner $other, mode 0666)" --db "$home/db/dembuf.db"
rm "$home/db/dembuf.db"
# 2. An empty -wal of hers beside the daemon's database.
as "$daemon_user" "$dembufd" --db "$home/db/dembuf.db" token-list > /dev/null 2>&1 || fail "token-list"
install -m 0666 -o "$other" /dev/null "$home/db/dembuf.db-wal"
daemon_refused "dembuf.db-wal belongs to another account (owner $other" --db "$home/db/dembuf.db"
rm "$home/db/dembuf.db-wal"
# 3. A folder others may write.
install -d -m 0777 -o "$daemon_user" "$home/open"
daemon_refused "may be written by other accounts (owner $daemon_user, mode 0777): .* chmod go-w $home/open" \
  --db "$home/open/dembuf.db"

# 4. Links where the daemon writes: the log and the lock note. (Planted here as root: no other
# account can write the daemon's folder, which is what the refusals above make sure of.)
install -m 0600 -o "$daemon_user" /dev/null "$home/bashrc"
echo "untouched" > "$home/bashrc"
ln -s "$home/bashrc" "$home/db/dembufd.log"
daemon_refused "dembufd.log is a symbolic link" --db "$home/db/dembuf.db" --log-file "$home/db/dembufd.log"
rm "$home/db/dembufd.log"
for name in dembuf.db.lock dembuf.db.lock.new; do ln -s "$home/bashrc" "$home/db/$name"; done
setpriv --reuid="$daemon_user" --regid="$daemon_user" --init-groups -- "$dembufd" \
  --listen 127.0.0.1:0 --access local --db "$home/db/dembuf.db" --log-file "$home/db/dembufd.log" \
  > "$work/daemon.out" 2>&1 &
daemon_pid=$!
for _ in $(seq 100); do grep -q "listening on" "$work/daemon.out" && break; sleep 0.1; done
grep -q "listening on" "$work/daemon.out" || fail "the daemon did not start: $(tail -3 "$work/daemon.out")"
stop_daemon
[ "$(cat "$home/bashrc")" = untouched ] || fail "a link was followed: $(cat "$home/bashrc")"
[ ! -L "$home/db/dembuf.db.lock" ] || fail "the lock note is still a link"
[ "$(stat -c %a "$home/db/dembufd.log")" = 600 ] || fail "the log is not private"

# 5. A Slurm work_dir she made first, and one that cannot be made.
slurm_config() {
  printf 'access = "local"\nexecutor = "slurm"\n[slurm]\nwork_dir = "%s"\ndembuf = "%s"\n' "$1" "$dembuf" \
    > "$home/slurm.toml"
  chown "$daemon_user" "$home/slurm.toml"
}
as "$other" mkdir -m 0755 "$shared/slurm-work"
slurm_config "$shared/slurm-work"
daemon_refused "slurm.work_dir $shared/slurm-work belongs to $other (owner $other, mode 0755), but this dembufd runs as $daemon_user" \
  --db "$home/db/dembuf.db" --config "$home/slurm.toml"
slurm_config "$home/no/such/folder"
daemon_refused "slurm.work_dir $home/no/such/folder cannot be made" --db "$home/db/dembuf.db" \
  --config "$home/slurm.toml"
echo "ownership test passed"
