# Install rules and the package config. After `cmake --install`, a consumer writes
#   find_package(eomgen CONFIG REQUIRED)
# and gets eom::runtime, eom::generator and add_eom_model(), and eom::mpi when eomgen was built
# with MPI and MPI is found again (find_package(eomgen CONFIG REQUIRED COMPONENTS mpi) requires it);
# the tracers it builds then compile
# against the installed generator and runtime. The generator's own install rule (in
# generator/CMakeLists.txt) puts eom_generator into the same export set, eomgen-targets.
include(CMakePackageConfigHelpers)

option(EOM_INSTALL "Generate eomgen's install rules" ${PROJECT_IS_TOP_LEVEL})
if(NOT EOM_INSTALL)
  return()
endif()

set(EOM_INSTALL_CMAKEDIR "${CMAKE_INSTALL_LIBDIR}/cmake/eomgen" CACHE STRING
    "Where the eomgen package config is installed (relative to the prefix)")

# The runtime is header-only: the INTERFACE target and its headers.
install(TARGETS eom_runtime EXPORT eomgen-targets)
install(DIRECTORY "${PROJECT_SOURCE_DIR}/runtime/include/"
        DESTINATION "${CMAKE_INSTALL_INCLUDEDIR}")

# A static library's PRIVATE links are exported too (as $<LINK_ONLY:...>), so eom_generator's
# private eom_warnings must be in the export set unless it is linked as
# $<BUILD_INTERFACE:eom_warnings>, the better fix. Only its link role is exported: no flags
# reach users.
if(TARGET eom_generator)
  get_target_property(generator_links eom_generator INTERFACE_LINK_LIBRARIES)
  if("$<LINK_ONLY:eom_warnings>" IN_LIST generator_links)
    install(TARGETS eom_warnings EXPORT eomgen-targets)
  endif()
endif()

install(EXPORT eomgen-targets NAMESPACE eom:: FILE eomgenTargets.cmake
        DESTINATION "${EOM_INSTALL_CMAKEDIR}")
# eom::mpi in an export set of its own: it names MPI::MPI_CXX, which the package config defines
# (find_dependency(MPI)) only for a consumer that asks for the component or has MPI itself.
if(TARGET eom_mpi)
  install(TARGETS eom_mpi EXPORT eomgen-mpi-targets)
  install(EXPORT eomgen-mpi-targets NAMESPACE eom:: FILE eomgenMpiTargets.cmake
          DESTINATION "${EOM_INSTALL_CMAKEDIR}")
endif()
configure_package_config_file("${PROJECT_SOURCE_DIR}/cmake/eomgenConfig.cmake.in"
                              "${PROJECT_BINARY_DIR}/eomgenConfig.cmake"
                              INSTALL_DESTINATION "${EOM_INSTALL_CMAKEDIR}")
# 0.x: a minor version may break the contract, so only the same minor version is compatible.
write_basic_package_version_file("${PROJECT_BINARY_DIR}/eomgenConfigVersion.cmake"
                                 COMPATIBILITY SameMinorVersion)
install(FILES "${PROJECT_BINARY_DIR}/eomgenConfig.cmake"
              "${PROJECT_BINARY_DIR}/eomgenConfigVersion.cmake"
              "${PROJECT_SOURCE_DIR}/cmake/EomGen.cmake"
        DESTINATION "${EOM_INSTALL_CMAKEDIR}")
