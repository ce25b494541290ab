#!/usr/bin/env bash
# Quick start: install the dependencies (Debian 12), build cfuse, install its Python package
# for Debian's python3 (`import cfuse` from any directory) and run `cfuse demo`.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DBUILD_TESTING=OFF
cmake --build build -j"$(nproc)" --target cfuse_exe cfuse_python
cmake --install build --component python
(cd / && /usr/bin/python3 -c "import cfuse; print('python: import cfuse from', cfuse.__file__)")
./build/cli/cfuse demo
