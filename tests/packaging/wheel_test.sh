#!/usr/bin/env bash
# The Python wheel (deploy/python-wheel.sh) installs with pip into a fresh venv, and there, away
# from the source and build trees, `import dembuf` and the readers work without gRPC; the
# client says what to install; with gRPC (Debian's, seen through --system-site-packages) it
# imports.
# Usage: wheel_test.sh DEMBUF PYTHON_DIR SOURCE_DIR
set -euo pipefail
dembuf=$1
python_dir=$2
src=$3
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }

wheel=$(bash "$src/deploy/python-wheel.sh" "$python_dir" "$work/dist") || fail "the wheel did not build"
version=$("$dembuf" --version | awk '{print $2}')
[ "$(basename "$wheel")" = "dembuf-$version-py3-none-any.whl" ] || fail "wheel named $(basename "$wheel")"
# (The citation's version is written by hand: it must be the program's.)
grep -qx "version: \"$version\"" "$src/CITATION.cff" || fail "CITATION.cff's version is not $version"
contents=$(/usr/bin/python3 -m zipfile -l "$wheel")
for file in dembuf/__init__.py dembuf/_version.py dembuf/frames.py dembuf/v1/dembuf_pb2.py \
  dembuf/v1/dembuf_pb2_grpc.py; do
  grep -q " *$file " <<< "$contents" || grep -q "^$file " <<< "$contents" || fail "the wheel lacks $file"
done
metadata=$(/usr/bin/python3 - "$wheel" <<'PY'
import sys, zipfile
with zipfile.ZipFile(sys.argv[1]) as w:
    name = next(n for n in w.namelist() if n.endswith(".dist-info/METADATA"))
    print(w.read(name).decode())
PY
)
for line in "Requires-Dist: numpy" "Requires-Dist: pandas" "Requires-Dist: grpcio.*extra == .server." \
  "Requires-Dist: protobuf.*extra == .server."; do
  grep -q "^$line" <<< "$metadata" || fail "METADATA lacks $line"
done

# A venv that sees Debian's numpy and pandas (PyPI is not reached: --no-index).
/usr/bin/python3 -m venv --system-site-packages "$work/venv"
"$work/venv/bin/pip" install --quiet --no-index "$wheel" || fail "pip install of the wheel"
"$dembuf" run --preset e2 --set bed.thickness_m=0 --no-plots --out "$work/first" \
  > /dev/null || fail "the local run"

cd "$work"
env -u PYTHONPATH "$work/venv/bin/python" - "$work" "$version" <<'PY' || fail "the wheel without gRPC"
import sys
# As if grpc and protobuf were not installed: an import of either fails.
for name in ("grpc", "google.protobuf"):
    sys.modules[name] = None
import dembuf
work, version = sys.argv[1], sys.argv[2]
assert dembuf.__file__.startswith(work + "/venv/"), dembuf.__file__
assert dembuf.__version__ == version, (dembuf.__version__, version)
run = dembuf.read_run(work + "/first")
assert len(run.series) > 10 and "plate_force_N" in run.series.columns, run.series
try:
    dembuf.connect()
    raise SystemExit("connect() without gRPC did not fail")
except ImportError as e:
    assert "[server]" in str(e) and "python3-grpcio" in str(e) and "read_run" in str(e), str(e)
print(f"dembuf {dembuf.__version__} from the wheel read {len(run.series)} samples without gRPC")
PY
env -u PYTHONPATH "$work/venv/bin/python" -c "from dembuf import Client, connect; print('with gRPC: the client imports')" ||
  fail "the client with gRPC"
echo "wheel: built, installed in a venv, readers without gRPC, the client with it"
