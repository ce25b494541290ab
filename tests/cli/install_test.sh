#!/usr/bin/env bash
# Installs the build in $1 to a temporary prefix and builds a consumer project that finds it
# with find_package(cfuse) and links cfuse::cfuse, then runs it on an example model. $3, if
# not empty, names the sanitizers the build was made with: the consumer links their runtime too.
set -euo pipefail
build=$1
src=$2
sanitize=${3:-}
flags=()
if [ -n "$sanitize" ]; then
  flags=("-DCMAKE_CXX_FLAGS=-fsanitize=$sanitize" "-DCMAKE_EXE_LINKER_FLAGS=-fsanitize=$sanitize")
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cmake --install "$build" --prefix "$work/prefix" > "$work/install.log"
mkdir -p "$work/consumer"
cat > "$work/consumer/CMakeLists.txt" <<'CMAKE'
cmake_minimum_required(VERSION 3.22)
project(consumer CXX)
set(CMAKE_CXX_STANDARD 20)
find_package(cfuse REQUIRED)
add_executable(consumer main.cpp)
target_link_libraries(consumer PRIVATE cfuse::cfuse)
CMAKE
cat > "$work/consumer/main.cpp" <<'CPP'
#include <cfuse/constraints/dof.h>
#include <cfuse/dsl/model_loader.h>
#include <iostream>
int main(int argc, char** argv) {
  const cfuse::ConstraintGraph g = cfuse::LoadModel(argv[1]);
  const cfuse::DofReport r = cfuse::AnalyzeDof(g, g.nominal);
  std::cout << "dof " << r.dof << "\n";
  return r.dof == 11 ? 0 : 1;
}
CPP
cmake -S "$work/consumer" -B "$work/consumer/build" -DCMAKE_PREFIX_PATH="$work/prefix" \
  -DCMAKE_BUILD_TYPE=Release "${flags[@]}" > "$work/configure.log"
cmake --build "$work/consumer/build" -j2 > "$work/build.log" || { cat "$work/build.log"; exit 1; }
"$work/consumer/build/consumer" "$src/examples/lamp.yaml"
test -x "$work/prefix/bin/cfuse"
# The Python package, where it was built: imported by Debian's interpreter from elsewhere.
if [ -z "$sanitize" ] && [ -d "$build/python/cfuse" ]; then
  site=$(ls -d "$work"/prefix/lib/python3*/dist-packages)
  (cd "$work" && PYTHONPATH="$site" /usr/bin/python3 -c "
import sys, cfuse
assert cfuse.__file__.startswith('$site'), cfuse.__file__
print('python dof', cfuse.load_model(sys.argv[1]).dof)
" "$src/examples/lamp.yaml")
fi
