#!/usr/bin/env bash
# Installs dembuf and dembufd under /usr/local, a system user `dembuf`, the configuration
# /etc/dembuf/dembufd.toml (kept if present) and the systemd unit, then starts the daemon.
# Run as root after deploy/build.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
[ "$(id -u)" = 0 ] || { echo "install-service.sh: run as root" >&2; exit 1; }
[ -x build/server/dembufd ] || { echo "install-service.sh: build first: bash deploy/build.sh" >&2; exit 1; }
cmake --install build --prefix /usr/local
id dembuf > /dev/null 2>&1 || useradd --system --home-dir /var/lib/dembuf --shell /usr/sbin/nologin dembuf
install -d -m 0755 /etc/dembuf
[ -f /etc/dembuf/dembufd.toml ] || install -m 0644 deploy/dembufd.toml /etc/dembuf/dembufd.toml
install -m 0644 deploy/dembufd.service /etc/systemd/system/dembufd.service
systemctl daemon-reload
systemctl enable --now dembufd
systemctl --no-pager status dembufd | head -5
echo "dembufd runs. Make a token (sudo -u dembuf dembufd --config /etc/dembuf/dembufd.toml token-create NAME --admin), then: DEMBUF_TOKEN=... dembuf server-info"
