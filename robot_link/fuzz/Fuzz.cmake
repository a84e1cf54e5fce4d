# Builds robot_link/fuzz/olf_decoder_fuzzer with clang's libFuzzer, ASan and
# UBSan. The firmware library is plain C99 without dependencies, so clang is
# invoked directly and the project may be configured with any C++ compiler.
# Sets ODOCAL_FUZZ_BINARY when the target exists.
set(_fuzz_clang "")
if(CMAKE_C_COMPILER_ID STREQUAL "Clang")
  set(_fuzz_clang ${CMAKE_C_COMPILER})
else()
  find_program(ODOCAL_FUZZ_CLANG NAMES clang clang-14 clang-15 clang-16)
  if(ODOCAL_FUZZ_CLANG)
    set(_fuzz_clang ${ODOCAL_FUZZ_CLANG})
  endif()
endif()

if(_fuzz_clang)
  # Probe: clang without libclang-rt-dev compiles but cannot link -fsanitize=fuzzer.
  set(_probe_dir ${CMAKE_CURRENT_BINARY_DIR}/fuzz_probe)
  file(MAKE_DIRECTORY ${_probe_dir})
  file(WRITE ${_probe_dir}/probe.c
       "#include <stddef.h>\n#include <stdint.h>\n"
       "int LLVMFuzzerTestOneInput(const uint8_t* d, size_t n) { (void)d; (void)n; return 0; }\n")
  execute_process(
    COMMAND ${_fuzz_clang} -fsanitize=fuzzer,address,undefined ${_probe_dir}/probe.c -o ${_probe_dir}/probe
    RESULT_VARIABLE _probe_rc OUTPUT_QUIET ERROR_QUIET)
  if(_probe_rc EQUAL 0)
    set(_fw ${CMAKE_CURRENT_SOURCE_DIR}/firmware)
    # The library's own source list, so that a new file cannot be forgotten here.
    get_target_property(_lib_sources odocal_link_firmware SOURCES)
    list(TRANSFORM _lib_sources PREPEND ${_fw}/)
    set(_sources ${_lib_sources} ${CMAKE_CURRENT_SOURCE_DIR}/fuzz/olf_decoder_fuzzer.c)
    set(ODOCAL_FUZZ_BINARY ${CMAKE_BINARY_DIR}/olf_decoder_fuzzer CACHE INTERNAL "")
    add_custom_command(
      OUTPUT ${ODOCAL_FUZZ_BINARY}
      COMMAND ${_fuzz_clang} -std=c99 -g -O1 -fsanitize=fuzzer,address,undefined
              -fno-sanitize-recover=undefined -I${_fw}/include -I${_fw}/src ${_sources}
              -o ${ODOCAL_FUZZ_BINARY}
      DEPENDS ${_sources} ${_fw}/include/odolink/olf.h ${_fw}/include/odolink/olf_wire.h
              ${_fw}/src/olf_internal.h
      COMMENT "Building libFuzzer target olf_decoder_fuzzer with ${_fuzz_clang}"
      VERBATIM)
    add_custom_target(olf_decoder_fuzzer ALL DEPENDS ${ODOCAL_FUZZ_BINARY})
    message(STATUS "robot_link: libFuzzer target olf_decoder_fuzzer enabled (${_fuzz_clang})")
  else()
    unset(ODOCAL_FUZZ_BINARY CACHE)
    message(STATUS "robot_link: ${_fuzz_clang} cannot link -fsanitize=fuzzer; fuzz target skipped")
  endif()
else()
  unset(ODOCAL_FUZZ_BINARY CACHE)
  message(STATUS "robot_link: no clang found; fuzz target skipped")
endif()
