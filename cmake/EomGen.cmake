# add_eom_model(): a model's kernels, generated at build time (docs/CONTRACT.md §3).
#
#   add_eom_model(<name>
#     HEADER <model header>              # the model's .hpp (relative to the calling directory)
#     CLASS <C++ type>                   # e.g. SpringPendulum, or my::Models<10>
#     | URDF <robot.urdf>                # instead of HEADER/CLASS: eomgen-urdf writes the model
#                                        # header eom::urdf_models::<name> at build time
#     | MJCF <model.xml>                 # or a MuJoCo model: MuJoCo's compiler reads it and
#                                        # eomgen-mjcf writes eom::mjcf_models::<name> (needs
#                                        # MuJoCo, Debian's libmujoco-dev)
#     [FLOATING_BASE]                    # URDF only: the root link flies free (a free joint,
#                                        # docs/CONTRACT.md §1), for a file without a floating joint
#     [INERTIA_POLICY error|warn|nearest] # URDF only: a moving link whose inertia is not
#                                        # physically consistent is refused (error, the default),
#                                        # taken with a warning (warn), or replaced by the nearest
#                                        # consistent one with a warning (nearest)
#     [GROUND [<height>]]                # URDF only: the model header also states the scene
#                                        # for eom::contact_step (docs/CONTRACT.md §1, "URDF:
#                                        # the scene"): the links' <collision> boxes, spheres,
#                                        # capsules and cylinders as geoms (a mesh is skipped
#                                        # with a warning; a cylinder meets the ground only), a
#                                        # ground plane z = <height> (default 0) against every
#                                        # moving one, MuJoCo's default contact parameters,
#                                        # <limit>s as limits, damping
#     [COLLISION_PAIRS <linkA>:<linkB> ...] # URDF only: link pairs whose geoms may touch (each
#                                        # of A's against each of B's); alone or with GROUND
#     [FRAMES <frame> ...]               # the frames (URDF: link names; MJCF: body and site
#                                        # names) to generate task-space
#                                        # kernels for: frame_placement, frame_jacobian and
#                                        # frame_acceleration_bias, their index f in this order
#     [WRENCH_INPUTS <frame>[:<kind>] ...] # external wrenches as more inputs, appended to u
#                                        # (eom/multibody/wrench_inputs.hpp): per frame of a
#                                        # tree-form model, kind wrench (default: force then
#                                        # torque about its origin, world axes; 6 inputs), force
#                                        # (3), body_wrench or body_force (in the frame's axes)
#     [CONTACTS <set>=<frame>[:6d][,<frame>[:6d]...] ...] # rigid contact sets (docs/CONTRACT.md
#                                        # §3): contact_dynamics and impulse_dynamics, their index s
#                                        # in this order; a frame is a point contact (3 rows)
#                                        # unless marked :6d; the frames join FRAMES
#     [KERNELS <kernel> ...]             # default: every kernel that applies, except the
#                                        # on-request forward_dynamics_parameter_derivatives
#                                        # (`defaults` stands for that default set, so
#                                        # KERNELS defaults forward_dynamics_batch adds one)
#     [FIXED_PARAMETERS <p>=<value> ...] # baked in as constants; removed from p. ALL fixes every
#                                        # parameter at its default (<p>=<value> entries then
#                                        # override a default)
#     [FREE_PARAMETERS <p> ...]          # with FIXED_PARAMETERS ALL: the ones that stay free
#     [BATCH_LANES 2|4|8]                # states per forward_dynamics_batch call (default 4)
#     [NAMESPACE <ns>]                   # default: <name>
#     [PYTHON]                           # also a Python extension module (below)
#     [PYTHON_MODULE <module>]           # its module name (default <name>; implies PYTHON)
#     [CUDA])                            # <name> compiled by nvcc: host code and device code (below)
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
# written), EOMGEN_TRACER (the tracer's target name; the models of one HEADER and CLASS share
# one), EOMGEN_HEADER, EOMGEN_CLASS, EOMGEN_URDF, EOMGEN_MJCF, EOMGEN_NAMESPACE. The target
# eomgen_sources_<name> runs the tracer alone.
#
# CUDA (needs the CUDA language enabled: eomgen's build does it where CMake finds nvcc): the
# generated source is compiled by nvcc instead, as relocatable device code (separable
# compilation), so that <name> holds the host code as before and device code of every kernel
# marked EOM_HOST_DEVICE, for CUDA code such as eom::cuda::ensemble (eom/ensemble/cuda/ensemble.hpp).
# A CUDA target that calls the kernels on the device sets CUDA_SEPARABLE_COMPILATION ON itself.
#
# PYTHON: also add_eom_python_module(<name> [MODULE <module>]), below.
#
#   add_eom_python_module(<model> [MODULE <module>] [TARGET <target>])
#
# A pybind11 extension module <module> (default: the model's name) for a model made by
# add_eom_model(), as the target <target> (default <model>_python), written to the calling
# directory's binary dir (property EOMGEN_PYTHON_MODULE_DIR on the target): the model's sizes,
# names and every kernel it has on NumPy arrays, one state or a batch, and integrate()/ensemble()
# (python/eom_python.hpp, python/README.md). It compiles the generated <model>.cpp itself
# (position-independent, with the model target's compile definitions and options) rather than
# linking the static library, which stays as it was. Python: the Python3_EXECUTABLE given, else
# the first of `python3` on PATH and /usr/bin/python3 that imports numpy and pybind11; it needs
# the development headers (Debian: python3-dev python3-numpy python3-pybind11). The binding
# header is found in the eomgen source tree (add_subdirectory(<eomgen>)), or where an installed
# eomgen put it (<prefix>/share/eomgen/python; the package config says where).

include_guard(GLOBAL)

# Where python/eom_python.hpp is (the source tree's python/ folder, next to cmake/).
get_filename_component(_eomgen_python_dir "${CMAKE_CURRENT_LIST_DIR}/../python" ABSOLUTE)
set_property(GLOBAL PROPERTY EOMGEN_PYTHON_DIR "${_eomgen_python_dir}")
unset(_eomgen_python_dir)

function(add_eom_model name)
  # Every configure-time problem is reported against the call, so users see which model it is.
  set(where "add_eom_model(${name})")
  set(urdf "")
  set(mjcf "")
  cmake_parse_arguments(PARSE_ARGV 1 arg "FLOATING_BASE;PYTHON;CUDA"
                        "HEADER;CLASS;URDF;MJCF;NAMESPACE;BATCH_LANES;PYTHON_MODULE;INERTIA_POLICY"
                        "KERNELS;FIXED_PARAMETERS;FREE_PARAMETERS;FRAMES;WRENCH_INPUTS;CONTACTS;GROUND;COLLISION_PAIRS")

  set(identifier "[A-Za-z_][A-Za-z0-9_]*")
  if(NOT name MATCHES "^${identifier}$")
    message(FATAL_ERROR "${where}: the model name must be a C++ identifier (it names the target, "
                        "the files <name>.hpp/.cpp and the default namespace)")
  endif()
  if(arg_UNPARSED_ARGUMENTS)
    list(JOIN arg_UNPARSED_ARGUMENTS " " arg_UNPARSED_ARGUMENTS)
    message(FATAL_ERROR "${where}: unexpected argument(s) \"${arg_UNPARSED_ARGUMENTS}\"; the "
                        "keywords are HEADER, CLASS, URDF, MJCF, FLOATING_BASE, INERTIA_POLICY, GROUND, "
                        "COLLISION_PAIRS, FRAMES, KERNELS, "
                        "WRENCH_INPUTS, CONTACTS, FIXED_PARAMETERS, FREE_PARAMETERS, NAMESPACE, BATCH_LANES, PYTHON, "
                        "PYTHON_MODULE and CUDA")
  endif()
  # GROUND's height is optional (default 0): GROUND alone is a keyword without a value.
  set(ground "")
  if(GROUND IN_LIST arg_KEYWORDS_MISSING_VALUES)
    list(REMOVE_ITEM arg_KEYWORDS_MISSING_VALUES GROUND)
    set(ground 0)
  elseif(DEFINED arg_GROUND)
    list(LENGTH arg_GROUND count)
    if(NOT count EQUAL 1 OR NOT arg_GROUND MATCHES "^[-+]?([0-9]+\\.?[0-9]*|\\.[0-9]+)([eE][-+]?[0-9]+)?$")
      message(FATAL_ERROR "${where}: GROUND \"${arg_GROUND}\": expected one height in metres "
                          "(or GROUND alone: height 0)")
    endif()
    set(ground "${arg_GROUND}")
  endif()
  if(arg_KEYWORDS_MISSING_VALUES)
    message(FATAL_ERROR "${where}: ${arg_KEYWORDS_MISSING_VALUES} given without a value")
  endif()
  if(NOT ground STREQUAL "" OR DEFINED arg_COLLISION_PAIRS)
    if(NOT DEFINED arg_URDF)
      message(FATAL_ERROR "${where}: GROUND and COLLISION_PAIRS are for URDF files; an MJCF model "
                          "states its geoms, pairs and options itself")
    endif()
    foreach(pair IN LISTS arg_COLLISION_PAIRS)
      if(NOT pair MATCHES "^[^:]+:[^:]+$")
        message(FATAL_ERROR "${where}: COLLISION_PAIRS \"${pair}\": expected <linkA>:<linkB>")
      endif()
    endforeach()
  endif()
  if(TARGET ${name} OR TARGET eom::${name})
    message(FATAL_ERROR "${where}: a target named \"${name}\" or \"eom::${name}\" already exists")
  endif()
  set(work_dir "${CMAKE_CURRENT_BINARY_DIR}/eomgen/${name}.tracer")
  set(out_dir "${CMAKE_CURRENT_BINARY_DIR}/eomgen/${name}")

  if(DEFINED arg_MJCF)
    # A MuJoCo model: MuJoCo's compiler reads it, eomgen-mjcf writes its model header
    # (eom::mjcf_models::<name>) at build time, and from there it is a model like any other.
    if(DEFINED arg_HEADER OR DEFINED arg_CLASS OR DEFINED arg_URDF)
      message(FATAL_ERROR "${where}: give one of MJCF <file>, URDF <file>, or HEADER and CLASS")
    endif()
    if(arg_FLOATING_BASE OR DEFINED arg_INERTIA_POLICY)
      message(FATAL_ERROR "${where}: FLOATING_BASE and INERTIA_POLICY are for URDF files; an "
                          "MJCF model states its free joint, and MuJoCo's compiler its inertias")
    endif()
    cmake_path(ABSOLUTE_PATH arg_MJCF BASE_DIRECTORY "${CMAKE_CURRENT_SOURCE_DIR}" NORMALIZE
               OUTPUT_VARIABLE mjcf)
    if(NOT EXISTS "${mjcf}" OR IS_DIRECTORY "${mjcf}")
      message(FATAL_ERROR "${where}: MJCF \"${arg_MJCF}\" not found (looked for ${mjcf})")
    endif()
    if(NOT TARGET eom::mjcf_tool)
      message(FATAL_ERROR "${where}: MJCF needs the eomgen-mjcf command (target eom::mjcf_tool), "
                          "which is built only where MuJoCo is found: install Debian's "
                          "libmujoco-dev (scripts/setup.sh does) and configure again")
    endif()
    set(header "${work_dir}/model/${name}_model.hpp")
    set(arg_CLASS "eom::mjcf_models::${name}")
    file(MAKE_DIRECTORY "${work_dir}/model")
    # The depfile lists the files the model <include>s, so that editing one writes it again.
    add_custom_command(
      OUTPUT "${header}"
      COMMAND eom::mjcf_tool "${mjcf}" --class ${name} --namespace eom::mjcf_models -o "${header}"
              --depfile "${header}.d"
      DEPENDS eom::mjcf_tool "${mjcf}"
      DEPFILE "${header}.d"
      COMMENT "Writing the model of ${arg_MJCF} (${name}_model.hpp)"
      VERBATIM)
  elseif(DEFINED arg_URDF)
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
    set(inertia_policy "")
    if(DEFINED arg_INERTIA_POLICY)
      if(NOT arg_INERTIA_POLICY MATCHES "^(error|warn|nearest)$")
        message(FATAL_ERROR "${where}: INERTIA_POLICY \"${arg_INERTIA_POLICY}\": expected error, "
                            "warn or nearest")
      endif()
      set(inertia_policy --inertia ${arg_INERTIA_POLICY})
    endif()
    set(scene "")  # GROUND and COLLISION_PAIRS: the scene for eom::contact_step
    if(NOT ground STREQUAL "")
      list(APPEND scene --ground ${ground})
    endif()
    foreach(pair IN LISTS arg_COLLISION_PAIRS)
      list(APPEND scene --collision-pair ${pair})
    endforeach()
    file(MAKE_DIRECTORY "${work_dir}/model")
    add_custom_command(
      OUTPUT "${header}"
      COMMAND eom::urdf_tool "${urdf}" --class ${name} --namespace eom::urdf_models ${free_root}
              ${inertia_policy} ${scene} -o "${header}"
      DEPENDS eom::urdf_tool "${urdf}"
      COMMENT "Writing the model of ${arg_URDF} (${name}_model.hpp)"
      VERBATIM)
  else()
    if(arg_FLOATING_BASE)
      message(FATAL_ERROR "${where}: FLOATING_BASE is for URDF files; a model header states "
                          "`static constexpr bool floating_base = true` itself")
    endif()
    if(DEFINED arg_INERTIA_POLICY)
      message(FATAL_ERROR "${where}: INERTIA_POLICY is for URDF files; a model header's bodies "
                          "must be physically consistent")
    endif()
    foreach(required HEADER CLASS)
      if(NOT DEFINED arg_${required} OR arg_${required} STREQUAL "")
        message(FATAL_ERROR "${where}: ${required} is required "
                            "(HEADER <model header> CLASS <C++ type>, or URDF <robot.urdf>, "
                            "or MJCF <model.xml>)")
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
  # WRENCH_INPUTS: the tracer traces eom::WrenchInputs<CLASS, Spec> instead of CLASS, with Spec
  # written here: each frame's kind, and its inputs' names <frame>_fx ... _tz.
  set(traced_class "${arg_CLASS}")
  set(wrench_spec "")
  if(arg_WRENCH_INPUTS)
    set(entries "")
    set(names "")
    set(checks "")
    set(wrench_frames "")
    set(count 0)
    foreach(entry IN LISTS arg_WRENCH_INPUTS)
      if(NOT entry MATCHES "^([^:\"]+)(:(force|wrench|body_force|body_wrench))?$")
        message(FATAL_ERROR "${where}: WRENCH_INPUTS entry \"${entry}\" is malformed; expected "
                            "<frame> or <frame>:<kind>, kind one of force, wrench (the default), "
                            "body_force, body_wrench")
      endif()
      set(frame "${CMAKE_MATCH_1}")
      set(kind wrench)
      if(CMAKE_MATCH_3)
        set(kind ${CMAKE_MATCH_3})
      endif()
      if(frame IN_LIST wrench_frames)
        message(FATAL_ERROR "${where}: WRENCH_INPUTS names the frame \"${frame}\" twice; one "
                            "wrench per frame (a wrench holds a force)")
      endif()
      list(APPEND wrench_frames "${frame}")
      string(MAKE_C_IDENTIFIER "${frame}" id)
      set(components fx fy fz)
      if(kind MATCHES "wrench$")
        list(APPEND components tx ty tz)
      endif()
      foreach(c IN LISTS components)
        string(APPEND names "\"${id}_${c}\", ")
        math(EXPR count "${count} + 1")
      endforeach()
      string(APPEND entries "{\"${frame}\", eom::WrenchKind::${kind}}, ")
      string(APPEND checks "static_assert(eom::detail::frame_index<${arg_CLASS}>(\"${frame}\") >= 0, "
             "\"${where} WRENCH_INPUTS: '${frame}' is not a frame of the model (its frame_names; "
             "URDF: link names)\");\n")
    endforeach()
    list(LENGTH wrench_frames nwrench)
    set(wrench_spec "#include <eom/multibody/wrench_inputs.hpp>
${checks}struct eomgen_wrench_inputs {  // WRENCH_INPUTS
  static constexpr std::array<eom::WrenchInput, ${nwrench}> wrench_inputs{{${entries}}};
  static constexpr std::array<std::string_view, ${count}> input_names{${names}};
};")
    set(traced_class "eom::WrenchInputs<${arg_CLASS}, eomgen_wrench_inputs>")
  endif()
  foreach(frame IN LISTS arg_FRAMES)
    list(APPEND options --frame ${frame})
  endforeach()
  foreach(set IN LISTS arg_CONTACTS)  # checked by the tracer, which knows the frames
    list(APPEND options --contact ${set})
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
  # only when it changes, so configuring again does not rebuild it. Its program depends on the
  # header and the traced class alone (the options reach it on its command line), so the models
  # of one project that trace the same class share one tracer: compiled once, each ~4 s of -O0
  # (a URDF or MJCF model's header is its own, so those never share).
  string(SHA1 tracer_key "${header}|${traced_class}|${wrench_spec}")
  get_property(tracer GLOBAL PROPERTY "EOMGEN_TRACER_${tracer_key}")
  if(NOT tracer)
    set(tracer eomgen_tracer_${name})
    set_property(GLOBAL PROPERTY "EOMGEN_TRACER_${tracer_key}" ${tracer})
    file(CONFIGURE OUTPUT "${work_dir}/${name}_tracer.cpp" @ONLY CONTENT [[
// The tracer of model @name@, written by add_eom_model(); it writes @name@.hpp and @name@.cpp.
#include "@header@"
#include <eomgen/tracer.hpp>
@wrench_spec@
int main(int argc, char** argv) { return eom::gen::tracer_main<@traced_class@>(argc, argv); }
]])
    add_executable(${tracer} "${work_dir}/${name}_tracer.cpp" "${header}")
    cmake_path(GET header PARENT_PATH header_dir)
    target_include_directories(${tracer} PRIVATE "${header_dir}")
    target_link_libraries(${tracer} PRIVATE eom::generator eom::runtime)
    set_target_properties(${tracer} PROPERTIES RUNTIME_OUTPUT_DIRECTORY "${work_dir}")
    # Unoptimized: the tracer runs once, and what it runs for long (derive, optimize, emit) is in
    # eom::generator, compiled optimized; its own unit only records the model on the tape. -O0
    # halves its compile (Solo12's: 9.4 s → 4.2 s) and writes the same bytes (IEEE arithmetic
    # at every level: tests/kernels' generated_up_to_date).
    target_compile_options(${tracer} PRIVATE $<$<COMPILE_LANG_AND_ID:CXX,GNU,Clang>:-O0>)
  endif()

  # Run it. The tracer rewrites <name>.hpp/.cpp only when their content changes (and writes
  # nothing on error), so their time stamps cannot tell whether it ran: the stamp file does, and
  # it is the command's only OUTPUT. The sources are BYPRODUCTS: as OUTPUTs, the Makefile
  # generators would touch them after every run and so recompile <name> even when nothing changed
  # (Ninja would not); no generator touches byproducts (tests/kernels: consumer.find_package).
  set(outputs "${out_dir}/${name}.hpp" "${out_dir}/${name}.cpp")
  set(stamp "${work_dir}/${name}.stamp")
  file(MAKE_DIRECTORY "${out_dir}" "${work_dir}")  # Ninja creates output directories, Make does not
  add_custom_command(
    OUTPUT "${stamp}"
    BYPRODUCTS ${outputs}
    COMMAND ${tracer} ${options} --out-dir "${out_dir}"
    COMMAND "${CMAKE_COMMAND}" -E touch "${stamp}"
    DEPENDS ${tracer} "${header}"
    COMMENT "Generating the kernels of ${arg_CLASS} (${name}.hpp, ${name}.cpp)"
    VERBATIM)

  # The generation as a target of its own, which <name> and other targets (the Python module)
  # wait for, so that the command never runs twice in parallel.
  add_custom_target(eomgen_sources_${name} DEPENDS "${stamp}")
  set(sources ${outputs})
  if(arg_CUDA)  # nvcc compiles the source through a .cu that includes it
    if(NOT CMAKE_CUDA_COMPILE_OBJECT)  # set where the language is enabled, and below
      message(FATAL_ERROR "${where}: CUDA needs the CUDA language enabled in this directory or one "
                          "above it (enable_language(CUDA) in the top-level CMakeLists.txt; "
                          "eomgen's own build enables it where CMake finds nvcc)")
    endif()
    set(cuda_source "${work_dir}/${name}_cuda.cu")
    file(CONFIGURE OUTPUT "${cuda_source}" @ONLY CONTENT [[
// Model @name@'s generated kernels compiled by nvcc (add_eom_model(... CUDA)): host and device code.
#include "@name@.cpp"
]])
    set_source_files_properties("${cuda_source}" PROPERTIES OBJECT_DEPENDS "${out_dir}/${name}.cpp")
    set(sources "${out_dir}/${name}.hpp" "${cuda_source}")
  endif()
  add_library(${name} STATIC ${sources})
  # Options for the generated kernels alone, from the environment at configure time: the
  # sanitizer run (scripts/sanitize.sh) compiles them at -O1 -g1, since a big kernel's
  # instrumented -O2 -g compile takes tens of GB.
  if(DEFINED ENV{EOM_KERNEL_CXXFLAGS})
    separate_arguments(kernel_options UNIX_COMMAND "$ENV{EOM_KERNEL_CXXFLAGS}")
    set_source_files_properties("${out_dir}/${name}.cpp" PROPERTIES
                                COMPILE_OPTIONS "${kernel_options}")
  endif()
  # GCC's basic-block (SLP) vectorizer packs pairs of a straight-line kernel's scalar operations
  # into vectors and pays for it in shuffles: the kernels ran 5-25% slower with it
  # (docs/benchmarks/pinocchio.md); loops and the batch kernels' explicit vectors are unaffected.
  target_compile_options(${name} PRIVATE $<$<COMPILE_LANG_AND_ID:CXX,GNU>:-fno-tree-slp-vectorize>)
  add_dependencies(${name} eomgen_sources_${name})
  add_library(eom::${name} ALIAS ${name})
  target_include_directories(${name} PUBLIC "$<BUILD_INTERFACE:${out_dir}>")
  target_compile_features(${name} PUBLIC cxx_std_17)  # what the generated code needs
  if(arg_CUDA)
    target_include_directories(${name} PRIVATE "${out_dir}")
    # (nvcc's default C++17 suffices.) numeric_limits (constexpr host functions) in device code;
    # EDG's note on the unused Taylor helpers silenced.
    target_compile_options(${name} PRIVATE
                           $<$<COMPILE_LANGUAGE:CUDA>:--expt-relaxed-constexpr -diag-suppress=177>)
    set_target_properties(${name} PROPERTIES CUDA_SEPARABLE_COMPILATION ON
                                             POSITION_INDEPENDENT_CODE ON)
  endif()
  set_target_properties(${name} PROPERTIES
    EOMGEN_OUTPUT_DIR "${out_dir}" EOMGEN_TRACER ${tracer}
    EOMGEN_HEADER "${header}" EOMGEN_CLASS "${arg_CLASS}" EOMGEN_URDF "${urdf}" EOMGEN_MJCF "${mjcf}"
    EOMGEN_NAMESPACE "${arg_NAMESPACE}")
  # The model header states a scene for eom::contact_step: an MJCF model's, or a URDF robot's with
  # GROUND or COLLISION_PAIRS.
  if(NOT mjcf STREQUAL "" OR NOT ground STREQUAL "" OR DEFINED arg_COLLISION_PAIRS)
    set_target_properties(${name} PROPERTIES EOMGEN_SCENE TRUE)
  else()
    set_target_properties(${name} PROPERTIES EOMGEN_SCENE FALSE)
  endif()

  if(arg_PYTHON OR DEFINED arg_PYTHON_MODULE)
    if(DEFINED arg_PYTHON_MODULE)
      add_eom_python_module(${name} MODULE ${arg_PYTHON_MODULE})
    else()
      add_eom_python_module(${name})
    endif()
  endif()
endfunction()

# The Python interpreter and headers for add_eom_python_module(), in the caller's scope (a macro:
# FindPython3's variables and Python3_add_library are used right after).
macro(_eom_find_python where)
  if(NOT Python3_EXECUTABLE)
    # The first python3 that has what the module needs: the one on PATH (a virtual environment)
    # may lack numpy or pybind11 where the system's has them (Debian: /usr/bin/python3).
    find_program(_eom_path_python NAMES python3 NO_CACHE)
    foreach(_eom_candidate IN ITEMS ${_eom_path_python} /usr/bin/python3)
      if(EXISTS "${_eom_candidate}")
        execute_process(COMMAND "${_eom_candidate}" -c "import numpy, pybind11"
                        RESULT_VARIABLE _eom_rc OUTPUT_QUIET ERROR_QUIET)
        if(_eom_rc EQUAL 0)
          set(Python3_EXECUTABLE "${_eom_candidate}" CACHE FILEPATH
              "The Python interpreter of eomgen's Python modules")
          break()
        endif()
      endif()
    endforeach()
    if(NOT Python3_EXECUTABLE)
      message(FATAL_ERROR "${where}: PYTHON needs a python3 that imports numpy and pybind11 "
                          "(Debian: apt-get install python3-dev python3-numpy python3-pybind11), "
                          "or -DPython3_EXECUTABLE=<python>")
    endif()
  endif()
  find_package(Python3 COMPONENTS Interpreter Development.Module QUIET)
  if(NOT Python3_Development.Module_FOUND)
    message(FATAL_ERROR "${where}: PYTHON: no development headers for ${Python3_EXECUTABLE} "
                        "(Debian: apt-get install python3-dev)")
  endif()
  if(NOT EOMGEN_PYBIND11_INCLUDE_DIR)
    execute_process(COMMAND "${Python3_EXECUTABLE}" -c "import pybind11; print(pybind11.get_include())"
                    RESULT_VARIABLE _eom_rc OUTPUT_VARIABLE _eom_pybind11 ERROR_QUIET
                    OUTPUT_STRIP_TRAILING_WHITESPACE)
    if(NOT _eom_rc EQUAL 0 OR NOT EXISTS "${_eom_pybind11}/pybind11/pybind11.h")
      # Name the interpreter, all it lacks, and one here that has it (the module is built for,
      # and imported by, Python3_EXECUTABLE).
      set(_eom_lacks "")
      foreach(_eom_module numpy pybind11)
        execute_process(COMMAND "${Python3_EXECUTABLE}" -c "import ${_eom_module}"
                        RESULT_VARIABLE _eom_rc OUTPUT_QUIET ERROR_QUIET)
        if(NOT _eom_rc EQUAL 0)
          list(APPEND _eom_lacks ${_eom_module})
        endif()
      endforeach()
      list(JOIN _eom_lacks " and " _eom_lacks_text)
      set(_eom_instead "")
      if(NOT Python3_EXECUTABLE STREQUAL "/usr/bin/python3" AND EXISTS /usr/bin/python3)
        execute_process(COMMAND /usr/bin/python3 -c "import numpy, pybind11"
                        RESULT_VARIABLE _eom_rc OUTPUT_QUIET ERROR_QUIET)
        if(_eom_rc EQUAL 0)
          set(_eom_instead " /usr/bin/python3 has them: -DPython3_EXECUTABLE=/usr/bin/python3.")
        endif()
      endif()
      message(FATAL_ERROR "${where}: PYTHON: the interpreter ${Python3_EXECUTABLE} "
                          "(Python3_EXECUTABLE) lacks ${_eom_lacks_text}: the module is built for "
                          "it.${_eom_instead} Or install them for it (${Python3_EXECUTABLE} -m pip "
                          "install numpy pybind11; Debian's python3: apt-get install python3-numpy "
                          "python3-pybind11)")
    endif()
    set(EOMGEN_PYBIND11_INCLUDE_DIR "${_eom_pybind11}" CACHE PATH "pybind11's headers" FORCE)
    mark_as_advanced(EOMGEN_PYBIND11_INCLUDE_DIR)
  endif()
  find_package(Threads REQUIRED)
endmacro()

function(add_eom_python_module model)
  set(where "add_eom_python_module(${model})")
  cmake_parse_arguments(PARSE_ARGV 1 arg "" "MODULE;TARGET" "")
  if(arg_UNPARSED_ARGUMENTS OR arg_KEYWORDS_MISSING_VALUES)
    message(FATAL_ERROR "${where}: the arguments are [MODULE <module>] [TARGET <target>]")
  endif()
  if(NOT TARGET ${model})
    message(FATAL_ERROR "${where}: no target \"${model}\"; call add_eom_model(${model} ...) first")
  endif()
  get_target_property(out_dir ${model} EOMGEN_OUTPUT_DIR)
  get_target_property(namespace ${model} EOMGEN_NAMESPACE)
  if(NOT out_dir OR NOT namespace)
    message(FATAL_ERROR "${where}: \"${model}\" was not made by add_eom_model()")
  endif()
  if(NOT DEFINED arg_MODULE)
    set(arg_MODULE ${model})
  elseif(NOT arg_MODULE MATCHES "^[A-Za-z_][A-Za-z0-9_]*$")
    message(FATAL_ERROR "${where}: MODULE \"${arg_MODULE}\" is not a Python identifier")
  endif()
  if(NOT DEFINED arg_TARGET)
    set(arg_TARGET ${model}_python)
  endif()
  if(TARGET ${arg_TARGET})
    message(FATAL_ERROR "${where}: a target named \"${arg_TARGET}\" already exists")
  endif()
  get_property(python_dir GLOBAL PROPERTY EOMGEN_PYTHON_DIR)
  if(NOT EXISTS "${python_dir}/eom_python.hpp")
    message(FATAL_ERROR "${where}: the binding header eom_python.hpp is not in \"${python_dir}\"; "
                        "Python modules need eomgen's source tree (add_subdirectory(<eomgen>))")
  endif()
  _eom_find_python("${where}")

  set(work_dir "${CMAKE_CURRENT_BINARY_DIR}/eomgen/${arg_TARGET}.python")
  set(source "${work_dir}/${arg_MODULE}_module.cpp")
  # A model header that states its scene (MJCF; URDF with GROUND or COLLISION_PAIRS): the module
  # also steps it with contact (python/eom_python_contact.hpp: rollout, contact_step).
  get_target_property(scene ${model} EOMGEN_SCENE)
  if(scene)
    get_target_property(scene_class ${model} EOMGEN_CLASS)
    get_target_property(scene_header ${model} EOMGEN_HEADER)
    cmake_path(GET scene_header PARENT_PATH scene_dir)
    cmake_path(GET scene_header FILENAME scene_file)
    file(CONFIGURE OUTPUT "${source}" @ONLY CONTENT [[
// The Python module @arg_MODULE@ of model @model@, written by add_eom_python_module().
#include "@model@.hpp"
#include "@scene_file@"
#include "eom_python_contact.hpp"
PYBIND11_MODULE(@arg_MODULE@, m) {
  eom::python::bind_model<::@namespace@::Kernels>(m, "@model@");
  eom::python::bind_contact_simulation<::@namespace@::Kernels, ::@scene_class@>(m);
}
]])
  else()
    file(CONFIGURE OUTPUT "${source}" @ONLY CONTENT [[
// The Python module @arg_MODULE@ of model @model@, written by add_eom_python_module().
#include "@model@.hpp"
#include "eom_python.hpp"
PYBIND11_MODULE(@arg_MODULE@, m) { eom::python::bind_model<::@namespace@::Kernels>(m, "@model@"); }
]])
  endif()
  # The generated kernels, compiled again position-independent for the module, with the model
  # target's own definitions and options (e.g. EOM_LIBMVEC).
  set(kernels "${out_dir}/${model}.cpp")
  set_source_files_properties("${kernels}" PROPERTIES GENERATED TRUE)
  add_library(${arg_TARGET}_kernels OBJECT "${kernels}")
  add_dependencies(${arg_TARGET}_kernels eomgen_sources_${model})
  target_include_directories(${arg_TARGET}_kernels PRIVATE "${out_dir}")
  target_compile_definitions(${arg_TARGET}_kernels PRIVATE
                             "$<TARGET_PROPERTY:${model},COMPILE_DEFINITIONS>")
  target_compile_options(${arg_TARGET}_kernels PRIVATE "$<TARGET_PROPERTY:${model},COMPILE_OPTIONS>")
  target_compile_features(${arg_TARGET}_kernels PRIVATE cxx_std_17)
  set_target_properties(${arg_TARGET}_kernels PROPERTIES POSITION_INDEPENDENT_CODE ON
                        CXX_VISIBILITY_PRESET hidden)
  Python3_add_library(${arg_TARGET} MODULE WITH_SOABI "${source}"
                      $<TARGET_OBJECTS:${arg_TARGET}_kernels>)
  add_dependencies(${arg_TARGET} eomgen_sources_${model})
  target_include_directories(${arg_TARGET} PRIVATE "${out_dir}" "${python_dir}")
  if(scene)
    target_include_directories(${arg_TARGET} PRIVATE "${scene_dir}")
    add_dependencies(${arg_TARGET} ${model})
  endif()
  target_include_directories(${arg_TARGET} SYSTEM PRIVATE "${EOMGEN_PYBIND11_INCLUDE_DIR}")
  target_link_libraries(${arg_TARGET} PRIVATE eom::runtime Threads::Threads)
  target_compile_features(${arg_TARGET} PRIVATE cxx_std_20)
  set_target_properties(${arg_TARGET} PROPERTIES
    OUTPUT_NAME ${arg_MODULE} CXX_VISIBILITY_PRESET hidden VISIBILITY_INLINES_HIDDEN ON
    LIBRARY_OUTPUT_DIRECTORY "${CMAKE_CURRENT_BINARY_DIR}"
    EOMGEN_PYTHON_MODULE_DIR "${CMAKE_CURRENT_BINARY_DIR}" EOMGEN_PYTHON_MODULE ${arg_MODULE})
endfunction()
