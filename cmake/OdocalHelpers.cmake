# odocal_test(name [SERIAL] [SERIAL_FILTER GTEST_FILTER] [ONE_PROCESS GTEST_FILTER] [COST SECONDS]
#             [SOURCES ...] [LIBS ...])
# One line registers a test: tests/<dir>/<name>.cc linked to GoogleTest, the
# shared test_util library and the listed module libraries. SERIAL: its
# tests run with nothing beside them; SERIAL_FILTER: only those the filter
# names (one that loads every core on purpose), the rest beside others. A
# serial test makes ctest drain every running test first (a 7-minute one
# included) with the other core idle: keep the list short. COST: ctest's
# estimate of its tests' seconds until it has measured them (a fresh
# checkout has no Testing/Temporary/CTestCostData.txt): the long ones start
# first instead of last, where one would run alone at the end. ONE_PROCESS:
# the tests the filter names run as one ctest test, `<name>.one_process`, in
# one process, so that what they share (a static cache of an expensive
# fixture: 30 real frames detected) is made once; ctest otherwise runs every
# test in a process of its own.
include(GoogleTest)
function(odocal_test name)
  cmake_parse_arguments(ARG "SERIAL" "SERIAL_FILTER;ONE_PROCESS;COST" "SOURCES;LIBS" ${ARGN})
  if(NOT ARG_SOURCES)
    set(ARG_SOURCES ${name}.cc)
  endif()
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE odocal::test_util GTest::gmock_main ${ARG_LIBS})
  # Records the tests' runs make go to the build tree's store, never the user's.
  set(env "ODOCAL_BINARY=${CMAKE_BINARY_DIR}/odocal;ODOCAL_SOURCE_DIR=${PROJECT_SOURCE_DIR};ODOCAL_DB=${CMAKE_BINARY_DIR}/Testing/records.sqlite")
  set(cost "")
  if(ARG_COST)
    set(cost COST ${ARG_COST})
  endif()
  if(ARG_ONE_PROCESS)
    if(ARG_SERIAL OR ARG_SERIAL_FILTER)
      message(FATAL_ERROR "odocal_test(${name}): ONE_PROCESS with SERIAL or SERIAL_FILTER is not supported")
    endif()
    gtest_discover_tests(${name} WORKING_DIRECTORY ${PROJECT_SOURCE_DIR} TEST_FILTER "-${ARG_ONE_PROCESS}"
      PROPERTIES ENVIRONMENT "${env}" ${cost} DISCOVERY_TIMEOUT 60)
    add_test(NAME ${name}.one_process COMMAND ${name} --gtest_filter=${ARG_ONE_PROCESS}
      WORKING_DIRECTORY ${PROJECT_SOURCE_DIR})
    set_tests_properties(${name}.one_process PROPERTIES ENVIRONMENT "${env}" ${cost})
  elseif(ARG_SERIAL)
    gtest_discover_tests(${name} WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
      PROPERTIES ENVIRONMENT "${env}" RUN_SERIAL TRUE ${cost} DISCOVERY_TIMEOUT 60)
  elseif(ARG_SERIAL_FILTER)
    gtest_discover_tests(${name} WORKING_DIRECTORY ${PROJECT_SOURCE_DIR} TEST_FILTER "-${ARG_SERIAL_FILTER}"
      PROPERTIES ENVIRONMENT "${env}" ${cost} DISCOVERY_TIMEOUT 60)
    gtest_discover_tests(${name} WORKING_DIRECTORY ${PROJECT_SOURCE_DIR} TEST_FILTER "${ARG_SERIAL_FILTER}"
      PROPERTIES ENVIRONMENT "${env}" RUN_SERIAL TRUE ${cost} DISCOVERY_TIMEOUT 60)
  else()
    gtest_discover_tests(${name} WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
      PROPERTIES ENVIRONMENT "${env}" ${cost} DISCOVERY_TIMEOUT 60)
  endif()
endfunction()

# odocal_module(name SOURCES ... [PUBLIC ...] [PRIVATE ...])
# One library per concern: target odocal_<name>, alias odocal::<name>, public headers under
# include/odocal/<name>/. PUBLIC lists what the public headers include, PRIVATE what only the
# sources include: the link lists are the architecture (docs/architecture.md).
# With ODOCAL_UNITY_BUILD (on by default) a module's sources compile eight to a translation
# unit: Eigen's, Ceres', OpenCV's and nlohmann::json's headers are parsed and instantiated once
# per eight files instead of once per file (README's first command on a fresh clone, no
# ccache: 6 min 55 s -> 4 min 32 s; docs/performance.md). Names private to a source file (its anonymous namespace) are therefore
# unique within its module: a clash is a compile error. -DODOCAL_UNITY_BUILD=OFF compiles
# file by file (quicker when editing one file of a large module).
function(odocal_module name)
  cmake_parse_arguments(ARG "" "" "SOURCES;PUBLIC;PRIVATE" ${ARGN})
  add_library(odocal_${name} ${ARG_SOURCES})
  add_library(odocal::${name} ALIAS odocal_${name})
  target_include_directories(odocal_${name} PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/include)
  target_link_libraries(odocal_${name} PUBLIC ${ARG_PUBLIC} PRIVATE ${ARG_PRIVATE})
  if(ODOCAL_UNITY_BUILD)
    set_target_properties(odocal_${name} PROPERTIES UNITY_BUILD ON UNITY_BUILD_BATCH_SIZE 8)
    # GCC takes every file a unity file includes for a header, and a lambda of a file's own
    # (anonymous-namespace) class for one that escapes it.
    target_compile_options(odocal_${name} PRIVATE $<$<CXX_COMPILER_ID:GNU>:-Wno-subobject-linkage>)
  endif()
endfunction()
