#!/usr/bin/env bash
# Replaces the vendored uPlot with VERSION from the npm registry (see README.md).
# Usage: update.sh VERSION
set -euo pipefail
version=${1:?usage: update.sh VERSION}
here=$(cd "$(dirname "$0")" && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
(cd "$work" && npm pack --silent "uplot@$version" > /dev/null && tar xzf "uplot-$version.tgz")
cp "$work/package/dist/uPlot.iife.min.js" "$work/package/dist/uPlot.min.css" "$here/"
cp "$work/package/LICENSE" "$here/uPlot.LICENSE"
echo "uplot $version: integrity $(npm view "uplot@$version" dist.integrity)"
