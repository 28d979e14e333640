# SPDX-License-Identifier: Apache-2.0
# The RTM CMake package: what `cmake --install` puts where, and RTMConfig.cmake for projects
# built on RTM (find_package(RTM)), from an install prefix or from this build tree.
#
#   RTM::core   the framework (ports, components, naming); brings RTM::rt, RTM::idl
#               (the stubs of idl/*.idl) and omniORB
#   RTM::host   the runner (a component executable's main()) with the access screen, TLS and
#               leases; brings RTM::core
#   RTM::rt     the real-time base (activities, clocks), no CORBA
#   RTM::can    CAN transports and the CANopen master, RTM::pa10 the PA10 arm (for hardware
#               components)
#   rtm_add_idl(<target> FILES <idl...>)  stubs of a project's own data types
#   rtm_add_component(<program> SOURCES ... LIBS ...)  a component's program and its module
#               for rtm-container, from one compile (cmake/RtmComponent.cmake)
#
# Layout (GNU): bin/ (rtm, the components, pa10-sim), lib/ (the shared rt, idl, core and host
# libraries, the static ones of the arm),
# include/rtm/ (the headers as #include "rtm/...", "rt/...", "arm/can/..."; the IDL stubs in
# include/rtm/idl), share/rtm/idl (the IDL files), share/rtm/models, lib/cmake/RTM,
# share/doc/rtm, share/bash-completion. Nothing in an installed file names the source or
# build tree: the package finds its files relative to itself.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(RTM_INSTALL_INCLUDEDIR ${CMAKE_INSTALL_INCLUDEDIR}/rtm)
set(RTM_INSTALL_IDLDIR ${CMAKE_INSTALL_DATADIR}/rtm/idl)
set(RTM_INSTALL_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/RTM)
set(RTM_INSTALL_MODELDIR ${CMAKE_INSTALL_DATADIR}/rtm/models)

# rtm_public_headers(<target> <include folder>): the target's users find the folder's headers,
# from the build tree and, installed, under include/rtm.
function(rtm_public_headers target folder)
  target_include_directories(${target} PUBLIC $<BUILD_INTERFACE:${folder}>
                                              $<INSTALL_INTERFACE:${RTM_INSTALL_INCLUDEDIR}>)
  install(DIRECTORY ${folder}/ DESTINATION ${RTM_INSTALL_INCLUDEDIR} COMPONENT dev)
endfunction()

# Installed programs and libraries find RTM's shared libraries relative to themselves, so the
# tree stays relocatable (the install test moves it).
set(CMAKE_INSTALL_RPATH "$ORIGIN/../${CMAKE_INSTALL_LIBDIR}")

# rtm_export_library(<target> <name>): installs the library as RTM::<name>. A shared one goes
# to the running system (runtime), its link name and a static one to the development files.
function(rtm_export_library target name)
  set_target_properties(${target} PROPERTIES EXPORT_NAME ${name})
  add_library(RTM::${name} ALIAS ${target})
  get_target_property(type ${target} TYPE)
  if(type STREQUAL "SHARED_LIBRARY")
    # 0.x: every minor version may change the ABI.
    set_target_properties(${target} PROPERTIES VERSION ${PROJECT_VERSION}
                                               SOVERSION ${PROJECT_VERSION_MAJOR}.${PROJECT_VERSION_MINOR})
    # Calls inside the library go straight to its own functions (no PLT), which may then be
    # inlined: nobody replaces one of them by preloading another library.
    target_compile_options(${target} PRIVATE -fno-semantic-interposition)
  endif()
  install(TARGETS ${target} EXPORT RTMTargets
          ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT dev
          LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT runtime NAMELINK_COMPONENT dev)
endfunction()

# rtm_install_programs(<targets...>): executables users run.
function(rtm_install_programs)
  install(TARGETS ${ARGN} RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT runtime)
endfunction()

# After every library is declared: the export set, the config files, the IDL, the docs.
function(rtm_install_package)
  install(EXPORT RTMTargets NAMESPACE RTM:: DESTINATION ${RTM_INSTALL_CMAKEDIR} COMPONENT dev)
  export(EXPORT RTMTargets NAMESPACE RTM:: FILE ${PROJECT_BINARY_DIR}/RTMTargets.cmake)
  write_basic_package_version_file(${PROJECT_BINARY_DIR}/RTMConfigVersion.cmake
                                   COMPATIBILITY SameMinorVersion)
  # Installed: the IDL folder relative to the package.
  set(RTM_CONFIG_IDL_DIR ${RTM_INSTALL_IDLDIR})
  configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/RTMConfig.cmake.in
                                ${PROJECT_BINARY_DIR}/install/RTMConfig.cmake
                                INSTALL_DESTINATION ${RTM_INSTALL_CMAKEDIR}
                                PATH_VARS RTM_CONFIG_IDL_DIR)
  # From the build tree: the source tree's IDL folder.
  set(RTM_CONFIG_IDL_DIR ${PROJECT_SOURCE_DIR}/idl)
  configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/RTMConfig.cmake.in
                                ${PROJECT_BINARY_DIR}/RTMConfig.cmake
                                INSTALL_DESTINATION ${PROJECT_BINARY_DIR}
                                PATH_VARS RTM_CONFIG_IDL_DIR)
  configure_file(${PROJECT_SOURCE_DIR}/cmake/RtmIdl.cmake ${PROJECT_BINARY_DIR}/RtmIdl.cmake COPYONLY)
  configure_file(${PROJECT_SOURCE_DIR}/cmake/RtmComponent.cmake ${PROJECT_BINARY_DIR}/RtmComponent.cmake COPYONLY)
  install(FILES ${PROJECT_BINARY_DIR}/install/RTMConfig.cmake ${PROJECT_BINARY_DIR}/RTMConfigVersion.cmake
                ${PROJECT_SOURCE_DIR}/cmake/RtmIdl.cmake ${PROJECT_SOURCE_DIR}/cmake/RtmComponent.cmake
          DESTINATION ${RTM_INSTALL_CMAKEDIR} COMPONENT dev)
  install(FILES ${PROJECT_SOURCE_DIR}/idl/RTM.idl ${PROJECT_SOURCE_DIR}/idl/RTMData.idl
                ${PROJECT_SOURCE_DIR}/idl/RTMExt.idl
          DESTINATION ${RTM_INSTALL_IDLDIR} COMPONENT dev)
  # The licence's NOTICE goes with the package (Apache-2.0 section 4(d)); the licence text itself
  # is Debian's /usr/share/common-licenses/Apache-2.0, which copyright points to.
  install(FILES ${PROJECT_SOURCE_DIR}/README.md ${PROJECT_SOURCE_DIR}/NOTICE ${PROJECT_SOURCE_DIR}/cmake/debian/copyright
          DESTINATION ${CMAKE_INSTALL_DATAROOTDIR}/doc/rtm COMPONENT runtime)
  # Each Debian package has its own copyright and changelog (the -dev one too).
  install(FILES ${PROJECT_SOURCE_DIR}/NOTICE ${PROJECT_SOURCE_DIR}/cmake/debian/copyright
          DESTINATION ${CMAKE_INSTALL_DATAROOTDIR}/doc/rtm-dev COMPONENT dev)
  # Debian's changelog.gz, made reproducibly (no name or time in the gzip header).
  configure_file(${PROJECT_SOURCE_DIR}/cmake/debian/changelog.in ${PROJECT_BINARY_DIR}/debian/changelog @ONLY)
  execute_process(COMMAND gzip -9nc ${PROJECT_BINARY_DIR}/debian/changelog
                  OUTPUT_FILE ${PROJECT_BINARY_DIR}/debian/changelog.gz COMMAND_ERROR_IS_FATAL ANY)
  install(FILES ${PROJECT_BINARY_DIR}/debian/changelog.gz DESTINATION ${CMAKE_INSTALL_DATAROOTDIR}/doc/rtm
          COMPONENT runtime)
  install(FILES ${PROJECT_BINARY_DIR}/debian/changelog.gz DESTINATION ${CMAKE_INSTALL_DATAROOTDIR}/doc/rtm-dev
          COMPONENT dev)
  install(FILES ${PROJECT_SOURCE_DIR}/cmake/debian/lintian-overrides DESTINATION ${CMAKE_INSTALL_DATAROOTDIR}/lintian/overrides
          RENAME rtm COMPONENT runtime)
  install(DIRECTORY ${PROJECT_SOURCE_DIR}/docs/ DESTINATION ${CMAKE_INSTALL_DATAROOTDIR}/doc/rtm COMPONENT runtime
          FILES_MATCHING PATTERN "*.md")
endfunction()

# rtm_debian_package(): `cpack -G DEB` in the build folder makes two packages, as Debian splits
# a library: rtm_<version>_amd64.deb, the running system (the programs, the examples and the
# demo, the models, the docs, the shared libraries the programs share), and
# rtm-dev_<version>_amd64.deb, the base to build on (the libraries' link names, the static
# libraries, headers, IDL, the CMake package and the scaffold's templates), which depends on
# rtm of the same version.
# rtm Depends: the shared libraries the programs link (dpkg-shlibdeps finds them; omniORB's are
# libomniorb4-2 and libomnithread4 unless RTM_STATIC_OMNIORB is ON) and the naming service.
# rtm-dev Depends: what find_package(RTM COMPONENTS core host) needs to build a project, and
# Recommends what the PA10's part (pa10) needs besides. copyright (DEP-5) names the licence of
# every work whose code is compiled into the packages' files.
function(rtm_debian_package)
  set(CPACK_GENERATOR DEB)
  set(CPACK_PACKAGE_NAME rtm)
  set(CPACK_PACKAGE_VENDOR "RTM developers")
  set(CPACK_PACKAGE_CONTACT "RTM developers <rtm-dev@lists.example.org>")
  # Each package's synopsis is the first line of its description (below), not a summary of all.
  set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "")
  set(CPACK_DEB_COMPONENT_INSTALL ON)
  set(CPACK_COMPONENTS_ALL runtime dev)
  set(CPACK_DEBIAN_RUNTIME_PACKAGE_NAME rtm)
  set(CPACK_DEBIAN_DEV_PACKAGE_NAME rtm-dev)
  # One string each: separate arguments would make a list, its ';' written into the control file.
  string(CONCAT CPACK_DEBIAN_RUNTIME_DESCRIPTION
         "RT-Middleware component framework for robot control\n"
         "Components with ports (omniORB), the rtm browser and launcher, and\n"
         "a PA10 force servo on SocketCAN or on a MuJoCo stand-in (rtm demo).")
  string(CONCAT CPACK_DEBIAN_DEV_DESCRIPTION
         "RT-Middleware component framework for robot control - development files\n"
         "The libraries, headers, IDL and CMake package to build components\n"
         "of one's own (find_package(RTM), rtm new component).")
  set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
  set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
  set(CPACK_DEBIAN_RUNTIME_PACKAGE_SECTION misc)
  set(CPACK_DEBIAN_DEV_PACKAGE_SECTION libdevel)
  set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
  set(CPACK_DEBIAN_PACKAGE_HOMEPAGE "https://example.org/rtm")
  set(CPACK_DEBIAN_RUNTIME_PACKAGE_SHLIBDEPS ON)
  # rtm's own shared libraries: a shlibs file (a package built on them depends on this very
  # version: 0.x changes the ABI with each release) and the ldconfig trigger.
  set(CPACK_DEBIAN_PACKAGE_GENERATE_SHLIBS ON)
  set(CPACK_DEBIAN_PACKAGE_GENERATE_SHLIBS_POLICY "=")
  set(CPACK_DEBIAN_RUNTIME_PACKAGE_CONTROL_EXTRA ${PROJECT_SOURCE_DIR}/cmake/debian/triggers)
  # python3: the demo's stall witness (share/rtm/tools/wakeup_witness.py) and the package rtm
  # (import rtm), whose data come as numpy arrays.
  if(RTM_PYTHON_DEB_DEPENDS)
    set(CPACK_DEBIAN_RUNTIME_PACKAGE_DEPENDS "omniorb-nameserver, ${RTM_PYTHON_DEB_DEPENDS}")
  else()
    set(CPACK_DEBIAN_RUNTIME_PACKAGE_DEPENDS "omniorb-nameserver, python3")
  endif()
  set(CPACK_DEBIAN_RUNTIME_PACKAGE_SUGGESTS "can-utils, gnuplot")
  set(CPACK_DEBIAN_DEV_PACKAGE_DEPENDS
      "rtm (= ${PROJECT_VERSION}), omniidl, libomniorb4-dev, libssl-dev, libcli11-dev, libspdlog-dev, libfmt-dev, cmake (>= 3.25), g++, pkg-config")
  set(CPACK_DEBIAN_DEV_PACKAGE_RECOMMENDS "libeigen3-dev, liborocos-kdl-dev, liburdfdom-dev")
  set(CPACK_DEBIAN_DEV_PACKAGE_SUGGESTS "libgtest-dev")
  set(CPACK_STRIP_FILES ON)
  # cpack packs what was built (tests run it after the build); it never starts a build itself.
  set(CMAKE_SKIP_INSTALL_ALL_DEPENDENCY ON PARENT_SCOPE)
  include(CPack)
endfunction()
