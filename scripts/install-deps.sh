#!/usr/bin/env bash
# Installs cfuse's build and test dependencies from Debian 12's packages.
# Idempotent: apt-get skips what is already installed. Run as root (or with sudo).
#   --fuzz  also clang and its libFuzzer runtime, for scripts/fuzz.sh only
set -euo pipefail

packages=(
  build-essential cmake pkgconf git ca-certificates
  libeigen3-dev        # linear algebra, AutoDiff module (kernel, constraints)
  libsuitesparse-dev   # SuiteSparseQR: ranks of sparse Jacobians (kernel's fit analysis)
  libyaml-cpp-dev      # model DSL parser (dsl)
  liburdfdom-dev       # URDF import (importers)
  libtinyxml-dev       # urdfdom's XML parser, read first for error locations (importers)
  libconsole-bridge-dev  # urdfdom's logging, captured into error messages (importers)
  libopencv-dev        # cameras, PnP, images (vision, cli)
  libcli11-dev         # command-line parsing (cli)
  nlohmann-json3-dev   # measurement and result files (cli, io)
  libfmt-dev           # message formatting (everywhere)
  catch2               # unit tests (v2, with ctest integration)
  libbenchmark-dev     # benchmarks (bench)
  libvisp-mbt-dev      # (bench only: ViSP's edge tracker as a peer)
  libceres-dev         # (bench only: Ceres on the robots' parametric problems, a peer)
  visp-images-data     # ViSP's public sequences, models and cameras: tracking tests and benchmarks
  graphviz             # renders `cfuse graph` output in tests
  python3-dev pybind11-dev  # the Python module (python/)
  python3-numpy        # the Python module's arrays
  python3-pytest       # the Python module's tests
  python3-matplotlib   # docs/python.md's worked example (its picture)
)
if [ "${1:-}" = "--fuzz" ]; then
  packages+=(clang libclang-rt-14-dev)  # libFuzzer, with ASan and UBSan (scripts/fuzz.sh)
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi

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
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
