#!/usr/bin/env bash
# The Python package against a real dembufd (tests/python/test_client.py), with Debian's
# python3, for which python3-grpcio and python3-pandas are installed.
# Then the same package with a token over TLS.
# Usage: client_test.sh DEMBUF DEMBUFD PYTHON_DIR (the build's python folder)
. "$(dirname "$0")/../server/lib.sh" "$1" "$2"
start_daemon "$work/dembuf.db" "$work/dembufd.log"
small_scene "$work/small.toml"
PYTHONPATH="$3" DEMBUF_CLI="$dembuf" DEMBUF_TEST_WORK="$work" DEMBUF_TEST_SCENE="$work/small.toml" \
  /usr/bin/python3 "$(dirname "$0")/test_client.py" -v ||
  fail "the Python client"

# One owner rule: with $USER and $LOGNAME unset, the CLI and the package file jobs under the
# same name (the user id's; the CLI said "anonymous" where the package said "root").
cli_job=$(env -u USER -u LOGNAME "$dembuf" submit --set bed.thickness_m=0 --set time.end_s=0.001 \
  2>&1 | sed -n 's/^job \([0-9]*\) queued.*/\1/p')
[ -n "$cli_job" ] || fail "the CLI's submit without USER"
env -u USER -u LOGNAME PYTHONPATH="$3" /usr/bin/python3 - "$cli_job" <<'PY' || fail "one owner rule"
import pwd, os, sys
import dembuf
with dembuf.connect() as daemon:
    job = daemon.submit(set={"bed.thickness_m": 0, "time.end_s": 0.001})
    mine, cli = daemon.job(job)["owner"], daemon.job(int(sys.argv[1]))["owner"]
expected = pwd.getpwuid(os.getuid()).pw_name
assert mine == cli == expected, (mine, cli, expected)
print(f"without USER and LOGNAME both file jobs under {mine!r}")
PY

# Token and TLS, from the environment as the CLI takes them: a daemon that needs tokens over
# TLS (a certificate made here) answers the package with alice's token, files her job under
# her name, and refuses it without one.
stop_daemon
openssl req -x509 -newkey rsa:2048 -nodes -days 1 -subj "/CN=localhost" \
  -addext "subjectAltName=DNS:localhost,IP:127.0.0.1" \
  -keyout "$work/key.pem" -out "$work/cert.pem" 2> /dev/null || fail "openssl"
alice=$("$dembufd" --db "$work/auth.db" token-create alice 2>/dev/null)
printf 'access = "tokens"\ntls_cert = "%s"\ntls_key = "%s"\n' "$work/cert.pem" \
  "$work/key.pem" > "$work/auth.toml"
start_daemon "$work/auth.db" "$work/auth.log" --config "$work/auth.toml" --workers 1
PYTHONPATH="$3" DEMBUF_SERVER="localhost:${DEMBUF_SERVER##*:}" DEMBUF_TLS_CA="$work/cert.pem" \
  DEMBUF_TOKEN="$alice" /usr/bin/python3 - "$work/small.toml" <<'PY' || fail "token and TLS"
import os, sys
import dembuf
with dembuf.connect() as daemon:
    assert daemon.server_info()["version"], "no version"
    job = daemon.submit(toml=sys.argv[1], set={"time.end_s": 0.001})
    assert daemon.job(job)["owner"] == "alice", daemon.job(job)
os.environ.pop("DEMBUF_TOKEN")
with dembuf.connect() as anonymous:
    try:
        anonymous.server_info()
        sys.exit("a request without a token was answered")
    except dembuf.DembufError as e:
        assert e.code == "UNAUTHENTICATED", e
print("token and TLS: alice's job filed under her name; no token refused")
PY
