# Install rules and the package config. After `cmake --install`, a consumer writes
#   find_package(eomgen CONFIG REQUIRED)
# and gets eom::runtime, eom::generator and add_eom_model(), and eom::mpi when eomgen was built
# with MPI and MPI is found again (find_package(eomgen CONFIG REQUIRED COMPONENTS mpi) requires it;
# COMPONENTS naming only others, e.g. python, the binding header, skips MPI);
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
set(EOM_INSTALL_PYTHON_HEADER_DIR "${CMAKE_INSTALL_DATADIR}/eomgen/python")  # eom_python.hpp
# ... as the package config finds it: relative to its own folder (PACKAGE_PREFIX_DIR is taken over
# by the configs of the dependencies it finds, e.g. fmt's).
file(RELATIVE_PATH EOM_CONFIG_TO_PYTHON_HEADER "/prefix/${EOM_INSTALL_CMAKEDIR}"
     "/prefix/${EOM_INSTALL_PYTHON_HEADER_DIR}")

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

# Python: the binding header (python/eom_python.hpp), which add_eom_model(... PYTHON) of an
# installed eomgen compiles (the package config points EOMGEN_PYTHON_DIR at it), and the eomgen
# package (python/eomgen, component python_package) in EOM_INSTALL_PYTHONDIR, with
# eomgen/_installed.py saying where this installation's package config is: eomgen.build() then
# uses it through find_package, its generator and eomgen-urdf already built (python/README.md).
install(FILES "${PROJECT_SOURCE_DIR}/python/eom_python.hpp" "${PROJECT_SOURCE_DIR}/python/eom_python_contact.hpp"
        DESTINATION "${EOM_INSTALL_PYTHON_HEADER_DIR}")
if(NOT DEFINED EOM_INSTALL_PYTHONDIR)
  # Where this prefix's python3 looks: lib/python3.X/dist-packages on Debian (which searches
  # /usr/local/lib/python3.X/dist-packages), else lib/python3.X/site-packages. The interpreter:
  # Python3_EXECUTABLE, else the first python3 that imports numpy and pybind11, else python3.
  set(eom_candidates ${Python3_EXECUTABLE})
  find_program(eom_install_path_python NAMES python3 NO_CACHE)
  list(APPEND eom_candidates ${eom_install_path_python} /usr/bin/python3)
  set(eom_pythondir "lib/python3/dist-packages")
  set(eom_pythondir_found FALSE)
  foreach(check "import numpy, pybind11" "")
    foreach(candidate IN LISTS eom_candidates)
      if(NOT eom_pythondir_found AND EXISTS "${candidate}")
        execute_process(
          COMMAND "${candidate}" -c "${check}
import sys
v = sys.version_info
print(f'lib/python{v[0]}.{v[1]}/' + ('dist-packages' if any(p.endswith('dist-packages') for p in sys.path) else 'site-packages'))"
          RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_QUIET OUTPUT_STRIP_TRAILING_WHITESPACE)
        if(rc EQUAL 0 AND out)
          set(eom_pythondir "${out}")
          set(eom_pythondir_found TRUE)
        endif()
      endif()
    endforeach()
  endforeach()
  set(EOM_INSTALL_PYTHONDIR "${eom_pythondir}" CACHE STRING
      "Where the eomgen Python package is installed, relative to the prefix")
endif()
if(IS_ABSOLUTE "${EOM_INSTALL_PYTHONDIR}" OR IS_ABSOLUTE "${EOM_INSTALL_CMAKEDIR}")
  message(FATAL_ERROR "EOM_INSTALL_PYTHONDIR and EOM_INSTALL_CMAKEDIR must be relative to the "
                      "prefix (the Python package finds the package config by a relative path)")
endif()
# Paths relative to the package folder, so that the installation can move as a whole.
set(eom_package "/prefix/${EOM_INSTALL_PYTHONDIR}/eomgen")
file(RELATIVE_PATH eom_cmake_dir "${eom_package}" "/prefix/${EOM_INSTALL_CMAKEDIR}")
set(eom_parts "")
foreach(part "${EOM_INSTALL_CMAKEDIR}" "${CMAKE_INSTALL_INCLUDEDIR}/eom" "${CMAKE_INSTALL_INCLUDEDIR}/eomgen"
             "${EOM_INSTALL_PYTHON_HEADER_DIR}"
             "${CMAKE_INSTALL_LIBDIR}/${CMAKE_STATIC_LIBRARY_PREFIX}eom_generator${CMAKE_STATIC_LIBRARY_SUFFIX}"
             "${CMAKE_INSTALL_BINDIR}/eomgen-urdf${CMAKE_EXECUTABLE_SUFFIX}"
             "${CMAKE_INSTALL_BINDIR}/eomgen-mjcf${CMAKE_EXECUTABLE_SUFFIX}")  # where MuJoCo was found
  file(RELATIVE_PATH relative "${eom_package}" "/prefix/${part}")
  string(APPEND eom_parts "    \"${relative}\",\n")
endforeach()
file(CONFIGURE OUTPUT "${PROJECT_BINARY_DIR}/python/_installed.py" @ONLY CONTENT [[
# Written by eomgen's install (cmake/Install.cmake): the installed eomgen that eomgen.build() uses,
# relative to this package's folder.
CMAKE_DIR = "@eom_cmake_dir@"  # eomgenConfig.cmake
PARTS = [  # the files whose change makes new modules (eomgen._build._Origin.fingerprint)
@eom_parts@]
]])
install(DIRECTORY "${PROJECT_SOURCE_DIR}/python/eomgen/" DESTINATION "${EOM_INSTALL_PYTHONDIR}/eomgen"
        COMPONENT python_package FILES_MATCHING PATTERN "*.py" PATTERN "__pycache__" EXCLUDE)
install(FILES "${PROJECT_BINARY_DIR}/python/_installed.py" DESTINATION "${EOM_INSTALL_PYTHONDIR}/eomgen"
        COMPONENT python_package)
