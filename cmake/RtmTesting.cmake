# rtm_add_gtest(<name> SOURCES <files...> LIBS <libs...> LABELS <labels...> [TIMEOUT s])
#
# One GoogleTest executable; each TEST becomes its own CTest test carrying LABELS
# (unit, integration, slow, socketcan; 'threading' marks the tests the TSan preset runs).
function(rtm_add_gtest name)
  cmake_parse_arguments(ARG "" "TIMEOUT" "SOURCES;LIBS;LABELS" ${ARGN})
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 120)
  endif()
  add_executable(${name} ${ARG_SOURCES})
  rtm_warnings(${name})
  target_link_libraries(${name} PRIVATE ${ARG_LIBS} GTest::gtest GTest::gtest_main GTest::gmock)
  gtest_discover_tests(${name}
    DISCOVERY_MODE PRE_TEST
    PROPERTIES LABELS "${ARG_LABELS}" TIMEOUT ${ARG_TIMEOUT}
               ENVIRONMENT "RTM_BUILD_DIR=${CMAKE_BINARY_DIR};RTM_SOURCE_DIR=${CMAKE_SOURCE_DIR}")
endfunction()
