// The simulator's sheet height map (models/sim/sheet_map.h): the grid read from its CSV, the
// surface between and beyond its points, and bad files named with their line.
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "models/sim/sheet_map.h"

namespace machplan::sim {
namespace {

using ::testing::HasSubstr;

std::string map_error(const std::string& text) {
  try {
    parse_sheet_map(text, "sheet.csv");
  } catch (const InputError& e) {
    return e.what();
  }
  return "<accepted>";
}

TEST(SheetMap, BilinearBetweenItsPointsAndTheEdgeBeyond) {
  // Rows in any order, comments and blank lines allowed.
  const SheetMap m = parse_sheet_map(
      "# a sheet measured on a 3 x 2 grid\nx_mm,y_mm,z_mm\n0,0,0\n100,0,1\n200,0,-1\n\n0,50,2\n200,50,3 # corner\n100,50,0.5\n",
      "sheet.csv");
  ASSERT_EQ(m.xs().size(), 3u);
  ASSERT_EQ(m.ys().size(), 2u);
  EXPECT_DOUBLE_EQ(m.z_mm(100, 0), 1.0);
  EXPECT_DOUBLE_EQ(m.z_mm(50, 0), 0.5);
  EXPECT_DOUBLE_EQ(m.z_mm(0, 25), 1.0);
  EXPECT_DOUBLE_EQ(m.z_mm(150, 25), 0.25 * (1.0 - 1.0 + 0.5 + 3.0));  // the mean of its cell's corners
  EXPECT_DOUBLE_EQ(m.z_mm(-500, -500), 0.0);  // beyond the grid: the nearest edge's
  EXPECT_DOUBLE_EQ(m.z_mm(900, 25), 1.0);
}

TEST(SheetMap, BadFilesNameTheFileAndLine) {
  EXPECT_EQ(map_error(""), "sheet.csv: no header 'x_mm,y_mm,z_mm': the file is empty");
  EXPECT_EQ(map_error("x,y,z\n"), "sheet.csv:1: the first line must be the header 'x_mm,y_mm,z_mm', found 'x,y,z'");
  EXPECT_EQ(map_error("x_mm,y_mm,z_mm\n0,0\n"), "sheet.csv:2: expected three numbers x_mm,y_mm,z_mm, found '0,0'");
  EXPECT_EQ(map_error("x_mm,y_mm,z_mm\n0,0,0,0\n"), "sheet.csv:2: expected three numbers x_mm,y_mm,z_mm, found '0,0,0,0'");
  EXPECT_EQ(map_error("x_mm,y_mm,z_mm\n0,a,0\n"), "sheet.csv:2: 'a' is not a number");
  EXPECT_EQ(map_error("x_mm,y_mm,z_mm\n0,0,nan\n"), "sheet.csv:2: 'nan' is not a number");
  EXPECT_EQ(map_error("x_mm,y_mm,z_mm\n0,0,60\n"), "sheet.csv:2: z 60 mm must be within +-50 mm of the nominal surface");
  EXPECT_EQ(map_error("x_mm,y_mm,z_mm\n0,0,0\n0,0,1\n"), "sheet.csv:3: (0, 0) given twice (first on line 2)");
  EXPECT_EQ(map_error("x_mm,y_mm,z_mm\n0,0,0\n1,0,0\n"), "sheet.csv:3: the grid has 2 x and 1 y values: at least 2 of each");
  EXPECT_EQ(map_error("x_mm,y_mm,z_mm\n0,0,0\n1,0,0\n0,1,0\n"),
            "sheet.csv:4: the grid of 2 x by 2 y values has no point at (1, 1)");
  EXPECT_EQ(map_error("x_mm,y_mm,z_mm\n2e6,0,0\n"), "sheet.csv:2: (2e+06, 0) lies beyond 1e6 mm");
}

}  // namespace
}  // namespace machplan::sim
