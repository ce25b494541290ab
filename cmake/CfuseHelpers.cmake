# cfuse_add_library(NAME <module> SOURCES ... HEADERS ... PUBLIC_LINKS ... PRIVATE_LINKS ...)
# Defines target cfuse_<module>, alias cfuse::<module>, and installs it. A module's folder holds
#   include/cfuse/<module>/  its public headers, included everywhere as "cfuse/<module>/<file>.h"
#                            and installed, sub-folders kept, under include/cfuse/<module>/;
#   src/                     its sources and internal headers; an internal header is included as
#                            "<file>.h" (relative to src/, a private include directory) and is
#                            not installed.
# SOURCES are relative to the module's folder (src/<file>.cpp, and the internal headers as
# src/<file>.h, so that IDEs list them); HEADERS are relative to include/cfuse/<module>/. Every
# header under include/ must be in HEADERS, and every one under src/ in SOURCES.
function(cfuse_add_library)
  cmake_parse_arguments(ARG "" "NAME" "SOURCES;HEADERS;PUBLIC_LINKS;PRIVATE_LINKS" ${ARGN})
  set(target cfuse_${ARG_NAME})
  set(public_dir ${CMAKE_CURRENT_SOURCE_DIR}/include/cfuse/${ARG_NAME})
  list(TRANSFORM ARG_HEADERS PREPEND ${public_dir}/ OUTPUT_VARIABLE public_headers)
  _cfuse_check_listed("${public_dir}" "${public_headers}" HEADERS)
  _cfuse_check_listed("${CMAKE_CURRENT_SOURCE_DIR}/src" "${ARG_SOURCES}" SOURCES)
  add_library(${target} ${ARG_SOURCES} ${public_headers})
  add_library(cfuse::${ARG_NAME} ALIAS ${target})
  set_target_properties(${target} PROPERTIES OUTPUT_NAME cfuse_${ARG_NAME} EXPORT_NAME ${ARG_NAME})
  target_include_directories(${target}
    PUBLIC $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
           $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>
    PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/src)
  target_link_libraries(${target} PUBLIC ${ARG_PUBLIC_LINKS} PRIVATE ${ARG_PRIVATE_LINKS})
  cfuse_set_warnings(${target})
  install(TARGETS ${target} EXPORT cfuseTargets
    ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
    LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
    RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
  foreach(header ${ARG_HEADERS})
    get_filename_component(dir ${header} DIRECTORY)
    install(FILES ${public_dir}/${header}
            DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/cfuse/${ARG_NAME}/${dir})
  endforeach()
endfunction()

# Fails the configuration when a header under <dir> is missing from <listed> (absolute paths, or
# relative to the current source folder): a public header left out would not be installed.
function(_cfuse_check_listed dir listed keyword)
  file(GLOB_RECURSE found CONFIGURE_DEPENDS ${dir}/*.h)
  list(TRANSFORM listed PREPEND ${CMAKE_CURRENT_SOURCE_DIR}/ REGEX "^[^/]")
  if(listed)
    list(REMOVE_ITEM found ${listed})
  endif()
  if(found)
    message(FATAL_ERROR "cfuse_add_library(${ARG_NAME}): not listed in ${keyword}: ${found}")
  endif()
endfunction()

function(cfuse_set_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic)
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
    # GCC 12 reports false positives in libstdc++'s string code at -O2 (GCC bug 105329).
    target_compile_options(${target} PRIVATE -Wno-restrict)
  endif()
endfunction()

# cfuse_add_test(NAME <name> SOURCES ... LINKS ...): one Catch2 executable, its test cases
# registered individually with ctest.
function(cfuse_add_test)
  cmake_parse_arguments(ARG "" "NAME" "SOURCES;LINKS" ${ARGN})
  add_executable(${ARG_NAME} ${ARG_SOURCES})
  target_link_libraries(${ARG_NAME} PRIVATE cfuse_test_main ${ARG_LINKS})
  cfuse_set_warnings(${ARG_NAME})
  # Under the sanitizers the cases tagged [heavy] (sweeps over many trials, inputs of a million
  # points) are not registered: instrumented, they took over half of the suite's time, and
  # their code paths run there in smaller cases too. The optimised build runs them all.
  # The tests' own code is compiled at -O1 there: instrumented at -O3 it took a third longer
  # to compile, and the time a test runs is spent in the libraries, which stay at -O3 (the
  # answers they give must be the ones the optimised build gives).
  set(spec "")
  if(CFUSE_SANITIZE)
    set(spec TEST_SPEC "~[heavy]")
    target_compile_options(${ARG_NAME} PRIVATE -O1)
  endif()
  catch_discover_tests(${ARG_NAME} ${spec} WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
    PROPERTIES ENVIRONMENT "CFUSE_SOURCE_DIR=${PROJECT_SOURCE_DIR}")
endfunction()
