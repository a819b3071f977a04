# The C++ test programs' helpers, included by the root CMakeLists.txt before the layers
# (whose unit tests lie beside them, lib/LAYER/tests/) and tests/ (the cross-layer
# tests: the fishcam program, install, fuzz, the Python package).
find_package(GTest REQUIRED)
include(GoogleTest)

# Per-test time limit (s); the sanitizer build (scripts/test-sanitizers.sh), several
# times slower, raises it.
set(FISHCAM_TEST_TIMEOUT 300 CACHE STRING "Time limit of each C++ test, seconds")

# Every CTest entry carries a label, and selections (the sanitizer stage, `ctest -L`)
# go by label, never by name:
#   unit      a library test (GoogleTest)          cli      runs the fishcam program
#   sweep     a numeric sweep over every model or many poses against an exact reference
#             (minutes under the sanitizers; the CI sanitizer stage leaves them out)
#   python    the Python package's tests, stubs and types
#   install   installs and builds a consumer        fuzz     replays a fuzz harness's corpus
#   style     the tree's style (scripts/style.sh)
#   real-data a library test of ../shared's real files (skips without them); the
#             Python files that read them carry python and real-data; a sweep that
#             reads them stays sweep (one label per discovered test)
# fishcam_test(NAME [LABEL cli] [SWEEPS GTEST_FILTER] [REAL_DATA GTEST_FILTER]): the
# tests of NAME.cpp; those matching SWEEPS (a GoogleTest filter, kept here beside the
# executable they belong to) are labelled sweep, those matching REAL_DATA (and not
# SWEEPS) real-data (gtest_discover_tests passes one label), the others LABEL
# (default unit).
function(fishcam_test name)
  cmake_parse_arguments(ARG "" "LABEL;SWEEPS;REAL_DATA" "" ${ARGN})
  if(NOT ARG_LABEL)
    set(ARG_LABEL unit)
  endif()
  add_executable(${name} ${name}.cpp ${ARG_UNPARSED_ARGUMENTS})
  # Every test program in one folder, beside the paths file below.
  set_target_properties(${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${FISHCAM_TEST_BINARY_DIR})
  target_link_libraries(${name} PRIVATE fishcam::fishcam fishcam_testing GTest::gtest_main)
  target_compile_options(${name} PRIVATE ${FISHCAM_WARNINGS})
  # No paths compiled in (test_support.hpp reads fishcam_test_paths.txt, below): the
  # objects are the same wherever the tree lies, so a clone elsewhere hits ccache.
  target_compile_definitions(${name} PRIVATE $<$<TARGET_EXISTS:fishcam_cli>:FISHCAM_HAS_CLI>)
  set(rest "")  # the filter of the others: "-SWEEPS:REAL_DATA"
  if(ARG_SWEEPS)
    gtest_discover_tests(${name} TEST_FILTER "${ARG_SWEEPS}" DISCOVERY_TIMEOUT 60
                         PROPERTIES TIMEOUT ${FISHCAM_TEST_TIMEOUT} LABELS sweep)
    set(rest "${ARG_SWEEPS}")
  endif()
  if(ARG_REAL_DATA)
    set(real "${ARG_REAL_DATA}")
    if(ARG_SWEEPS)
      set(real "${ARG_REAL_DATA}-${ARG_SWEEPS}")
    endif()
    gtest_discover_tests(${name} TEST_FILTER "${real}" DISCOVERY_TIMEOUT 60
                         PROPERTIES TIMEOUT ${FISHCAM_TEST_TIMEOUT} LABELS real-data)
    if(rest)
      set(rest "${rest}:${ARG_REAL_DATA}")
    else()
      set(rest "${ARG_REAL_DATA}")
    endif()
  endif()
  if(rest)
    gtest_discover_tests(${name} TEST_FILTER "-${rest}" DISCOVERY_TIMEOUT 60
                         PROPERTIES TIMEOUT ${FISHCAM_TEST_TIMEOUT} LABELS ${ARG_LABEL})
  else()
    gtest_discover_tests(${name} DISCOVERY_TIMEOUT 60 PROPERTIES TIMEOUT ${FISHCAM_TEST_TIMEOUT} LABELS ${ARG_LABEL})
  endif()
endfunction()

# The paths the tests read at run time (test::test_path), beside the test programs.
set(FISHCAM_TEST_BINARY_DIR ${PROJECT_BINARY_DIR}/tests)
file(GENERATE OUTPUT ${FISHCAM_TEST_BINARY_DIR}/fishcam_test_paths.txt CONTENT
"data=${PROJECT_SOURCE_DIR}/data
shared=${PROJECT_SOURCE_DIR}/../shared
tmp=${FISHCAM_TEST_BINARY_DIR}/tmp
mrcal_map_script=${PROJECT_SOURCE_DIR}/tools/mrcal_map.py
binary=$<$<TARGET_EXISTS:fishcam_cli>:$<TARGET_FILE:fishcam_cli>>
")

