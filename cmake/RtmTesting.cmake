# SPDX-License-Identifier: Apache-2.0
# rtm_add_gtest(<name> SOURCES <files...> LIBS <libs...> LABELS <labels...> [TIMEOUT s]
#               [RESOURCE_LOCK lock] [FIXTURES fixture])
#
# One GoogleTest executable; each TEST becomes its own CTest test carrying LABELS
# (unit, integration, slow, socketcan; 'threading' marks the tests the TSan preset runs).
# RESOURCE_LOCK: no two tests holding the same lock run at once (a real-time loop of several
# processes, which two at a time on 2 CPUs would starve). FIXTURES: a CTest fixture each test
# requires (its setup test runs first, e.g. the MCAP reference readers' install).
#
# The properties are set by a script CTest includes after the tests are discovered, not through
# gtest_discover_tests(PROPERTIES): CMake 3.25 splits list values there, which would drop every
# label but the first and garble TIMEOUT and ENVIRONMENT.
function(rtm_add_gtest name)
  cmake_parse_arguments(ARG "" "TIMEOUT;RESOURCE_LOCK;FIXTURES" "SOURCES;LIBS;LABELS" ${ARGN})
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 120)
  endif()
  add_executable(${name} ${ARG_SOURCES})
  rtm_warnings(${name})
  target_link_libraries(${name} PRIVATE ${ARG_LIBS} GTest::gtest GTest::gtest_main GTest::gmock)
  gtest_discover_tests(${name} DISCOVERY_MODE PRE_TEST TEST_LIST ${name}_TESTS)
  set(props ${CMAKE_CURRENT_BINARY_DIR}/${name}_properties.cmake)
  set(lock "")
  if(ARG_RESOURCE_LOCK)
    set(lock "    RESOURCE_LOCK \"${ARG_RESOURCE_LOCK}\"\n")
  endif()
  if(ARG_FIXTURES)
    string(APPEND lock "    FIXTURES_REQUIRED \"${ARG_FIXTURES}\"\n")
  endif()
  file(WRITE ${props}
    "foreach(t IN LISTS ${name}_TESTS)\n"
    "  set_tests_properties(\"\${t}\" PROPERTIES\n"
    "    LABELS \"${ARG_LABELS}\"\n"
    "    TIMEOUT ${ARG_TIMEOUT}\n"
    "${lock}"
    "    ENVIRONMENT \"RTM_BUILD_DIR=${CMAKE_BINARY_DIR};RTM_SOURCE_DIR=${CMAKE_SOURCE_DIR}\")\n"
    "endforeach()\n")
  set_property(DIRECTORY APPEND PROPERTY TEST_INCLUDE_FILES ${props})
endfunction()

# rtm_add_vcan_test(<name> COMMAND <command...> [TIMEOUT s])
#
# A test that needs a kernel with SocketCAN: scripts/vm-vcan-run boots Debian's kernel under
# QEMU with vcan0 up and runs COMMAND there, from this host's filesystem. Labels socketcan and
# integration in every preset (ASan and TSan builds run in the guest too). It is skipped
# (SKIP_RETURN_CODE 77) only when no guest can be started on this host at all, saying why;
# a guest that boots and fails, or a command that fails, fails the test.
function(rtm_add_vcan_test name)
  cmake_parse_arguments(ARG "" "TIMEOUT" "COMMAND" ${ARGN})
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 420)
  endif()
  math(EXPR guest_timeout "${ARG_TIMEOUT} - 30")
  add_test(NAME ${name}
    COMMAND ${PROJECT_SOURCE_DIR}/scripts/vm-vcan-run --skip-code 77 -t ${guest_timeout} --
            ${ARG_COMMAND})
  set_tests_properties(${name} PROPERTIES
    LABELS "socketcan;integration"
    SKIP_RETURN_CODE 77
    TIMEOUT ${ARG_TIMEOUT}
    ENVIRONMENT "RTM_BUILD_DIR=${CMAKE_BINARY_DIR};RTM_SOURCE_DIR=${CMAKE_SOURCE_DIR}")
endfunction()
