// Parts made in code for the nesting tests: a rectangle and a disc, with their areas.
#pragma once

#include <cmath>
#include <string>

#include "solvers/nesting/part.h"

namespace machplan::nesting::test {

inline NestPart rect(double w, double h, const std::string& name = "rect") {
  NestPart p;
  p.file = name;
  p.outer = Contour({{0, 0}, {w, 0}, {w, h}, {0, h}}, {0, 0, 0, 0});
  p.area_mm2 = w * h;
  return p;
}

inline NestPart disc(double r) {
  NestPart p;
  p.file = "disc";
  p.outer = Contour::circle({0, 0}, r);
  p.area_mm2 = M_PI * r * r;
  return p;
}

}  // namespace machplan::nesting::test
