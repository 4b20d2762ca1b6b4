#!/usr/bin/env bash
# Set-up command 3: builds dembuf (deploy/build.sh), then the Debian package and the Python
# wheel from that build: build/dembuf_VERSION_ARCH.deb (the programs, manual pages, bash
# completion, Python package, systemd unit and /etc/dembuf/dembufd.toml) and
# build/dist/dembuf-VERSION-py3-none-any.whl. Install them with
#   sudo apt install ./build/dembuf_*.deb
#   python3 -m venv .venv && .venv/bin/pip install build/dist/dembuf-*.whl
#   (the readers; "build/dist/dembuf-VERSION-py3-none-any.whl[server]" adds the client's gRPC)
set -euo pipefail
cd "$(dirname "$0")/.."
bash deploy/build.sh
cmake --build build --target dembuf_wheel
(cd build && cpack -G DEB > /dev/null)
ls build/dembuf_*.deb build/dist/dembuf-*.whl
