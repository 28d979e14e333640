# rtm_add_gtest(<name> SOURCES <files...> LIBS <libs...> LABELS <labels...> [TIMEOUT s])
#
# One GoogleTest executable; each TEST becomes its own CTest test carrying LABELS
# (unit, integration, slow, socketcan; 'threading' marks the tests the TSan preset runs).
#
# The properties are set by a script CTest includes after the tests are discovered, not through
# gtest_discover_tests(PROPERTIES): CMake 3.25 splits list values there, which would drop every
# label but the first and garble TIMEOUT and ENVIRONMENT.
function(rtm_add_gtest name)
  cmake_parse_arguments(ARG "" "TIMEOUT" "SOURCES;LIBS;LABELS" ${ARGN})
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 120)
  endif()
  add_executable(${name} ${ARG_SOURCES})
  rtm_warnings(${name})
  target_link_libraries(${name} PRIVATE ${ARG_LIBS} GTest::gtest GTest::gtest_main GTest::gmock)
  gtest_discover_tests(${name} DISCOVERY_MODE PRE_TEST TEST_LIST ${name}_TESTS)
  set(props ${CMAKE_CURRENT_BINARY_DIR}/${name}_properties.cmake)
  file(WRITE ${props}
    "foreach(t IN LISTS ${name}_TESTS)\n"
    "  set_tests_properties(\"\${t}\" PROPERTIES\n"
    "    LABELS \"${ARG_LABELS}\"\n"
    "    TIMEOUT ${ARG_TIMEOUT}\n"
    "    ENVIRONMENT \"RTM_BUILD_DIR=${CMAKE_BINARY_DIR};RTM_SOURCE_DIR=${CMAKE_SOURCE_DIR}\")\n"
    "endforeach()\n")
  set_property(DIRECTORY APPEND PROPERTY TEST_INCLUDE_FILES ${props})
endfunction()
