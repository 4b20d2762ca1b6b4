#!/usr/bin/env bash
# Builds the dembuf wheel from a build tree's python folder (the package, its generated gRPC
# stubs and version, pyproject.toml) with pip and setuptools, offline: no build isolation, no
# dependencies fetched. The CMake target dembuf_wheel and the wheel test call it.
# Usage: deploy/python-wheel.sh PYTHON_DIR OUT_DIR   (prints the wheel's path)
set -euo pipefail
python_dir=$1
out=$2
[ -f "$python_dir/pyproject.toml" ] && [ -f "$python_dir/dembuf/_version.py" ] ||
  { echo "python-wheel.sh: $python_dir is not a built python folder (build first)" >&2; exit 1; }
mkdir -p "$out"
# setuptools writes its build/ and egg-info beside the sources: a copy keeps the tree clean.
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cp -r "$python_dir/pyproject.toml" "$python_dir/README.md" "$python_dir/dembuf" "$work/"
find "$work" -name __pycache__ -prune -exec rm -rf {} +
version=$(sed -n 's/^__version__ = "\(.*\)"$/\1/p' "$python_dir/dembuf/_version.py")
rm -f "$out/dembuf-$version-"*.whl
/usr/bin/python3 -m pip wheel --quiet --no-deps --no-build-isolation --no-index \
  --wheel-dir "$out" "$work" >&2
ls "$out/dembuf-$version-"*.whl
