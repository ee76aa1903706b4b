# ctest find_package_scancam: installs the core (component "core") into a prefix inside the build
# directory, configures and builds tests/find_package/ against it in a directory of its own (no
# path into the source tree but its own sources), and runs the program.
#   cmake -DBUILD_DIR=<build> -DSOURCE_DIR=<tests/find_package> -DWORK_DIR=<tmp> -DGENERATOR=...
#         -DCXX_COMPILER=... [-DCCACHE=<ccache>] -P run.cmake
cmake_minimum_required(VERSION 3.18)
set(prefix ${WORK_DIR}/prefix)
set(build ${WORK_DIR}/build)
file(REMOVE_RECURSE ${prefix})
file(MAKE_DIRECTORY ${build})

function(run what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${what} failed (${rc}):\n${out}\n${err}")
  endif()
  set(run_output "${out}" PARENT_SCOPE)
endfunction()

run("install" ${CMAKE_COMMAND} --install ${BUILD_DIR} --component core --prefix ${prefix})
if(NOT EXISTS ${prefix}/lib/cmake/ScanCam/ScanCamConfig.cmake OR
   NOT EXISTS ${prefix}/lib/cmake/ScanCam/ScanCamConfigVersion.cmake OR
   NOT EXISTS ${prefix}/include/scancam/camera/camera_model.h)
  message(FATAL_ERROR "the install is missing the package config or the headers")
endif()
set(launcher "")
if(CCACHE)
  set(launcher -DCMAKE_CXX_COMPILER_LAUNCHER=${CCACHE})
endif()
run("configure" ${CMAKE_COMMAND} -S ${SOURCE_DIR} -B ${build} -G ${GENERATOR}
    -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_COMPILER=${CXX_COMPILER} ${launcher}
    -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_FIND_PACKAGE_NO_PACKAGE_REGISTRY=ON)
run("build" ${CMAKE_COMMAND} --build ${build} -j1)
run("the program" ${build}/consumer ${WORK_DIR})
message(STATUS "${run_output}")
if(NOT run_output MATCHES "projected \\(0.2, -0.1, 2\\) to \\(370.000000, 220.000000\\)")
  message(FATAL_ERROR "unexpected output:\n${run_output}")
endif()
