# The out-of-tree tool test (cmake -P): installs Kiji into a prefix inside the build folder, builds
# the tool in this folder against that prefix only, installs it there, and runs its check.
#   -DKIJI_BUILD_DIR -DSOURCE_DIR -DWORK_DIR -DGENERATOR -DCXX_COMPILER -DBUILD_TYPE -DLIBDIR
#   -DEXTRA_CXX_FLAGS -DEXTRA_LINK_FLAGS (a sanitizer build's flags, else empty)
set(prefix ${WORK_DIR}/prefix)
set(build ${WORK_DIR}/build)
file(REMOVE_RECURSE ${WORK_DIR})

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
step("configure" ${CMAKE_COMMAND} -S ${SOURCE_DIR} -B ${build} -G ${GENERATOR}
     -DCMAKE_BUILD_TYPE=${BUILD_TYPE} -DCMAKE_CXX_COMPILER=${CXX_COMPILER}
     -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_INSTALL_PREFIX=${prefix} -DCMAKE_INSTALL_LIBDIR=${LIBDIR}
     "-DCMAKE_CXX_FLAGS=${EXTRA_CXX_FLAGS}" "-DCMAKE_EXE_LINKER_FLAGS=${EXTRA_LINK_FLAGS}"
     "-DCMAKE_MODULE_LINKER_FLAGS=${EXTRA_LINK_FLAGS}" "-DCMAKE_SHARED_LINKER_FLAGS=${EXTRA_LINK_FLAGS}")
step("build" ${CMAKE_COMMAND} --build ${build} -j 2)
step("install the tool" ${CMAKE_COMMAND} --install ${build})
step("check" ${CMAKE_COMMAND} -E env --unset=KIJI_PLUGIN_PATH
     ${build}/check_nudge ${build} ${prefix}/${LIBDIR}/kiji/plugins)
message("${step_output}")
