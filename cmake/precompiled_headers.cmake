# Precompiled headers (MACHPLAN_PCH), for a build that compiles everything often. Nearly every
# source of machplan reads Eigen and fmt through its headers, and every test reads GoogleTest
# and GoogleMock; parsing them again for each of the ~250 sources costs 2.5 to 3.5 s of CPU
# each (measured alone: GoogleTest with GoogleMock 3.5 s, Eigen 3.2 s, nlohmann-json 3.4 s,
# fmt with the standard headers 2.5 s). With MACHPLAN_PCH each library and program parses them
# once, and all the tests share one precompiled header (tests/CMakeLists.txt).
#
# Off by default (scripts/test and the demo build leave it off): a source that forgets an
# #include the precompiled header happens to provide fails in a build without it, so keep one.
# scripts/test's MACHPLAN_TESTS_O0 gives the tests alone their shared one (tests/CMakeLists.txt).
# Measured on single sources of the sanitized build, it saves about a tenth of a compile (from
# -17 % to +14 % on a loaded machine): worth turning on only once measured on a whole build.
set(MACHPLAN_PCH_HEADERS
  <algorithm> <cmath> <functional> <map> <memory> <optional> <string> <vector>
  <Eigen/Core> <Eigen/Geometry> <fmt/format.h>)
set(MACHPLAN_TEST_PCH_HEADERS ${MACHPLAN_PCH_HEADERS} <gtest/gtest.h> <gmock/gmock.h> <nlohmann/json.hpp>)

# The libraries and the program: each its own precompiled header (their flags differ).
function(machplan_precompile_headers)
  if(MACHPLAN_PCH)
    foreach(target ${ARGN})
      target_precompile_headers(${target} PRIVATE ${MACHPLAN_PCH_HEADERS})
    endforeach()
  endif()
endfunction()
