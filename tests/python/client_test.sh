#!/usr/bin/env bash
# The Python package against a real dembufd (tests/python/test_client.py), with Debian's
# python3, for which python3-grpcio and python3-pandas are installed.
# Usage: client_test.sh DEMBUF DEMBUFD PYTHON_DIR (the build's python folder)
. "$(dirname "$0")/../server/lib.sh" "$1" "$2"
start_daemon "$work/dembuf.db" "$work/dembufd.log"
small_scene "$work/small.toml"
PYTHONPATH="$3" DEMBUF_CLI="$dembuf" DEMBUF_TEST_WORK="$work" DEMBUF_TEST_SCENE="$work/small.toml" \
  /usr/bin/python3 "$(dirname "$0")/test_client.py" -v ||
  fail "the Python client"
