#!/usr/bin/env bash
# Installs everything dembuf needs to build, test and plot on Debian 12 (bookworm) or newer,
# or, given package names, just those (deploy/slurm/up.sh asks for Slurm's this way).
# Safe to run again: apt-get skips what is already there.
set -euo pipefail

packages=("$@")
[ ${#packages[@]} -gt 0 ] || packages=(
  # toolchain
  g++ cmake ninja-build pkg-config
  # service
  libgrpc++-dev protobuf-compiler-grpc libprotobuf-dev protobuf-compiler libsqlite3-dev libssl-dev
  libcpp-httplib-dev
  openssl
  # engine and tools
  libeigen3-dev zlib1g-dev libspdlog-dev libfmt-dev libcli11-dev nlohmann-json3-dev libtoml11-dev
  # tests, fuzzers (clang's libFuzzer and OpenMP) and plots
  libgtest-dev libgmock-dev clang libclang-rt-dev libomp-dev gnuplot-nox python3
  # gRPC from Python (the tests' health check), HTTP/2 by hand (the flood tests); the manual
  # pages
  python3-grpcio python3-h2 help2man
  # the front proxy that holds against HTTP/2 rapid reset (deploy/haproxy/)
  haproxy
  # the Python package: data frames, the worked example's plots, VTK to read files back
  python3-pandas python3-matplotlib python3-vtk9
  # packaging: the Debian package (dpkg-shlibdeps) and the wheel, tried in a venv
  dpkg-dev python3-pip python3-venv python3-setuptools python3-wheel
  # LAMMPS: the peer of the speed benchmark, and the reader of exported beds
  lammps
)

sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi
echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
# Waiting for dpkg's lock rather than failing on it: the tests run in parallel, and two of them
# installing at once failed on it.
apt=("${sudo_cmd[@]}" apt-get -o DPkg::Lock::Timeout=600)
"${apt[@]}" update -qq
"${apt[@]}" install -y -qq --no-install-recommends "${missing[@]}"
