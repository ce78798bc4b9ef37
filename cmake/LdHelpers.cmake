# Shared compile settings and helpers for every lapdissect target.

add_library(ld_options INTERFACE)
target_compile_options(ld_options INTERFACE
  $<$<CXX_COMPILER_ID:GNU,Clang>:-Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wno-unused-parameter>
  $<$<BOOL:${LD_WERROR}>:-Werror>)
if(LD_FUZZ)
  # Coverage instrumentation for every library the fuzzers link.
  target_compile_options(ld_options INTERFACE -fsanitize=fuzzer-no-link,address,undefined -fno-omit-frame-pointer)
  target_link_options(ld_options INTERFACE -fsanitize=address,undefined)
endif()
if(LD_SANITIZE)
  target_compile_options(ld_options INTERFACE -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined)
  target_link_options(ld_options INTERFACE -fsanitize=address,undefined)
endif()

# ld_add_library(NAME SOURCES ... [PUBLIC_LIBS ...] [PRIVATE_LIBS ...])
function(ld_add_library name)
  cmake_parse_arguments(A "" "" "SOURCES;PUBLIC_LIBS;PRIVATE_LIBS" ${ARGN})
  add_library(${name} STATIC ${A_SOURCES})
  target_include_directories(${name} PUBLIC ${PROJECT_SOURCE_DIR})
  target_link_libraries(${name} PUBLIC ld_options ${A_PUBLIC_LIBS} PRIVATE ${A_PRIVATE_LIBS})
  set_target_properties(${name} PROPERTIES POSITION_INDEPENDENT_CODE ON)
endfunction()

# ld_add_gtest(NAME SOURCES ... LIBS ... [LABELS ...])
# One executable per test folder; tests are discovered so ctest lists each case.
function(ld_add_gtest name)
  cmake_parse_arguments(A "" "" "SOURCES;LIBS;LABELS" ${ARGN})
  add_executable(${name} ${A_SOURCES})
  target_link_libraries(${name} PRIVATE ld_options ld_test_support ${A_LIBS} GTest::gtest GTest::gmock GTest::gtest_main)
  if(NOT A_LABELS)
    set(A_LABELS unit)
  endif()
  # gtest_discover_tests splits list-valued PROPERTIES, so labels and environment are
  # set from an include file that runs after discovery.
  # The program name prefixes every test, so `ctest -R physics_test` selects one module.
  gtest_discover_tests(${name} TEST_PREFIX "${name}." TEST_LIST ${name}_TESTS DISCOVERY_TIMEOUT 60)
  file(WRITE ${CMAKE_CURRENT_BINARY_DIR}/${name}_props.cmake
    "if(${name}_TESTS)\n  set_tests_properties(\${${name}_TESTS} PROPERTIES LABELS \"${A_LABELS}\"\n"
    "    ENVIRONMENT \"LD_SHARED_DATA=${LD_SHARED_DATA_DIR};LD_RESOURCES=${LD_RESOURCES_DIR}\")\nendif()\n")
  set_property(DIRECTORY APPEND PROPERTY TEST_INCLUDE_FILES ${CMAKE_CURRENT_BINARY_DIR}/${name}_props.cmake)
endfunction()

# ld_add_benchmark(NAME SOURCES ... LIBS ...): a Google Benchmark program (not a test).
function(ld_add_benchmark name)
  cmake_parse_arguments(A "" "" "SOURCES;LIBS" ${ARGN})
  if(NOT LD_BUILD_BENCHMARKS)
    return()
  endif()
  find_package(benchmark REQUIRED)
  add_executable(${name} ${A_SOURCES})
  target_include_directories(${name} PRIVATE ${PROJECT_SOURCE_DIR})
  target_link_libraries(${name} PRIVATE ld_options ${A_LIBS} benchmark::benchmark)
  set_target_properties(${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/bench)
endfunction()

# ld_add_fuzzer(NAME SOURCES ... LIBS ... CORPUS DIR)
# The sources define LLVMFuzzerTestOneInput. With LD_FUZZ (clang) this is a libFuzzer
# binary; otherwise it links a small driver that replays the seed corpus and a fixed
# number of seeded random mutations, registered as a ctest test so every run fuzzes a bit.
function(ld_add_fuzzer name)
  cmake_parse_arguments(A "" "CORPUS" "SOURCES;LIBS" ${ARGN})
  add_executable(${name} ${A_SOURCES})
  target_include_directories(${name} PRIVATE ${PROJECT_SOURCE_DIR})
  target_link_libraries(${name} PRIVATE ld_options ${A_LIBS})
  set_target_properties(${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/fuzz)
  if(LD_FUZZ)
    target_compile_options(${name} PRIVATE -fsanitize=fuzzer,address,undefined)
    target_link_options(${name} PRIVATE -fsanitize=fuzzer,address,undefined)
    set_property(GLOBAL APPEND PROPERTY LD_FUZZERS "${name}=${A_CORPUS}")
    get_property(_all GLOBAL PROPERTY LD_FUZZERS)
    string(REPLACE ";" "\n" _lines "${_all}")
    file(WRITE ${PROJECT_BINARY_DIR}/fuzzers.txt "${_lines}\n")
  else()
    target_sources(${name} PRIVATE ${PROJECT_SOURCE_DIR}/tests/support/fuzz_driver.cpp)
    if(LD_BUILD_TESTS)
      add_test(NAME ${name} COMMAND ${name} ${A_CORPUS} --iterations 3000)
      set_tests_properties(${name} PROPERTIES LABELS "fuzz;sanitize")
    endif()
  endif()
endfunction()
