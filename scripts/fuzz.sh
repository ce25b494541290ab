#!/usr/bin/env bash
# Fuzzes every parser with libFuzzer: builds fuzz/*_fuzz.cpp with clang, ASan and UBSan in
# build-fuzz/, then runs each target for SECONDS (default 60) from its seed corpus
# (fuzz/corpora.txt) and its past findings (fuzz/regressions/<target>/), one after the other.
#
#   scripts/fuzz.sh [SECONDS] [TARGET...]      e.g. scripts/fuzz.sh 600 model_dsl urdf
#
# The corpus grows in build-fuzz/corpus/<target>/ across runs. A crash, sanitizer report,
# hang (-timeout) or memory blow-up (-rss_limit_mb) is written to build-fuzz/findings/<target>/;
# copy it into fuzz/regressions/<target>/ once fixed, and ctest replays it from then on. Prints
# the executions and findings per target (the table of docs/reliability.md); exit status 1 if
# anything was found.
set -euo pipefail
cd "$(dirname "$0")/.."

seconds=${1:-60}
shift || true
mapfile -t all < <(sed -n 's/^\([a-z_]*\):.*/\1/p' fuzz/corpora.txt)
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=("${all[@]}")
for t in "${targets[@]}"; do
  if ! printf '%s\n' "${all[@]}" | grep -qx "$t"; then
    echo "fuzz.sh: unknown target '$t' (targets: ${all[*]})" >&2
    exit 2
  fi
done

bash scripts/install-deps.sh --fuzz
CXX=clang++ cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=Release -DBUILD_TESTING=OFF \
  -DCFUSE_FUZZ=ON >/dev/null
cmake --build build-fuzz -j"$(nproc)" --target "${targets[@]/%/_fuzz}"

# Sanitizer reports abort the run, so that libFuzzer records the input.
export ASAN_OPTIONS=abort_on_error=1:detect_leaks=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
status=0
summary=()
for t in "${targets[@]}"; do
  corpus=build-fuzz/corpus/$t
  findings=build-fuzz/findings/$t
  mkdir -p "$corpus" "$findings"
  # Findings of earlier runs stay in $findings until fixed; this run counts its own only.
  started=build-fuzz/$t.started
  touch "$started"
  read -r -a seeds <<<"$(sed -n "s/^$t:\(.*\)/\1/p" fuzz/corpora.txt)"
  [ -d "fuzz/regressions/$t" ] && seeds+=("fuzz/regressions/$t")
  dict=()
  [ -f "fuzz/$t.dict" ] && dict=(-dict="fuzz/$t.dict")
  log=build-fuzz/$t.log
  echo "fuzz.sh: $t for ${seconds} s (log $log)"
  # Seed files given directly (not in a directory) are copied in, since libFuzzer reads
  # corpora from directories.
  for s in "${seeds[@]}"; do [ -f "$s" ] && cp "$s" "$corpus/"; done
  seed_dirs=()
  for s in "${seeds[@]}"; do [ -d "$s" ] && seed_dirs+=("$s"); done
  set +e
  "build-fuzz/fuzz/${t}_fuzz" "$corpus" "${seed_dirs[@]}" "${dict[@]}" \
    -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -max_len=65536 \
    -artifact_prefix="$findings/" -print_final_stats=1 >"$log" 2>&1
  rc=$?
  set -e
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  found=$(find "$findings" -type f -newer "$started" | wc -l)
  units=$(find "$corpus" -type f | wc -l)
  [ "$rc" -ne 0 ] || [ "$found" -ne 0 ] && status=1
  summary+=("$(printf '| %-12s | %6s | %12s | %7s | %s |' "$t" "$seconds" "${execs:-?}" "$units" \
    "$([ "$found" -eq 0 ] && echo none || echo "$found in $findings (exit $rc)")")")
done

echo
echo "| target       | s      | executions   | corpus  | findings |"
echo "|---|---|---|---|---|"
printf '%s\n' "${summary[@]}"
exit $status
