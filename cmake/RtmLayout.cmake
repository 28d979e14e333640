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
