// The constants that angle and distance code needs everywhere: pi, one degree in radians, and
// infinity as "no bound yet". One definition for the whole tree (the unity build, which compiles
// several .cpp files as one, also needs them defined once).
#pragma once

#include <limits>
#include <numbers>

namespace machplan {

inline constexpr double kPi = std::numbers::pi;
inline constexpr double kDeg = std::numbers::pi / 180.0;  // one degree, in radians
inline constexpr double kInf = std::numeric_limits<double>::infinity();

}  // namespace machplan
