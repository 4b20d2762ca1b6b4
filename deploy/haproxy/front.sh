#!/usr/bin/env bash
# Starts haproxy in the foreground in front of a dembufd:
#   deploy/haproxy/front.sh FRONT BACKEND [WEB_FRONT WEB_BACKEND]
# (addresses host:port: where users connect, where dembufd listens; the same for its web
# pages). Installs haproxy when it is missing. Stop it with SIGTERM. docs/service.md, "In front
# of the daemon".
set -euo pipefail
[ $# = 2 ] || [ $# = 4 ] || {
  echo "usage: front.sh FRONT_ADDRESS DEMBUFD_ADDRESS [WEB_FRONT_ADDRESS DEMBUFD_WEB_ADDRESS]" >&2
  exit 2
}
here=$(cd "$(dirname "$0")" && pwd)
command -v haproxy > /dev/null || bash "$here/../install-deps.sh" haproxy > /dev/null
export DEMBUF_FRONT=$1 DEMBUF_BACKEND=$2
if [ $# = 4 ]; then export DEMBUF_WEB_FRONT=$3 DEMBUF_WEB_BACKEND=$4; fi
exec haproxy -db -f "$here/dembufd.cfg"
