#!/usr/bin/env bash
# No work before a token: floods at dembufd's port beside a user's calls (floods.py).
# Usage: floods_test.sh DEMBUF DEMBUFD SOURCE_DIR
set -euo pipefail
command -v haproxy > /dev/null || bash "$3/deploy/install-deps.sh" haproxy > /dev/null
exec /usr/bin/python3 "$(dirname "$0")/floods.py" "$1" "$2" "$(dirname "$1")/../python" "$3"
