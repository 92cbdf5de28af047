# The out-of-tree tool test (cmake -P): installs Kiji into a prefix inside the build folder, builds
# the tool of this folder against that prefix only, installs it there, and runs its check. The tool's
# source, nudge.cpp, is the example of the README's "Writing a tool", taken from the README as it
# stands, so that the example a newcomer copies is known to build and work.
#   -DKIJI_BUILD_DIR -DSOURCE_DIR -DWORK_DIR -DREADME -DGENERATOR -DCXX_COMPILER -DBUILD_TYPE -DLIBDIR
#   -DEXTRA_CXX_FLAGS -DEXTRA_LINK_FLAGS (a sanitizer build's flags, else empty)
set(prefix ${WORK_DIR}/prefix)
set(build ${WORK_DIR}/build)
set(source ${WORK_DIR}/source)
file(REMOVE_RECURSE ${WORK_DIR})

# The first ```cpp block after the README's heading "## Writing a tool".
file(READ ${README} readme)
string(FIND "${readme}" "\n## Writing a tool\n" at)
if(at EQUAL -1)
  message(FATAL_ERROR "external tool: ${README} has no section '## Writing a tool'")
endif()
string(SUBSTRING "${readme}" ${at} -1 readme)
string(FIND "${readme}" "\n```cpp\n" open)
if(open EQUAL -1)
  message(FATAL_ERROR "external tool: the README's 'Writing a tool' has no ```cpp block")
endif()
math(EXPR open "${open} + 8")
string(SUBSTRING "${readme}" ${open} -1 readme)
string(FIND "${readme}" "\n```" close)
string(SUBSTRING "${readme}" 0 ${close} example)
file(COPY ${SOURCE_DIR}/ DESTINATION ${source})
file(WRITE ${source}/nudge.cpp "${example}\n")

function(step what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "external tool: ${what} failed (${rc}):\n${out}")
  endif()
  message(STATUS "external tool: ${what}: done")
  set(step_output "${out}" PARENT_SCOPE)
endfunction()

step("install Kiji into ${prefix}" ${CMAKE_COMMAND} --install ${KIJI_BUILD_DIR} --prefix ${prefix})
# The same compiler as Kiji's: the ABI tag names it, and a plugin from another would be refused.
step("configure" ${CMAKE_COMMAND} -S ${source} -B ${build} -G ${GENERATOR}
     -DCMAKE_BUILD_TYPE=${BUILD_TYPE} -DCMAKE_CXX_COMPILER=${CXX_COMPILER}
     -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_INSTALL_PREFIX=${prefix} -DCMAKE_INSTALL_LIBDIR=${LIBDIR}
     "-DCMAKE_CXX_FLAGS=${EXTRA_CXX_FLAGS}" "-DCMAKE_EXE_LINKER_FLAGS=${EXTRA_LINK_FLAGS}"
     "-DCMAKE_MODULE_LINKER_FLAGS=${EXTRA_LINK_FLAGS}" "-DCMAKE_SHARED_LINKER_FLAGS=${EXTRA_LINK_FLAGS}")
step("build" ${CMAKE_COMMAND} --build ${build} -j 2)
step("install the tool" ${CMAKE_COMMAND} --install ${build})
step("check" ${CMAKE_COMMAND} -E env --unset=KIJI_PLUGIN_PATH
     ${build}/check_nudge ${build} ${prefix}/${LIBDIR}/kiji/plugins)
message("${step_output}")
