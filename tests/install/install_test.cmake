# The installed machplan, tested from outside the source and build trees. Run by ctest as
#   cmake -DSTEP=install|headers|downstream|run|cleanup -DBUILD_DIR=... -DPREFIX=... [...] -P install_test.cmake
#
#   install     cmake --install BUILD_DIR --prefix PREFIX, then checks the layout (the API's
#               headers, none of an internal/ folder)
#   headers     no installed file #includes a private dependency (yaml-cpp, nlohmann-json,
#               Cairo, SQLite, FCL, Ceres, NLopt, OMPL), and every installed header compiles on
#               its own with only PREFIX/include, PREFIX/include/machplan and HEADER_INCLUDES
#               (Eigen's and fmt's folders, |-separated) on the include path, reading no file
#               of a private dependency
#   downstream  configures and builds tests/install/downstream (find_package(machplan)) against
#               PREFIX and runs it: it links the private dependencies without seeing them
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
  foreach(f bin/machplan include/machplan/engine/common/error.h include/machplan/solvers/placement/search/search.h
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
  # Only the API: no header of an internal/ folder, nor the HAL component's shared-memory layout.
  file(GLOB_RECURSE inside RELATIVE "${PREFIX}" "${PREFIX}/include/*")
  list(FILTER inside INCLUDE REGEX "/internal/|/engine/hardware/hal/")
  if(inside)
    message(FATAL_ERROR "internal headers installed as API: ${inside}")
  endif()
elseif(STEP STREQUAL "headers")
  set(private_deps "yaml-cpp|nlohmann|cairo|sqlite3|fcl|ceres|nlopt|ompl")
  # 1. The text: no #include naming a private dependency, in any installed file.
  file(GLOB_RECURSE installed "${PREFIX}/include/*")
  set(found "")
  foreach(f ${installed})
    file(STRINGS "${f}" lines REGEX "^[ \t]*#[ \t]*include[ \t]*[<\"](${private_deps})")
    foreach(line ${lines})
      string(APPEND found "\n  ${f}: ${line}")
    endforeach()
  endforeach()
  if(found)
    message(FATAL_ERROR "installed headers include private dependencies (they must stay in .cpp files):${found}")
  endif()
  # 2. The compiler: each header alone in a translation unit, as a consumer includes it,
  # compiled by a generated project with nothing else on the include path. -H lists every file
  # read; none may come from a private dependency's folder.
  file(GLOB_RECURSE headers RELATIVE "${PREFIX}/include" "${PREFIX}/include/machplan/*.h")
  list(LENGTH headers count)
  if(count LESS 10)
    message(FATAL_ERROR "only ${count} headers installed under ${PREFIX}/include/machplan")
  endif()
  set(project "${PREFIX}-headers")
  file(REMOVE_RECURSE "${project}")
  foreach(h ${headers})
    string(REGEX REPLACE "^machplan/(.*)\\.h$" "\\1" name "${h}")
    string(REPLACE "/" "__" name "${name}")
    file(WRITE "${project}/tu/${name}.cpp" "#include <${h}>\n")
  endforeach()
  string(REPLACE "|" ";" extra "${HEADER_INCLUDES}")
  file(WRITE "${project}/CMakeLists.txt" "cmake_minimum_required(VERSION 3.25)
project(machplan_headers LANGUAGES CXX)
set(CMAKE_CXX_STANDARD 20)
file(GLOB units tu/*.cpp)
add_library(headers OBJECT \${units})
target_include_directories(headers PRIVATE \"${PREFIX}/include\" \"${PREFIX}/include/machplan\" ${extra})
target_compile_options(headers PRIVATE -H)
")
  run_checked("configuring the header project" ${CMAKE_COMMAND} -S "${project}" -B "${project}/build" -G "${GENERATOR}"
              -DCMAKE_CXX_COMPILER=${CXX} -DCMAKE_CXX_COMPILER_LAUNCHER=${LAUNCHER})
  set(keep_going -k)  # report every header that fails, not only the first
  if(GENERATOR MATCHES "Ninja")
    set(keep_going -k 0)
  endif()
  execute_process(COMMAND ${CMAKE_COMMAND} --build "${project}/build" -j 2 -- ${keep_going} RESULT_VARIABLE rc
                  OUTPUT_VARIABLE out ERROR_VARIABLE err)
  string(APPEND out "\n${err}")
  if(NOT rc EQUAL 0)
    string(REGEX REPLACE "\n\\.+ [^\n]*" "" out "${out}")  # the -H lines
    message(FATAL_ERROR "installed headers do not compile on their own with only ${PREFIX}/include, "
                        "${PREFIX}/include/machplan and '${HEADER_INCLUDES}' on the include path:\n${out}")
  endif()
  string(REGEX MATCHALL "\n\\.+ [^\n]*/(${private_deps})[^/\n]*(/[^\n]*)?" read "${out}")
  if(read)
    list(REMOVE_DUPLICATES read)
    message(FATAL_ERROR "installed headers read files of private dependencies:${read}")
  endif()
  message("${count} installed headers compile on their own; none includes a private dependency")
elseif(STEP STREQUAL "downstream")
  set(build "${PREFIX}-downstream")
  file(REMOVE_RECURSE "${build}")
  run_checked("configuring the downstream project" ${CMAKE_COMMAND} -S "${SOURCE_DIR}/tests/install/downstream"
              -B "${build}" -G "${GENERATOR}" -DCMAKE_PREFIX_PATH=${PREFIX} -DCMAKE_CXX_COMPILER=${CXX}
              -DCMAKE_CXX_COMPILER_LAUNCHER=${LAUNCHER} -DCMAKE_BUILD_TYPE=${BUILD_TYPE})
  run_checked("building the downstream project" ${CMAKE_COMMAND} --build "${build}")
  set(scratch "${build}/scratch")
  file(MAKE_DIRECTORY "${scratch}")
  run_checked("running the downstream program" "${build}/downstream" "${scratch}")
  message("${last_out}")
  expect_in("${last_out}" "machine: thermal_gantry from ${PREFIX}/share/machplan/machines/" "downstream")
  expect_in("${last_out}" "calibration store: 0 fits" "downstream")
  if(NOT EXISTS "${scratch}/picture.png")
    message(FATAL_ERROR "the downstream program wrote no picture")
  endif()
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
  file(REMOVE_RECURSE "${PREFIX}" "${PREFIX}-downstream" "${PREFIX}-headers")
else()
  message(FATAL_ERROR "STEP must be install, headers, downstream, run or cleanup (got '${STEP}')")
endif()
