#!/usr/bin/env bash
# Installs dembuf and dembufd under /usr/local (with their manual pages, completion and Python
# package), a system user `dembuf`, the configuration /etc/dembuf/dembufd.toml (kept if
# present) and the systemd unit, then starts the daemon. Run as root after deploy/build.sh.
# (The Debian package of deploy/package.sh installs the same under /usr.)
set -euo pipefail
cd "$(dirname "$0")/.."
[ "$(id -u)" = 0 ] || { echo "install-service.sh: run as root" >&2; exit 1; }
[ -x build/server/dembufd ] || { echo "install-service.sh: build first: bash deploy/build.sh" >&2; exit 1; }
cmake --install build --prefix /usr/local
# The unit (in /usr/local/lib/systemd/system) and the configuration: a configuration already
# there is the lab's and stays.
kept=""
if [ -f /etc/dembuf/dembufd.toml ]; then
  kept=$(mktemp)
  cp -p /etc/dembuf/dembufd.toml "$kept"
  # Put back whatever happens below (a failed install, Ctrl-C).
  trap 'mv "$kept" /etc/dembuf/dembufd.toml' EXIT
fi
cmake --install build --prefix /usr/local --component service
id dembuf > /dev/null 2>&1 || useradd --system --user-group --home-dir /var/lib/dembuf --shell /usr/sbin/nologin dembuf
systemctl daemon-reload
systemctl enable --now dembufd
systemctl --no-pager status dembufd | head -5
echo "dembufd runs. Make a token (sudo -u dembuf dembufd --config /etc/dembuf/dembufd.toml token-create NAME --admin), then: DEMBUF_TOKEN=... dembuf server-info"
