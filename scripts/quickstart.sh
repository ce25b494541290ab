#!/usr/bin/env bash
# Quick start: install the dependencies (Debian 12), build cfuse and run `cfuse demo`.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DBUILD_TESTING=OFF
cmake --build build -j"$(nproc)" --target cfuse_exe
./build/cli/cfuse demo
