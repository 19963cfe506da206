# Warning flags for ctcal's own targets (never applied to third-party headers, which are SYSTEM).
function(ctcal_warnings target)
  # -Wshadow=local is GCC's (clang has no such option: with -Werror it would be an error there).
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
    target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow=local
                                             -Wno-unused-parameter)
  else()
    target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wno-unused-parameter)
  endif()
  if(CTCAL_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()

# ctcal_library(NAME SOURCES a.cpp b.cpp DEPS x y [PRIVATE_DEPS z])
# A library folder: public headers under <folder>/include/ctcal/<name>/.
function(ctcal_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS;PRIVATE_DEPS" ${ARGN})
  if(ARG_SOURCES)
    add_library(ctcal_${name} STATIC ${ARG_SOURCES})
    target_include_directories(ctcal_${name} PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/include)
    target_link_libraries(ctcal_${name} PUBLIC ${ARG_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
    set_target_properties(ctcal_${name} PROPERTIES POSITION_INDEPENDENT_CODE ON)
    ctcal_warnings(ctcal_${name})
  else()
    add_library(ctcal_${name} INTERFACE)
    target_include_directories(ctcal_${name} INTERFACE ${CMAKE_CURRENT_SOURCE_DIR}/include)
    target_link_libraries(ctcal_${name} INTERFACE ${ARG_DEPS})
  endif()
  add_library(ctcal::${name} ALIAS ctcal_${name})
endfunction()

# Every ctcal_test's TMPDIR (below), which tests/CMakeLists.txt empties before each ctest run.
set(CTCAL_TEST_TMPDIR ${CMAKE_BINARY_DIR}/test_tmp)

# ctcal_test(NAME SOURCES a.cpp DEPS ctcal::spline [LABELS unit])
# One GoogleTest executable per unit; each TEST becomes its own CTest test.
function(ctcal_test name)
  cmake_parse_arguments(ARG "" "TIMEOUT" "SOURCES;DEPS;LABELS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} GTest::gtest GTest::gmock GTest::gtest_main)
  target_compile_definitions(${name} PRIVATE
    CTCAL_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
    CTCAL_SHARED_DATA_DIR="${PROJECT_SOURCE_DIR}/../shared/data"
    CTCAL_BINARY="${CMAKE_BINARY_DIR}/bin/ctcal")
  set_target_properties(${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/tests)
  # The test files themselves at -O1 (after the build type's -O3, so it wins): their run time is
  # the libraries' and the ctcal program's (still -O3), while -O3 on ~100 template-heavy test files
  # (autodiff residuals, gtest) costs a quarter more compile time of the whole `make test`.
  if(CMAKE_BUILD_TYPE STREQUAL "Release" AND NOT CTCAL_SANITIZE)
    target_compile_options(${name} PRIVATE -O1)
  endif()
  ctcal_warnings(${name})
  # GoogleTest's TYPED_TEST_SUITE(Name, Types) leaves its macro's `...` empty, which clang's
  # -Wpedantic reports (C++20 allows it; GCC does not warn).
  if(CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    target_compile_options(${name} PRIVATE -Wno-gnu-zero-variadic-macro-arguments)
  endif()
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 600)
  endif()
  # Every test's temporary files under the build folder (GoogleTest's TempDir() and
  # std::filesystem::temp_directory_path() read TMPDIR), emptied at the start of each ctest run
  # (the ctcal_test_tmp fixture, tests/CMakeLists.txt): in /tmp a run of the suite left ~470 MB of
  # simulated recordings, bags and outputs behind, and each run its own (their names hold the pid).
  # (Key-value pairs: an empty LABELS would take the next key as its value.)
  set(properties TIMEOUT ${ARG_TIMEOUT} ENVIRONMENT "TMPDIR=${CTCAL_TEST_TMPDIR}"
                 FIXTURES_REQUIRED ctcal_test_tmp)
  if(ARG_LABELS)
    list(APPEND properties LABELS "${ARG_LABELS}")
  endif()
  gtest_discover_tests(${name} DISCOVERY_TIMEOUT 60 PROPERTIES ${properties})
endfunction()
