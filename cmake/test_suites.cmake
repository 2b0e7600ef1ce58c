# machplan_add_test_suites(TARGET [LAUNCHER cmd...] [WORKING_DIRECTORY dir] [PROPERTIES prop value...])
#
# One ctest test for each GoogleTest suite of a test program, named after the suite and run as
# `PROGRAM --gtest_filter=SUITE.*`. ctest lists the suites when it starts (it runs the program
# with --gtest_list_tests), so a new suite needs no reconfigure.
#
# Why a test a suite and not a test a TEST (gtest_discover_tests): in the sanitized build each
# process costs about 0.17 s of CPU before and after its test (AddressSanitizer's start and its
# leak check at exit), and the suites of one file share what they load once (a placement scene,
# a parsed program). For the 1000-odd tests that was more than two minutes of a CI run on two
# cores. A single test still runs with `PROGRAM --gtest_filter=SUITE.NAME`; `ctest -R SUITE`
# selects suites.
#
# LAUNCHER is put before the program (the computing tests run under `nice`: tests/CMakeLists.txt).
# PROPERTIES are set on every suite's test.
function(machplan_add_test_suites target)
  cmake_parse_arguments(PARSE_ARGV 1 arg "" "WORKING_DIRECTORY" "LAUNCHER;PROPERTIES")
  set(command "")
  foreach(word IN LISTS arg_LAUNCHER)
    string(APPEND command " [==[${word}]==]")
  endforeach()
  string(APPEND command " [==[$<TARGET_FILE:${target}>]==]")
  set(properties "")
  foreach(word IN LISTS arg_PROPERTIES)
    string(APPEND properties " [==[${word}]==]")
  endforeach()
  if(arg_WORKING_DIRECTORY)
    string(APPEND properties " WORKING_DIRECTORY [==[${arg_WORKING_DIRECTORY}]==]")
  endif()
  set(script "${CMAKE_CURRENT_BINARY_DIR}/${target}_suites.cmake")
  # Read by ctest (script mode) each time it starts. A program that cannot list its tests
  # becomes one failing test that says so, rather than a run that silently lacks its suites.
  file(GENERATE OUTPUT "${script}" CONTENT "\
# A test that fails with MESSAGE as its output (echo succeeds, so WILL_FAIL fails it).
function(machplan_failing_test name message)
  add_test(\"\${name}\" [==[${CMAKE_COMMAND}]==] -E echo \"\${message}\")
  set_tests_properties(\"\${name}\" PROPERTIES WILL_FAIL TRUE)
endfunction()
execute_process(COMMAND ${command} --gtest_list_tests
                OUTPUT_VARIABLE listing ERROR_VARIABLE errors RESULT_VARIABLE status TIMEOUT 60)
if(NOT status EQUAL 0)
  machplan_failing_test([==[${target}_lists_its_tests]==] \"${target} --gtest_list_tests failed: \${status} \${errors}\")
  return()
endif()
# A suite is a line that starts in the first column and ends its name with a dot (typed suites
# add a comment after it). Parameter values printed on the test lines may hold ; and brackets,
# which would split or join CMake list items: they go before the split.
string(REGEX REPLACE \"[][;]\" \"\" listing \"\${listing}\")
string(REPLACE \"\\n\" \";\" lines \"\${listing}\")
foreach(line IN LISTS lines)
  if(line MATCHES \"^([A-Za-z_][A-Za-z0-9_/]*)\\\\.( .*)?$\")
    set(suite \"\${CMAKE_MATCH_1}\")
    # ctest keeps one test a name: a suite of the same name in another program would hide one
    list(FIND machplan_listed_suites \"\${suite}\" seen)  # (ctest's scripts lack IN_LIST)
    if(NOT seen EQUAL -1)
      machplan_failing_test(\"\${suite}_is_in_two_programs\"
                            \"suite \${suite} of ${target} has the name of another program's suite: rename one\")
      continue()
    endif()
    list(APPEND machplan_listed_suites \"\${suite}\")
    add_test(\"\${suite}\"${command} \"--gtest_filter=\${suite}.*\")
    set_tests_properties(\"\${suite}\" PROPERTIES${properties})
  endif()
endforeach()
")
  set_property(DIRECTORY APPEND PROPERTY TEST_INCLUDE_FILES "${script}")
endfunction()
