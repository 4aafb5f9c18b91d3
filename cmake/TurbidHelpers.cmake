# Small helpers so that every module, test binary and benchmark is declared the same way.

function(turbid_set_warnings target)
  # -Wno-restrict: GCC 12 false positive on std::string concatenation at -O3 (GCC bug 105329);
  # clang (the sanitizer build) has no such warning.
  target_compile_options(${target} PRIVATE -Wall -Wextra $<$<CXX_COMPILER_ID:GNU>:-Wno-restrict>)
endfunction()

# turbid_add_module(NAME <module> DEPS <targets...>)
# Builds library turbid_<module> from every .cc file in the calling folder and its subfolders
# (enhancer/blocks/, enhancer/paper/, ...), except those under plugin/ (scenes' dlopen plugins).
function(turbid_add_module)
  cmake_parse_arguments(ARG "" "NAME" "DEPS" ${ARGN})
  file(GLOB_RECURSE sources CONFIGURE_DEPENDS "${CMAKE_CURRENT_SOURCE_DIR}/*.cc")
  list(FILTER sources EXCLUDE REGEX "/plugin/[^/]*\\.cc$")
  if(NOT sources)  # a module with headers only so far
    add_library(turbid_${ARG_NAME} INTERFACE)
    target_link_libraries(turbid_${ARG_NAME} INTERFACE ${ARG_DEPS})
    return()
  endif()
  add_library(turbid_${ARG_NAME} STATIC ${sources})
  target_include_directories(turbid_${ARG_NAME} PUBLIC ${PROJECT_SOURCE_DIR}
                                                       ${PROJECT_BINARY_DIR}/generated)
  target_link_libraries(turbid_${ARG_NAME} PUBLIC ${ARG_DEPS})
  turbid_set_warnings(turbid_${ARG_NAME})
endfunction()

# turbid_add_test_suite(NAME <module> DEPS <targets...>)
# One GoogleTest binary per module from every .cc in the calling folder; CTest names are
# <module>/<Suite>.<Test>.
function(turbid_add_test_suite)
  cmake_parse_arguments(ARG "" "NAME" "DEPS" ${ARGN})
  file(GLOB_RECURSE sources CONFIGURE_DEPENDS "${CMAKE_CURRENT_SOURCE_DIR}/*.cc")
  if(NOT sources)
    return()
  endif()
  set(target turbid_${ARG_NAME}_tests)
  add_executable(${target} ${sources})
  target_link_libraries(${target} PRIVATE ${ARG_DEPS} turbid_test_support GTest::gtest_main)
  turbid_set_warnings(${target})
  gtest_discover_tests(${target} TEST_PREFIX "${ARG_NAME}/" DISCOVERY_TIMEOUT 120
                       PROPERTIES ENVIRONMENT "TURBID_BIN=$<TARGET_FILE:turbid>")
endfunction()

# turbid_add_benchmark(NAME <name> SOURCES <files...> DEPS <targets...>)
function(turbid_add_benchmark)
  cmake_parse_arguments(ARG "" "NAME" "SOURCES;DEPS" ${ARGN})
  add_executable(bench_${ARG_NAME} ${ARG_SOURCES})
  target_link_libraries(bench_${ARG_NAME} PRIVATE ${ARG_DEPS} benchmark::benchmark)
  turbid_set_warnings(bench_${ARG_NAME})
endfunction()
