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
#               datasets/machines/thermal_gantry.yaml is not searched when it is the current one;
#               `serve --port 0` from / serves the installed page (a marker written into the
#               installed index.html comes back, so it is not the source tree's page) and answers
#               its API with the printed token (401 without it), then stops on SIGTERM
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

# The installed `machplan serve`, started from / in the background (its output to a file), asked
# for its page and its API with CMake's own HTTP client, then stopped. `env` (coreutils) execs
# machplan, so the pid the shell reports is the server's. Uses `xdg` of the caller.
function(serve_installed_page)
  set(index "${PREFIX}/share/machplan/panel/index.html")
  string(RANDOM LENGTH 16 marker)
  set(marker "<!-- installed page ${marker} -->")
  file(APPEND "${index}" "${marker}\n")
  set(out "${PREFIX}-serve.out")
  set(pidfile "${PREFIX}-serve.pid")
  file(REMOVE "${out}" "${pidfile}")
  execute_process(COMMAND sh -c "exec \"$@\" >'${out}' 2>&1 </dev/null & echo $! >'${pidfile}'" serve
                          env XDG_CONFIG_HOME=${xdg} XDG_DATA_HOME=${xdg}/data
                          LSAN_OPTIONS=suppressions=${SOURCE_DIR}/tests/lsan.supp "${PREFIX}/bin/machplan" serve --port 0
                  WORKING_DIRECTORY / RESULT_VARIABLE rc)
  file(READ "${pidfile}" pid)
  string(STRIP "${pid}" pid)
  if(NOT rc EQUAL 0 OR NOT pid MATCHES "^[0-9]+$")
    message(FATAL_ERROR "machplan serve did not start (${rc})")
  endif()
  # The URL with its token, once the server listens (30 s: the sanitized build starts slowly).
  set(url "")
  foreach(i RANGE 300)
    if(EXISTS "${out}")
      file(READ "${out}" text)
      if(text MATCHES "open the panel at (http://[^/ \n]+)/\\?token=([0-9a-f]+)")
        set(url "${CMAKE_MATCH_1}")
        set(token "${CMAKE_MATCH_2}")
        break()
      endif()
    endif()
    if(NOT EXISTS "/proc/${pid}")
      break()
    endif()
    execute_process(COMMAND ${CMAKE_COMMAND} -E sleep 0.1)
  endforeach()
  if(url STREQUAL "")
    execute_process(COMMAND kill -KILL ${pid})
    file(READ "${out}" text)
    message(FATAL_ERROR "the installed machplan serve printed no URL:\n${text}")
  endif()
  message("installed machplan serve at ${url}")
  set(failed "")
  file(DOWNLOAD "${url}/" "${PREFIX}-page.html" STATUS st TIMEOUT 30)
  list(GET st 0 code)
  file(READ "${PREFIX}-page.html" page)
  if(NOT code EQUAL 0)
    string(APPEND failed "\nGET / failed: ${st}")
  else()
    string(FIND "${page}" "${marker}" at)
    if(at EQUAL -1)
      string(APPEND failed "\nGET / did not serve the installed ${index}")
    endif()
  endif()
  file(DOWNLOAD "${url}/api/status" "${PREFIX}-status.json" STATUS st TIMEOUT 30
       HTTPHEADER "Authorization: Bearer ${token}")
  list(GET st 0 code)
  file(READ "${PREFIX}-status.json" status)
  if(NOT code EQUAL 0 OR NOT status MATCHES "^{")
    string(APPEND failed "\nGET /api/status with the token failed: ${st}: ${status}")
  endif()
  file(DOWNLOAD "${url}/api/status" "${PREFIX}-status.json" STATUS st TIMEOUT 30 LOG log)
  if(NOT log MATCHES "HTTP/[0-9.]+ 401")
    string(APPEND failed "\nGET /api/status without the token was not refused with 401: ${st}\n${log}")
  endif()
  file(REMOVE "${PREFIX}-page.html" "${PREFIX}-status.json")
  # SIGTERM: a controlled stop and a clean exit (the sanitizers report at exit into ${out}).
  execute_process(COMMAND kill -TERM ${pid})
  set(stopped FALSE)
  foreach(i RANGE 300)
    if(NOT EXISTS "/proc/${pid}/stat")
      set(stopped TRUE)
      break()
    endif()
    file(READ "/proc/${pid}/stat" stat)
    if(stat MATCHES "^[0-9]+ \\([^)]*\\) Z")  # exited; its parent (init) has not reaped it yet
      set(stopped TRUE)
      break()
    endif()
    execute_process(COMMAND ${CMAKE_COMMAND} -E sleep 0.1)
  endforeach()
  file(READ "${out}" text)
  if(NOT stopped)
    execute_process(COMMAND kill -KILL ${pid})
    string(APPEND failed "\nmachplan serve did not stop within 30 s of SIGTERM")
  endif()
  if(text MATCHES "Sanitizer")
    string(APPEND failed "\nthe sanitizers reported")
  endif()
  file(REMOVE "${out}" "${pidfile}")
  if(failed)
    message(FATAL_ERROR "the installed machplan serve:${failed}\n--- its output\n${text}")
  endif()
  message("the installed machplan serve served ${index} and its API, and stopped")
endfunction()

if(STEP STREQUAL "install")
  file(REMOVE_RECURSE "${PREFIX}")
  run_checked("cmake --install" ${CMAKE_COMMAND} --install "${BUILD_DIR}" --prefix "${PREFIX}")
  foreach(f bin/machplan include/machplan/engine/common/error.h include/machplan/solvers/placement/search/search.h
            include/machplan/models/cutting/machine_config.h lib/libmachplan_engine.a lib/libmachplan_models.a
            lib/libmachplan_solvers.a lib/cmake/machplan/machplanConfig.cmake
            lib/cmake/machplan/machplanConfigVersion.cmake lib/cmake/machplan/machplanTargets.cmake
            share/machplan/machines/thermal_gantry.yaml share/machplan/machines/xy_table.yaml
            share/machplan/datasets/parts/triangle_45.ngc share/machplan/datasets/hexam-paper/scene.yaml
            share/machplan/panel/index.html share/machplan/panel/panel.js share/machplan/panel/panel.css)
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
  # read; none may come from a private dependency's folder. -fsyntax-only: parsing is the check,
  # and it is most of the cost of a header alone (the unit emits no code worth generating).
  # The C++ standard library's common headers are parsed once, into a precompiled header that
  # every unit starts with: that halves the check's time (about 200 s of CPU for 110 headers
  # before, on this machine). It does not check that a header includes the standard headers it
  # uses; libstdc++'s headers include each other, so nothing could rely on that anyway. Eigen,
  # fmt and machplan's own headers are not in it: each unit still reads them as a consumer does.
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
set_source_files_properties(\${units} PROPERTIES COMPILE_OPTIONS \"-H;-fsyntax-only\")
target_precompile_headers(headers PRIVATE <algorithm> <array> <atomic> <chrono> <cmath> <cstdint>
  <functional> <map> <memory> <mutex> <optional> <set> <string> <string_view> <unordered_map>
  <utility> <variant> <vector>)
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
  file(REMOVE_RECURSE "${stray}")
  serve_installed_page()
  file(REMOVE_RECURSE "${xdg}")
elseif(STEP STREQUAL "cleanup")
  file(REMOVE_RECURSE "${PREFIX}" "${PREFIX}-downstream" "${PREFIX}-headers")
else()
  message(FATAL_ERROR "STEP must be install, headers, downstream, run or cleanup (got '${STEP}')")
endif()
