// The pictures' scale: round lengths for scale bars and ticks, and a scale bar drawn to scale
// (solvers/common/picture.h; the placement, run, guard and tuning plots draw theirs with it).
// The bar is read back from the PNG with Cairo, pixel by pixel.
#include "solvers/common/picture.h"

#include <cairo.h>

#include <gtest/gtest.h>

#include "tests/support/temp_dir.h"

namespace machplan {
namespace {

TEST(RoundStep, TheLargestOneTwoOrFiveTimesAPowerOfTenNotAboveTheWish) {
  EXPECT_DOUBLE_EQ(round_step(7.0), 5.0);
  EXPECT_DOUBLE_EQ(round_step(19.9), 10.0);
  EXPECT_DOUBLE_EQ(round_step(20.0), 20.0);
  EXPECT_DOUBLE_EQ(round_step(120.0), 100.0);
  EXPECT_DOUBLE_EQ(round_step(480.0), 200.0);
  EXPECT_DOUBLE_EQ(round_step(0.3), 0.2);
  for (const double want : {0.07, 1.0, 3.3, 64.0, 999.0, 12345.0}) {
    const double s = round_step(want);
    EXPECT_LE(s, want * (1 + 1e-12)) << want;
    EXPECT_GT(s, want / 2.5) << want;  // never less than the next round length down
  }
}

// Dark, opaque pixels of row `y`, and the first and last of them.
struct DarkRun {
  int count = 0, first = -1, last = -1;
};
DarkRun dark_pixels(cairo_surface_t* png, int y) {
  const unsigned char* row = cairo_image_surface_get_data(png) + y * cairo_image_surface_get_stride(png);
  DarkRun r;
  for (int x = 0; x < cairo_image_surface_get_width(png); ++x) {
    const std::uint32_t argb = reinterpret_cast<const std::uint32_t*>(row)[x];
    const int a = argb >> 24, g = (argb >> 8) & 0xff;
    if (a > 200 && g < 60) {
      ++r.count;
      if (r.first < 0) r.first = x;
      r.last = x;
    }
  }
  return r;
}

TEST(ScaleBar, IsAsLongAsItsLengthAtThePicturesScaleAndLabelledAboveIt) {
  test::TempDir dir;
  const std::string path = (dir.path() / "bar.png").string();
  // 50 mm at 2.5 px/mm from (20, 60): 125 px long, on rows 59 and 60 (a 2 px line).
  write_picture(path, "plot", 200, 100, [](Canvas& c) { draw_scale_bar(c, 20, 60, 2.5, 50); });
  cairo_surface_t* png = cairo_image_surface_create_from_png(path.c_str());
  ASSERT_EQ(cairo_surface_status(png), CAIRO_STATUS_SUCCESS);
  const DarkRun bar = dark_pixels(png, 59);
  EXPECT_EQ(bar.first, 20);
  EXPECT_EQ(bar.last, 144);
  EXPECT_EQ(bar.count, 125);
  EXPECT_EQ(dark_pixels(png, 60).count, 125);
  EXPECT_EQ(dark_pixels(png, 64).count, 0);  // nothing below it
  int label = 0;  // the "50 mm" text, in the 12 rows above the bar
  for (int y = 42; y < 54; ++y) label += dark_pixels(png, y).count;
  EXPECT_GT(label, 20);
  cairo_surface_destroy(png);
}

}  // namespace
}  // namespace machplan
