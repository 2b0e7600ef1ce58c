# Precompiled headers (MACHPLAN_PCH), for the builds that compile everything often: scripts/test
# turns them on. Nearly every source of machplan reads Eigen and fmt through its headers, and
# every test reads GoogleTest and GoogleMock; parsing them again for each of the ~250 sources
# is a large part of a build. With MACHPLAN_PCH each library and program parses them once, and
# all the tests share one precompiled header (tests/CMakeLists.txt).
#
# Off by default, and off in the demo build (g++, Release): a source that forgets an #include
# the precompiled header happens to provide still fails there, so the sources stay complete.
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
