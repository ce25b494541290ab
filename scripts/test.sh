#!/usr/bin/env bash
# Installs the dependencies (Debian 12), builds everything and runs the whole test suite
# through ctest; then builds the suite again with AddressSanitizer and UndefinedBehaviorSanitizer
# (build-asan/) and runs all of it there too, fuzz replays included. This is what CI runs
# (.ci/run). `--no-sanitize` skips the second build (a quick local check).
set -euo pipefail
cd "$(dirname "$0")/.."
sanitize=1
[ "${1:-}" = "--no-sanitize" ] && sanitize=0
bash scripts/install-deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DBUILD_TESTING=ON -DCFUSE_BUILD_BENCHMARKS=ON
cmake --build build -j"$(nproc)"
ctest --test-dir build --output-on-failure -j"$(nproc)"
[ "$sanitize" -eq 1 ] || exit 0

# Any sanitizer report fails its test (-fno-sanitize-recover=all), leaks included.
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=Release -DBUILD_TESTING=ON \
  -DCFUSE_BUILD_BENCHMARKS=OFF -DCFUSE_SANITIZE=address,undefined
cmake --build build-asan -j"$(nproc)"
ctest --test-dir build-asan --output-on-failure -j"$(nproc)"
