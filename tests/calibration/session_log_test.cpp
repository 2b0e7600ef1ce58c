// The session log reader: good logs read back exactly; every defect is named with FILE:LINE.
#include <sstream>

#include <gtest/gtest.h>

#include "engine/calibration/session_log.h"
#include "engine/common/error.h"

namespace machplan::calibration {
namespace {

constexpr const char* kGood =
    "# machine: thermal_gantry\n"
    "# operator: test\n"
    "t_s,axis,dac,counter,dir,ref_mm\n"
    "0.000,x,0,40000,0,0.0125\n"
    "0.000,y,0,123,0,\n"
    "\n"
    "0.001,x,410,39998,0,\n"
    "0.001,y,-2048,125,8,\n"
    "0.002,x,2047,65535,0,-12.5\n";

TEST(SessionLog, ReadsRowsAndComments) {
  const auto log = read_session_log_text(kGood, "good.csv");
  ASSERT_EQ(log.comments.size(), 2u);
  EXPECT_EQ(log.comments[0], "machine: thermal_gantry");
  ASSERT_EQ(log.samples.size(), 5u);
  EXPECT_EQ(log.samples[0].axis, 0);
  EXPECT_TRUE(log.samples[0].has_ref);
  EXPECT_DOUBLE_EQ(log.samples[0].ref_mm, 0.0125);
  EXPECT_FALSE(log.samples[1].has_ref);
  EXPECT_EQ(log.samples[3].dac, -2048);
  EXPECT_TRUE(log.samples[3].direction_negative);
  EXPECT_EQ(log.samples[4].counter, 65535u);
  EXPECT_EQ(log.samples[4].line, 9);
}

TEST(SessionLog, WritesWhatItReads) {
  const auto log = read_session_log_text(kGood, "good.csv");
  std::ostringstream out;
  write_session_log(out, log);
  const auto again = read_session_log_text(out.str(), "again.csv");
  ASSERT_EQ(again.samples.size(), log.samples.size());
  EXPECT_EQ(again.comments, log.comments);
  for (std::size_t k = 0; k < log.samples.size(); ++k) {
    EXPECT_DOUBLE_EQ(again.samples[k].t_s, log.samples[k].t_s);
    EXPECT_EQ(again.samples[k].counter, log.samples[k].counter);
    EXPECT_EQ(again.samples[k].dac, log.samples[k].dac);
    EXPECT_EQ(again.samples[k].has_ref, log.samples[k].has_ref);
    EXPECT_DOUBLE_EQ(again.samples[k].ref_mm, log.samples[k].ref_mm);
  }
}

struct Bad {
  const char* body;  // rows after the header (header is line 1)
  int line;
  const char* says;
};

TEST(SessionLog, NamesEveryDefectWithItsLine) {
  const Bad cases[] = {
      {"0.0,x,0,1,0,\n0.001,x,0,1\n", 3, "truncated row: 4 of 6"},
      {"0.0,x,0,1,0,,7\n", 2, "too many fields"},
      {"abc,x,0,1,0,\n", 2, "t_s 'abc' is not a finite number"},
      {"nan,x,0,1,0,\n", 2, "t_s 'nan' is not a finite number"},
      {"0.0,z,0,1,0,\n", 2, "axis 'z' is not x or y"},
      {"0.0,x,1.5,1,0,\n", 2, "dac '1.5' is not an integer"},
      {"0.0,x,2048,1,0,\n", 2, "dac 2048 is outside -2048 .. 2047"},
      {"0.0,x,0,65536,0,\n", 2, "counter 65536 is outside 0 .. 65535"},
      {"0.0,x,0,-1,0,\n", 2, "counter -1 is outside"},
      {"0.0,x,0,1,1,\n", 2, "dir '1' is not 0 (positive) or 8 (negative)"},
      {"0.0,x,0,1,0,12mm\n", 2, "ref_mm '12mm' is not a finite number"},
      {"0.002,x,0,1,0,\n0.001,y,0,1,0,\n0.001,x,0,1,0,\n", 4, "time goes backwards or stands still on axis x"},
      {"0.001,x,0,1,0,\n0.001,x,0,1,0,\n", 3, "time goes backwards or stands still"},
      {"-1,x,0,1,0,\n", 2, "t_s -1 is negative"},
  };
  for (const auto& c : cases) {
    const std::string text = std::string("t_s,axis,dac,counter,dir,ref_mm\n") + c.body;
    try {
      read_session_log_text(text, "bad.csv");
      ADD_FAILURE() << "accepted: " << c.body;
    } catch (const InputError& e) {
      EXPECT_EQ(e.where(), "bad.csv");
      EXPECT_EQ(e.line(), c.line) << e.what();
      EXPECT_NE(std::string(e.what()).find(c.says), std::string::npos) << e.what() << "\nwanted: " << c.says;
    }
  }
}

TEST(SessionLog, RejectsAFileThatIsNotALog) {
  EXPECT_THROW(read_session_log_text("", "empty.csv"), InputError);
  EXPECT_THROW(read_session_log_text("# only a comment\n", "c.csv"), InputError);
  EXPECT_THROW(read_session_log_text("t_s,axis,dac,counter,dir,ref_mm\n", "h.csv"), InputError);
  try {
    read_session_log_text("time,axis,dac\n0,x,0\n", "other.csv");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 1);
    EXPECT_NE(std::string(e.what()).find("expected the header"), std::string::npos);
  }
}

}  // namespace
}  // namespace machplan::calibration
