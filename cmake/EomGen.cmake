# add_eom_model(): a model's kernels, generated at build time (docs/CONTRACT.md §3).
#
#   add_eom_model(<name>
#     HEADER <model header>              # the model's .hpp (relative to the calling directory)
#     CLASS <C++ type>                   # e.g. SpringPendulum, or my::Models<10>
#     | URDF <robot.urdf>                # instead of HEADER/CLASS: eomgen-urdf writes the model
#                                        # header eom::urdf_models::<name> at build time
#     [FLOATING_BASE]                    # URDF only: the root link flies free (a free joint,
#                                        # docs/CONTRACT.md §1), for a file without a floating joint
#     [FRAMES <frame> ...]               # the frames (URDF: link names) to generate task-space
#                                        # kernels for: frame_placement, frame_jacobian and
#                                        # frame_acceleration_bias, their index f in this order
#     [KERNELS <kernel> ...]             # default: every kernel that applies, except the
#                                        # on-request forward_dynamics_parameter_derivatives
#                                        # (`defaults` stands for that default set, so
#                                        # KERNELS defaults forward_dynamics_batch adds one)
#     [FIXED_PARAMETERS <p>=<value> ...] # baked in as constants; removed from p. ALL fixes every
#                                        # parameter at its default (<p>=<value> entries then
#                                        # override a default)
#     [FREE_PARAMETERS <p> ...]          # with FIXED_PARAMETERS ALL: the ones that stay free
#     [BATCH_LANES 2|4|8]                # states per forward_dynamics_batch call (default 4)
#     [NAMESPACE <ns>])                  # default: <name>
#
# Creates the static library <name> (alias eom::<name>) whose include directory holds <name>.hpp.
# How: a one-line tracer program (the model header + eom::generator) is compiled and run at build
# time; it writes <name>.hpp and <name>.cpp, which <name> compiles. The tracer is rebuilt, and the
# code regenerated, whenever the model header (or anything it includes) or the generator changes.
# The library needs the C++ standard library only: it links neither the runtime nor fmt.
#
# Available in this repository's build, to a consumer after add_subdirectory(<eomgen>), and after
# find_package(eomgen CONFIG REQUIRED) (the package config includes this file).
#
# Properties set on <name>, for tests and tools: EOMGEN_OUTPUT_DIR (where <name>.hpp/.cpp are
# written), EOMGEN_TRACER (the tracer's target name), EOMGEN_HEADER, EOMGEN_CLASS.

include_guard(GLOBAL)

function(add_eom_model name)
  # Every configure-time problem is reported against the call, so users see which model it is.
  set(where "add_eom_model(${name})")
  set(urdf "")
  cmake_parse_arguments(PARSE_ARGV 1 arg "FLOATING_BASE" "HEADER;CLASS;URDF;NAMESPACE;BATCH_LANES"
                        "KERNELS;FIXED_PARAMETERS;FREE_PARAMETERS;FRAMES")

  set(identifier "[A-Za-z_][A-Za-z0-9_]*")
  if(NOT name MATCHES "^${identifier}$")
    message(FATAL_ERROR "${where}: the model name must be a C++ identifier (it names the target, "
                        "the files <name>.hpp/.cpp and the default namespace)")
  endif()
  if(arg_UNPARSED_ARGUMENTS)
    list(JOIN arg_UNPARSED_ARGUMENTS " " arg_UNPARSED_ARGUMENTS)
    message(FATAL_ERROR "${where}: unexpected argument(s) \"${arg_UNPARSED_ARGUMENTS}\"; the "
                        "keywords are HEADER, CLASS, URDF, FLOATING_BASE, FRAMES, KERNELS, "
                        "FIXED_PARAMETERS, FREE_PARAMETERS, NAMESPACE and BATCH_LANES")
  endif()
  if(arg_KEYWORDS_MISSING_VALUES)
    message(FATAL_ERROR "${where}: ${arg_KEYWORDS_MISSING_VALUES} given without a value")
  endif()
  if(TARGET ${name} OR TARGET eom::${name})
    message(FATAL_ERROR "${where}: a target named \"${name}\" or \"eom::${name}\" already exists")
  endif()
  set(work_dir "${CMAKE_CURRENT_BINARY_DIR}/eomgen/${name}.tracer")
  set(out_dir "${CMAKE_CURRENT_BINARY_DIR}/eomgen/${name}")

  if(DEFINED arg_URDF)
    # A robot description: eomgen-urdf writes its model header (eom::urdf_models::<name>) at build
    # time, and from there the model goes the same way as every other.
    if(DEFINED arg_HEADER OR DEFINED arg_CLASS)
      message(FATAL_ERROR "${where}: give either URDF <file> or HEADER and CLASS, not both")
    endif()
    cmake_path(ABSOLUTE_PATH arg_URDF BASE_DIRECTORY "${CMAKE_CURRENT_SOURCE_DIR}" NORMALIZE
               OUTPUT_VARIABLE urdf)
    if(NOT EXISTS "${urdf}" OR IS_DIRECTORY "${urdf}")
      message(FATAL_ERROR "${where}: URDF \"${arg_URDF}\" not found (looked for ${urdf})")
    endif()
    if(NOT TARGET eom::urdf_tool)
      message(FATAL_ERROR "${where}: the eomgen-urdf command (target eom::urdf_tool) is not "
                          "defined; use find_package(eomgen CONFIG REQUIRED) or "
                          "add_subdirectory(<eomgen>) before add_eom_model()")
    endif()
    set(header "${work_dir}/model/${name}_model.hpp")
    set(arg_CLASS "eom::urdf_models::${name}")
    set(free_root "")
    if(arg_FLOATING_BASE)
      set(free_root "--floating-base")
    endif()
    file(MAKE_DIRECTORY "${work_dir}/model")
    add_custom_command(
      OUTPUT "${header}"
      COMMAND eom::urdf_tool "${urdf}" --class ${name} --namespace eom::urdf_models ${free_root}
              -o "${header}"
      DEPENDS eom::urdf_tool "${urdf}"
      COMMENT "Writing the model of ${arg_URDF} (${name}_model.hpp)"
      VERBATIM)
  else()
    if(arg_FLOATING_BASE)
      message(FATAL_ERROR "${where}: FLOATING_BASE is for URDF files; a model header states "
                          "`static constexpr bool floating_base = true` itself")
    endif()
    foreach(required HEADER CLASS)
      if(NOT DEFINED arg_${required} OR arg_${required} STREQUAL "")
        message(FATAL_ERROR "${where}: ${required} is required "
                            "(HEADER <model header> CLASS <C++ type>, or URDF <robot.urdf>)")
      endif()
    endforeach()
    cmake_path(ABSOLUTE_PATH arg_HEADER BASE_DIRECTORY "${CMAKE_CURRENT_SOURCE_DIR}" NORMALIZE
               OUTPUT_VARIABLE header)
    if(NOT EXISTS "${header}" OR IS_DIRECTORY "${header}")
      message(FATAL_ERROR "${where}: HEADER \"${arg_HEADER}\" not found (looked for ${header})")
    endif()
  endif()

  if(NOT DEFINED arg_NAMESPACE)
    set(arg_NAMESPACE ${name})
  elseif(NOT arg_NAMESPACE MATCHES "^${identifier}(::${identifier})*$")
    message(FATAL_ERROR "${where}: NAMESPACE \"${arg_NAMESPACE}\" is not a C++ namespace name")
  endif()

  # The tracer's command line: --kernel and --fixed once per entry. Kernel names are checked by
  # the tracer (it alone knows which kernels apply to the model); here only their spelling.
  set(options --name ${name} --class ${arg_CLASS} --namespace ${arg_NAMESPACE})
  foreach(kernel IN LISTS arg_KERNELS)
    if(NOT kernel MATCHES "^${identifier}$")
      message(FATAL_ERROR "${where}: KERNELS entry \"${kernel}\" is not a kernel name")
    endif()
    list(APPEND options --kernel ${kernel})
  endforeach()
  # Frame names are checked by the tracer (it knows the model's frames and the closest names).
  foreach(frame IN LISTS arg_FRAMES)
    list(APPEND options --frame ${frame})
  endforeach()
  if(DEFINED arg_BATCH_LANES)
    if(NOT arg_BATCH_LANES MATCHES "^(2|4|8)$")
      message(FATAL_ERROR "${where}: BATCH_LANES \"${arg_BATCH_LANES}\" must be 2, 4 or 8")
    endif()
    list(APPEND options --batch-lanes ${arg_BATCH_LANES})
  endif()
  set(number "[-+]?([0-9]+(\\.[0-9]*)?|\\.[0-9]+)([eE][-+]?[0-9]+)?")
  set(fixed_names "")
  foreach(entry IN LISTS arg_FIXED_PARAMETERS)
    if(entry STREQUAL "ALL")
      list(APPEND options --fixed ALL)  # the tracer refuses a second ALL
      continue()
    endif()
    if(NOT entry MATCHES "^(${identifier})=${number}$")
      message(FATAL_ERROR "${where}: FIXED_PARAMETERS entry \"${entry}\" is malformed; expected "
                          "<parameter>=<number>, e.g. g=9.81, or ALL")
    endif()
    if(CMAKE_MATCH_1 IN_LIST fixed_names)
      message(FATAL_ERROR "${where}: FIXED_PARAMETERS gives \"${CMAKE_MATCH_1}\" twice")
    endif()
    list(APPEND fixed_names ${CMAKE_MATCH_1})
    list(APPEND options --fixed ${entry})
  endforeach()

  foreach(entry IN LISTS arg_FREE_PARAMETERS)  # checked by the tracer, which knows the names
    list(APPEND options --free ${entry})
  endforeach()

  if(NOT TARGET eom::generator OR NOT TARGET eom::runtime)
    message(FATAL_ERROR "${where}: the targets eom::generator and eom::runtime are not defined; "
                        "use find_package(eomgen CONFIG REQUIRED) or add_subdirectory(<eomgen>) "
                        "before add_eom_model()")
  endif()

  # The tracer: the model header, the generator, and one line of main(). The source is rewritten
  # only when it changes, so configuring again does not rebuild it.
  set(tracer eomgen_tracer_${name})
  file(CONFIGURE OUTPUT "${work_dir}/${name}_tracer.cpp" @ONLY CONTENT [[
// The tracer of model @name@, written by add_eom_model(); it writes @name@.hpp and @name@.cpp.
#include "@header@"
#include <eomgen/tracer.hpp>
int main(int argc, char** argv) { return eom::gen::tracer_main<@arg_CLASS@>(argc, argv); }
]])
  add_executable(${tracer} "${work_dir}/${name}_tracer.cpp" "${header}")
  cmake_path(GET header PARENT_PATH header_dir)
  target_include_directories(${tracer} PRIVATE "${header_dir}")
  target_link_libraries(${tracer} PRIVATE eom::generator eom::runtime)
  set_target_properties(${tracer} PROPERTIES RUNTIME_OUTPUT_DIRECTORY "${work_dir}")

  # Run it. The tracer rewrites <name>.hpp/.cpp only when their content changes (and writes
  # nothing on error), so their time stamps cannot tell whether it ran: the stamp file does.
  # Without it an unchanged output would make every build run the tracer again.
  set(outputs "${out_dir}/${name}.hpp" "${out_dir}/${name}.cpp")
  set(stamp "${work_dir}/${name}.stamp")
  file(MAKE_DIRECTORY "${out_dir}")  # Ninja creates output directories, Make does not
  add_custom_command(
    OUTPUT "${stamp}" ${outputs}
    COMMAND ${tracer} ${options} --out-dir "${out_dir}"
    COMMAND "${CMAKE_COMMAND}" -E touch "${stamp}"
    DEPENDS ${tracer} "${header}"
    COMMENT "Generating the kernels of ${arg_CLASS} (${name}.hpp, ${name}.cpp)"
    VERBATIM)

  add_library(${name} STATIC ${outputs} "${stamp}")
  add_library(eom::${name} ALIAS ${name})
  target_include_directories(${name} PUBLIC "$<BUILD_INTERFACE:${out_dir}>")
  target_compile_features(${name} PUBLIC cxx_std_17)  # what the generated code needs
  set_target_properties(${name} PROPERTIES
    EOMGEN_OUTPUT_DIR "${out_dir}" EOMGEN_TRACER ${tracer}
    EOMGEN_HEADER "${header}" EOMGEN_CLASS "${arg_CLASS}" EOMGEN_URDF "${urdf}")
endfunction()
