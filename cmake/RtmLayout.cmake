# SPDX-License-Identifier: Apache-2.0
# rtm_add_subdirectories([names...])
#
# Adds the subfolders of the current folder that have a CMakeLists.txt: the named ones in the
# given order, or, with no names, every such subfolder in alphabetical order.
function(rtm_add_subdirectories)
  set(names ${ARGN})
  if(NOT names)
    file(GLOB children LIST_DIRECTORIES true RELATIVE ${CMAKE_CURRENT_SOURCE_DIR}
         ${CMAKE_CURRENT_SOURCE_DIR}/*)
    list(SORT children)
    set(names ${children})
  endif()
  foreach(name ${names})
    if(EXISTS ${CMAKE_CURRENT_SOURCE_DIR}/${name}/CMakeLists.txt)
      add_subdirectory(${name})
    endif()
  endforeach()
endfunction()

# rtm_enabled_areas(<out-var> <always...>)
#
# The per-area folder names (as in tests/ and bench/) of the parts this configuration builds:
# the given ones, then can and arm (RTM_WITH_ARM), sim (with RTM_WITH_SIM), and components,
# tools and examples (RTM_WITH_COMPONENTS). A preset that leaves a part out (tsan) thus never
# adds folders whose targets do not exist.
function(rtm_enabled_areas out)
  set(areas ${ARGN})
  if(RTM_WITH_ARM)
    list(APPEND areas can arm)
  endif()
  if(RTM_WITH_ARM AND RTM_WITH_SIM)
    list(APPEND areas sim)
  endif()
  if(RTM_WITH_COMPONENTS)
    list(APPEND areas components tools examples)
  endif()
  if(RTM_WITH_COMPONENTS AND RTM_WITH_PYTHON)
    list(APPEND areas python)
  endif()
  set(${out} ${areas} PARENT_SCOPE)
endfunction()
