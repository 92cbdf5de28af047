# kiji_add_tool(): builds one fabric tool as a plugin, in the manner of MeshLab's add_meshlab_plugin.
#
#   kiji_add_tool(<id> SOURCES <file>... [OUTPUT_DIRECTORY <dir>] [NO_INSTALL])
#
# makes a MODULE library kiji_<id>.so (hidden visibility: only KIJI_TOOL_PLUGIN's entry point is
# exported) linked to Kiji::kiji, and after each link writes kiji_<id>.json beside it with
# kiji-plugin-meta, which loads the library once and records its id, label, description, parameters
# and ABI tag, so the host can check a plugin before it loads it. The tool's info().id must be <id>.
#
# The library goes to <Kiji's build dir>/plugins when the tool is built in Kiji's own tree (where
# libkiji looks for it), to the calling folder's build dir otherwise, or to OUTPUT_DIRECTORY. Both
# files are installed into ${CMAKE_INSTALL_LIBDIR}/kiji/plugins unless NO_INSTALL is given.
include_guard(GLOBAL)
include(GNUInstallDirs)

function(kiji_add_tool id)
  cmake_parse_arguments(PARSE_ARGV 1 ARG "NO_INSTALL" "OUTPUT_DIRECTORY" "SOURCES")
  if(ARG_UNPARSED_ARGUMENTS)
    message(FATAL_ERROR "kiji_add_tool(${id}): unexpected arguments ${ARG_UNPARSED_ARGUMENTS}")
  endif()
  if(NOT id MATCHES "^[A-Za-z_][A-Za-z0-9_]*$")
    message(FATAL_ERROR "kiji_add_tool(${id}): a tool id is a verb usable as a Python name "
                        "(letters, digits and _, not starting with a digit)")
  endif()
  if(NOT ARG_SOURCES)
    message(FATAL_ERROR "kiji_add_tool(${id}): no SOURCES given")
  endif()
  if(NOT TARGET Kiji::kiji OR NOT TARGET Kiji::plugin_meta)
    message(FATAL_ERROR "kiji_add_tool(${id}): Kiji::kiji and Kiji::plugin_meta are not defined: "
                        "call find_package(Kiji REQUIRED) first")
  endif()

  set(target kiji_${id})
  # Inside Kiji's own build libkiji is a real target; outside it, an imported one.
  get_target_property(kiji_imported Kiji::kiji IMPORTED)
  if(ARG_OUTPUT_DIRECTORY)
    set(out_dir ${ARG_OUTPUT_DIRECTORY})
  elseif(NOT kiji_imported AND DEFINED Kiji_BINARY_DIR)
    set(out_dir ${Kiji_BINARY_DIR}/plugins)
  else()
    set(out_dir ${CMAKE_CURRENT_BINARY_DIR})
  endif()

  add_library(${target} MODULE ${ARG_SOURCES})
  target_link_libraries(${target} PRIVATE Kiji::kiji)
  target_compile_features(${target} PRIVATE cxx_std_17)
  set_target_properties(${target} PROPERTIES
    PREFIX ""
    LIBRARY_OUTPUT_DIRECTORY ${out_dir}
    CXX_VISIBILITY_PRESET hidden
    C_VISIBILITY_PRESET hidden
    VISIBILITY_INLINES_HIDDEN ON
    # Installed beside libkiji's folder: lib/kiji/plugins -> lib.
    INSTALL_RPATH "$ORIGIN/../..")
  if(CMAKE_SYSTEM_NAME STREQUAL "Linux" AND NOT KIJI_SANITIZE STREQUAL "thread")
    # A symbol missing from the plugin is a link error here rather than a refusal at load time.
    # (Not under ThreadSanitizer: its static runtime lives in the executable, not in the plugin.)
    target_link_options(${target} PRIVATE "LINKER:--no-undefined")
  endif()

  # Same stem as the library: kiji_<id>.so -> kiji_<id>.json.
  set(metadata ${out_dir}/${target}.json)
  add_custom_command(TARGET ${target} POST_BUILD
    COMMAND $<TARGET_FILE:Kiji::plugin_meta> --id ${id} $<TARGET_FILE:${target}> ${metadata}
    BYPRODUCTS ${metadata}
    COMMENT "Writing the metadata of tool '${id}'"
    VERBATIM)
  get_target_property(meta_imported Kiji::plugin_meta IMPORTED)
  if(NOT meta_imported)
    get_target_property(meta_target Kiji::plugin_meta ALIASED_TARGET)
    add_dependencies(${target} ${meta_target})
  endif()
  set_property(TARGET ${target} PROPERTY KIJI_TOOL_METADATA ${metadata})

  if(NOT ARG_NO_INSTALL)
    # The tools a build installs, for packages that carry them (the Python package).
    set_property(GLOBAL APPEND PROPERTY KIJI_TOOL_TARGETS ${target})
    install(TARGETS ${target} LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}/kiji/plugins)
    install(FILES ${metadata} DESTINATION ${CMAKE_INSTALL_LIBDIR}/kiji/plugins)
  endif()
endfunction()
