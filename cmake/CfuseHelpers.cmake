# cfuse_add_library(NAME <module> SOURCES ... HEADERS ... PUBLIC_LINKS ... PRIVATE_LINKS ...)
# Defines target cfuse_<module>, alias cfuse::<module>, installs it and its headers under
# include/cfuse/<module>/. In-tree and installed code include headers as "<module>/<file>.h".
function(cfuse_add_library)
  cmake_parse_arguments(ARG "" "NAME" "SOURCES;HEADERS;PUBLIC_LINKS;PRIVATE_LINKS" ${ARGN})
  set(target cfuse_${ARG_NAME})
  add_library(${target} ${ARG_SOURCES} ${ARG_HEADERS})
  add_library(cfuse::${ARG_NAME} ALIAS ${target})
  set_target_properties(${target} PROPERTIES OUTPUT_NAME cfuse_${ARG_NAME} EXPORT_NAME ${ARG_NAME})
  target_include_directories(${target} PUBLIC
    $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}>
    $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}/cfuse>
    $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  target_link_libraries(${target} PUBLIC ${ARG_PUBLIC_LINKS} PRIVATE ${ARG_PRIVATE_LINKS})
  cfuse_set_warnings(${target})
  install(TARGETS ${target} EXPORT cfuseTargets
    ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
    LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
    RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
  foreach(header ${ARG_HEADERS})
    get_filename_component(dir ${header} DIRECTORY)
    install(FILES ${header} DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/cfuse/${ARG_NAME}/${dir})
  endforeach()
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
  catch_discover_tests(${ARG_NAME} WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
    PROPERTIES ENVIRONMENT "CFUSE_SOURCE_DIR=${PROJECT_SOURCE_DIR}")
endfunction()
