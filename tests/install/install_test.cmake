# The installed machplan, tested from outside the source and build trees. Run by ctest as
#   cmake -DSTEP=install|downstream|run|cleanup -DBUILD_DIR=... -DPREFIX=... [...] -P install_test.cmake
#
#   install     cmake --install BUILD_DIR --prefix PREFIX, then checks the layout
#   downstream  configures and builds tests/install/downstream (find_package(machplan)) against
#               PREFIX and runs it
#   run         runs PREFIX/bin/machplan from / : `machines` lists the installed machines,
#               `run PART --machine thermal_gantry` works, and a folder holding
#               datasets/machines/thermal_gantry.yaml is not searched when it is the current one
#   cleanup     removes PREFIX
#
# PREFIX lies outside the build tree, so the installed binary cannot fall back on the source
# tree's machines.
cmake_minimum_required(VERSION 3.25)

function(run_checked what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err ${EXTRA_ARGS})
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${what} failed (${rc}):\n${ARGN}\n--- stdout\n${out}\n--- stderr\n${err}")
  endif()
  set(last_out "${out}" PARENT_SCOPE)
  set(last_err "${err}" PARENT_SCOPE)
endfunction()

function(expect_in text needle what)
  string(FIND "${text}" "${needle}" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "${what}: expected to find '${needle}' in:\n${text}")
  endif()
endfunction()

if(STEP STREQUAL "install")
  file(REMOVE_RECURSE "${PREFIX}")
  run_checked("cmake --install" ${CMAKE_COMMAND} --install "${BUILD_DIR}" --prefix "${PREFIX}")
  foreach(f bin/machplan include/machplan/engine/common/error.h include/machplan/solvers/placement/search.h
            include/machplan/models/cutting/machine_config.h lib/libmachplan_engine.a lib/libmachplan_models.a
            lib/libmachplan_solvers.a lib/cmake/machplan/machplanConfig.cmake
            lib/cmake/machplan/machplanConfigVersion.cmake lib/cmake/machplan/machplanTargets.cmake
            share/machplan/machines/thermal_gantry.yaml share/machplan/machines/xy_table.yaml
            share/machplan/datasets/parts/triangle_45.ngc share/machplan/datasets/hexam-paper/scene.yaml)
    if(NOT EXISTS "${PREFIX}/${f}")
      message(FATAL_ERROR "cmake --install did not install ${f} under ${PREFIX}")
    endif()
  endforeach()
  file(GLOB_RECURSE cpp RELATIVE "${PREFIX}" "${PREFIX}/include/*.cpp")
  if(cpp)
    message(FATAL_ERROR "sources installed as headers: ${cpp}")
  endif()
elseif(STEP STREQUAL "downstream")
  set(build "${PREFIX}-downstream")
  file(REMOVE_RECURSE "${build}")
  run_checked("configuring the downstream project" ${CMAKE_COMMAND} -S "${SOURCE_DIR}/tests/install/downstream"
              -B "${build}" -G "${GENERATOR}" -DCMAKE_PREFIX_PATH=${PREFIX} -DCMAKE_CXX_COMPILER=${CXX}
              -DCMAKE_CXX_COMPILER_LAUNCHER=${LAUNCHER} -DCMAKE_BUILD_TYPE=${BUILD_TYPE})
  run_checked("building the downstream project" ${CMAKE_COMMAND} --build "${build}")
  run_checked("running the downstream program" "${build}/downstream")
  message("${last_out}")
  expect_in("${last_out}" "machine: thermal_gantry from ${PREFIX}/share/machplan/machines/" "downstream")
elseif(STEP STREQUAL "run")
  set(xdg "${PREFIX}-xdg")
  set(EXTRA_ARGS WORKING_DIRECTORY /)
  file(REMOVE_RECURSE "${xdg}")
  set(env ${CMAKE_COMMAND} -E env XDG_CONFIG_HOME=${xdg} LSAN_OPTIONS=suppressions=${SOURCE_DIR}/tests/lsan.supp)
  run_checked("machplan machines" ${env} "${PREFIX}/bin/machplan" machines)
  message("${last_out}")
  expect_in("${last_out}" "installed ${PREFIX}/share/machplan/machines" "machplan machines")
  expect_in("${last_out}" "${PREFIX}/share/machplan/machines/thermal_gantry.yaml" "machplan machines")
  expect_in("${last_out}" "user      ${xdg}/machplan/machines" "machplan machines")
  if(NOT IS_DIRECTORY "${xdg}/machplan/machines")
    message(FATAL_ERROR "the user's machine folder ${xdg}/machplan/machines was not created on first use")
  endif()
  string(FIND "${last_out}" "${SOURCE_DIR}" at)
  if(NOT at EQUAL -1)
    message(FATAL_ERROR "the installed binary searches the source tree:\n${last_out}")
  endif()
  set(part "${PREFIX}/share/machplan/datasets/parts/triangle_45.ngc")
  run_checked("machplan run from /" ${env} "${PREFIX}/bin/machplan" run "${part}" --machine thermal_gantry)
  message("${last_out}")
  # A stray datasets/machines in the current folder must not replace the installed machine.
  set(stray "${PREFIX}-stray")
  file(WRITE "${stray}/datasets/machines/thermal_gantry.yaml" "this: is not the gantry\n")
  set(EXTRA_ARGS WORKING_DIRECTORY "${stray}")
  run_checked("machplan run beside a stray machine folder" ${env} "${PREFIX}/bin/machplan" run "${part}"
              --machine thermal_gantry)
  file(REMOVE_RECURSE "${stray}" "${xdg}")
elseif(STEP STREQUAL "cleanup")
  file(REMOVE_RECURSE "${PREFIX}" "${PREFIX}-downstream")
else()
  message(FATAL_ERROR "STEP must be install, downstream, run or cleanup (got '${STEP}')")
endif()
