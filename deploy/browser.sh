#!/usr/bin/env bash
# A headless browser for the web pages' test (tests/web/): Debian's Chromium, installed when
# missing, and puppeteer-core, the library that drives it, at the version tests/web's
# lockfile pins (npm ci; it downloads no browser of its own). Safe to run again.
# Prints the browser's path.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
web_tests="$here/../tests/web"
command -v node > /dev/null || bash "$here/install-deps.sh" nodejs >&2
command -v npm > /dev/null || bash "$here/install-deps.sh" npm >&2
bash "$here/install-deps.sh" chromium >&2
# npm ci again only when the lockfile changed since the last install.
if ! cmp -s "$web_tests/package-lock.json" "$web_tests/node_modules/.dembuf-installed-lock"; then
  (cd "$web_tests" && npm ci --no-audit --no-fund --loglevel=error >&2)
  cp "$web_tests/package-lock.json" "$web_tests/node_modules/.dembuf-installed-lock"
fi
command -v chromium
