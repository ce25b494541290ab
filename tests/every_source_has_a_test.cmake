# Fails when a library source file <module>/src/<path>/<name>.cpp has no test file
# tests/<module>/<name>_test.cpp, or one that tests/CMakeLists.txt does not build: each library
# file is tested on its own, under its own name (run by ctest as "architecture: every library
# source file has its test").
#   cmake -DSOURCE_DIR=<repository> -P tests/every_source_has_a_test.cmake
set(modules kernel constraints dsl importers geometry interp vision track)
set(missing "")
file(READ ${SOURCE_DIR}/tests/CMakeLists.txt built)
foreach(module ${modules})
  file(GLOB_RECURSE sources RELATIVE ${SOURCE_DIR} ${SOURCE_DIR}/${module}/src/*.cpp)
  foreach(source ${sources})
    get_filename_component(name ${source} NAME_WE)
    set(test ${module}/${name}_test.cpp)
    string(FIND "${built}" " ${test}" listed)
    if(NOT EXISTS ${SOURCE_DIR}/tests/${test} OR listed EQUAL -1)
      list(APPEND missing "${source} (tests/${test}, listed in tests/CMakeLists.txt)")
    endif()
  endforeach()
endforeach()
if(missing)
  list(JOIN missing "\n  " text)
  message(FATAL_ERROR "library source files without their test:\n  ${text}")
endif()
