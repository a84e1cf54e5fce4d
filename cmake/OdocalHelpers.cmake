# odocal_test(name [SOURCES ...] [LIBS ...])
# One line registers a test: tests/<dir>/<name>.cc linked to GoogleTest, the
# shared test_util library and the listed module libraries.
include(GoogleTest)
function(odocal_test name)
  cmake_parse_arguments(ARG "" "" "SOURCES;LIBS" ${ARGN})
  if(NOT ARG_SOURCES)
    set(ARG_SOURCES ${name}.cc)
  endif()
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE odocal::test_util GTest::gmock_main ${ARG_LIBS})
  gtest_discover_tests(${name}
    WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
    PROPERTIES ENVIRONMENT "ODOCAL_BINARY=${CMAKE_BINARY_DIR}/odocal;ODOCAL_SOURCE_DIR=${PROJECT_SOURCE_DIR}"
    DISCOVERY_TIMEOUT 60)
endfunction()
