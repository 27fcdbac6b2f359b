# Run by CTest (tests/install/CMakeLists.txt): checks that docs/library.md shows the example's code,
# installs the build into WORK_DIR/prefix, builds the example apps/examples/minimal against it as a
# project of its own, renders 4 s of a scene and runs the example on it. Fails on the first step
# that fails, naming it.
foreach(var FSP_BUILD_DIR FSP_SOURCE_DIR FSP_BINARY WORK_DIR)
  if(NOT ${var})
    message(FATAL_ERROR "test_install.cmake: -D${var}=... is required")
  endif()
endforeach()

function(step name)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${name} failed (${rc}):\n${out}\n${err}")
  endif()
  set(step_output "${out}" PARENT_SCOPE)
endfunction()

# docs/library.md shows the example's code: it must be this file, word for word.
file(READ ${FSP_SOURCE_DIR}/apps/examples/minimal/main.cc example_code)
file(READ ${FSP_SOURCE_DIR}/docs/library.md doc)
string(FIND "${doc}" "```cpp\n${example_code}```" at)
if(at EQUAL -1)
  message(FATAL_ERROR "docs/library.md does not show "
                      "apps/examples/minimal/main.cc as it is")
endif()

set(prefix ${WORK_DIR}/prefix)
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})

step("cmake --install" ${CMAKE_COMMAND} --install ${FSP_BUILD_DIR} --prefix ${prefix})
foreach(f include/fsp/pipeline/system.h include/fsp/frontend/frontend.h
          include/fsp/backend/estimator.h include/fsp/common/types.h
          lib/libfsp_common.a lib/libfsp_frontend.a lib/libfsp_backend.a lib/libfsp_pipeline.a
          lib/cmake/fsp/fspConfig.cmake lib/cmake/fsp/fspConfigVersion.cmake
          lib/cmake/fsp/fspTargets.cmake)
  if(NOT EXISTS ${prefix}/${f})
    message(FATAL_ERROR "cmake --install did not write ${prefix}/${f}")
  endif()
endforeach()

# A separate project that sees only the installed package (no package registry, no build tree).
set(configure_args -S ${FSP_SOURCE_DIR}/apps/examples/minimal -B ${WORK_DIR}/build
    -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF)
if(CXX_COMPILER)
  list(APPEND configure_args -DCMAKE_CXX_COMPILER=${CXX_COMPILER})
endif()
if(CXX_COMPILER_LAUNCHER)
  list(APPEND configure_args -DCMAKE_CXX_COMPILER_LAUNCHER=${CXX_COMPILER_LAUNCHER})
endif()
if(BUILD_TYPE)
  list(APPEND configure_args -DCMAKE_BUILD_TYPE=${BUILD_TYPE})
endif()
if(CXX_FLAGS)
  list(APPEND configure_args "-DCMAKE_CXX_FLAGS=${CXX_FLAGS}")
endif()
if(EXE_LINKER_FLAGS)
  list(APPEND configure_args "-DCMAKE_EXE_LINKER_FLAGS=${EXE_LINKER_FLAGS}")
endif()
step("configuring the example" ${CMAKE_COMMAND} ${configure_args})
step("building the example" ${CMAKE_COMMAND} --build ${WORK_DIR}/build)

# 4 s of the tracker's clip (1.6 s still for the initialisation, then the poster, window and tag
# approach), images only.
step("fsp render" ${FSP_BINARY} render ${FSP_SOURCE_DIR}/assets/scenes/clip_zoom_roll.yaml
     --out ${WORK_DIR}/seq --duration 4 --no-video)
step("running the example" ${WORK_DIR}/build/minimal ${WORK_DIR}/seq)
message("${step_output}")
if(NOT step_output MATCHES "([0-9]+) poses, ([0-9]+) objects")
  message(FATAL_ERROR "the example printed no \"N poses, M objects\" line")
endif()
if(NOT CMAKE_MATCH_1 EQUAL 80 OR CMAKE_MATCH_2 LESS 1)
  message(FATAL_ERROR "expected 80 poses and at least one object, got ${CMAKE_MATCH_1} poses and "
                      "${CMAKE_MATCH_2} objects")
endif()
# Tag 30 of the scene is 0.3 x 0.3 m.
if(NOT step_output MATCHES "object 30 tag: ([0-9.]+) x ([0-9.]+) m")
  message(FATAL_ERROR "the example printed no line for tag 30")
endif()
foreach(size ${CMAKE_MATCH_1} ${CMAKE_MATCH_2})
  if(size LESS 0.27 OR size GREATER 0.33)
    message(FATAL_ERROR "tag 30 measures ${CMAKE_MATCH_1} x ${CMAKE_MATCH_2} m, not 0.3 x 0.3 m")
  endif()
endforeach()
