# ctest core_layers_reject_wrong_way_include: the layer check (cmake/CheckLayers.cmake) passes on a
# copy of core/ and fails, naming the file, the line and the edge, once a wrong-way include or a
# file of no module is planted in the copy (never in the tree).
#   cmake -DSOURCE_DIR=<repo> -DMANIFEST=<build>/core/scancam_layers.cmake -DWORK_DIR=<tmp> -P ...
cmake_minimum_required(VERSION 3.18)
set(copy ${WORK_DIR}/core)
set(check ${SOURCE_DIR}/cmake/CheckLayers.cmake)

function(fresh_copy)
  file(REMOVE_RECURSE ${WORK_DIR})
  file(MAKE_DIRECTORY ${WORK_DIR})
  file(COPY ${SOURCE_DIR}/core/include ${SOURCE_DIR}/core/src DESTINATION ${copy})
endfunction()

function(run_check out_rc out_text)
  execute_process(COMMAND ${CMAKE_COMMAND} -DROOT=${copy} -DMANIFEST=${MANIFEST} -P ${check}
                  RESULT_VARIABLE rc OUTPUT_VARIABLE o ERROR_VARIABLE e)
  set(${out_rc} ${rc} PARENT_SCOPE)
  set(${out_text} "${o}${e}" PARENT_SCOPE)
endfunction()

# Inserts `line` after the first line of `file` (so it is line 2).
function(plant file line)
  file(READ ${file} text)
  string(FIND "${text}" "\n" nl)
  math(EXPR after "${nl} + 1")
  string(SUBSTRING "${text}" 0 ${after} head)
  string(SUBSTRING "${text}" ${after} -1 tail)
  file(WRITE ${file} "${head}${line}\n${tail}")
endfunction()

function(expect_failure what expected)
  run_check(rc text)
  if(rc EQUAL 0)
    message(FATAL_ERROR "${what}: the layer check passed, it should have failed:\n${text}")
  endif()
  string(FIND "${text}" "${expected}" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "${what}: the message does not hold '${expected}':\n${text}")
  endif()
  message(STATUS "${what}: rejected as expected")
endfunction()

# 1. The tree as it is passes.
fresh_copy()
run_check(rc text)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the layer check fails on an unmodified copy of core/:\n${text}")
endif()

# 2. io (below solve) includes a solve header: the file, line 2, the edge.
plant(${copy}/src/io/pcd.cpp "#include \"scancam/solve/calibrate.h\"")
expect_failure("io -> solve in a source"
  "${copy}/src/io/pcd.cpp:2: wrong-way include: module 'io' includes \"scancam/solve/calibrate.h\" of module 'solve' (edge io -> solve)")

# 3. A public header of camera includes colour through a relative path.
fresh_copy()
plant(${copy}/include/scancam/camera/valid_region.h "#include \"../colour/overlay.h\"")
expect_failure("camera -> colour in a header, relative path"
  "${copy}/include/scancam/camera/valid_region.h:2: wrong-way include: module 'camera' includes \"../colour/overlay.h\" of module 'colour' (edge camera -> colour)")

# 4. The lowest module includes the highest.
fresh_copy()
plant(${copy}/src/error.cpp "#include \"scancam/sim/simulate.h\"")
expect_failure("base -> sim" "src/error.cpp:2: wrong-way include: module 'base' includes \"scancam/sim/simulate.h\" of module 'sim' (edge base -> sim)")

# 5. A source no module lists.
fresh_copy()
file(WRITE ${copy}/src/io/stray.cpp "#include \"scancam/io/pcd.h\"\n")
expect_failure("unlisted source" "${copy}/src/io/stray.cpp:1: belongs to no core module")

file(REMOVE_RECURSE ${WORK_DIR})
