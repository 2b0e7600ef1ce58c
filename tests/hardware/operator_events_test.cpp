// The operator-events timeline: what `run --operator-events` reads.
#include <string>

#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "engine/hardware/operator_events.h"

namespace machplan::hardware {
namespace {

std::string error_of(const std::string& text) {
  try {
    parse_operator_events(text, "ev.csv");
  } catch (const InputError& e) {
    return e.what();
  }
  return "<accepted>";
}

TEST(OperatorEvents, ButtonsArePressedAndReleasedAndLevelsLast) {
  const OperatorTimeline tl = parse_operator_events(
      "t_s,event,value\n# comment\n\n1.0,hold,\n2.0,start,\n3.0,feed_override,50\n4.0,rapid_override,25\n"
      "5.0,paused_motion,-5\n5.5,recover,2\n5.7,paused_motion_speed,-0.5\n5.9,paused_motion_speed,0\n6.0,thc,0\n"
      "6.5,torch,0\n7.0,stop,\n",
      "ev.csv");
  ASSERT_EQ(tl.rows.size(), 11u);
  EXPECT_EQ(tl.rows[5].kind, OperatorEventRow::Kind::paused_motion);  // `recover`, the older name
  EXPECT_EQ(tl.rows[0].line, 4);
  const auto at = [&](double t) {
    OperatorInputs s;
    for (const OperatorEvent& e : tl.states)
      if (e.at_s <= t) s = e.inputs;
    return s;
  };
  EXPECT_TRUE(at(1.005).feed_hold);
  EXPECT_FALSE(at(1.02).feed_hold);  // released kPress_s later
  EXPECT_TRUE(at(2.0).cycle_start);
  EXPECT_EQ(at(3.5).feed_override_pct, 50.0);
  EXPECT_EQ(at(100).feed_override_pct, 50.0);
  EXPECT_EQ(at(4.5).rapid_override_pct, 25.0);
  EXPECT_EQ(at(5.2).paused_motion_mm, -5.0);
  EXPECT_EQ(at(5.6).paused_motion_mm, -3.0);  // requests add up
  EXPECT_EQ(at(5.6).paused_motion_speed, 0.0);
  EXPECT_EQ(at(5.8).paused_motion_speed, -0.5);  // a level, held
  EXPECT_EQ(at(5.95).paused_motion_speed, 0.0);
  EXPECT_FALSE(at(6.5).thc_enabled);
  EXPECT_TRUE(at(6.4).torch_enabled);
  EXPECT_FALSE(at(6.6).torch_enabled);
  EXPECT_TRUE(at(7.0).stop);
  EXPECT_FALSE(at(8.0).stop);
}

TEST(OperatorEvents, BadRowsNameTheFileAndLine) {
  EXPECT_EQ(error_of("0,hold,\n"), "ev.csv:1: the first line must be the header 't_s,event,value', found '0,hold,'");
  EXPECT_EQ(error_of("t_s,event,value\n1,jump,\n"),
            "ev.csv:2: unknown event 'jump' (events: hold, start, stop, feed_override, rapid_override, paused_motion, "
            "paused_motion_speed, thc, torch)");
  EXPECT_EQ(error_of("t_s,event,value\n1,hold,3\n"), "ev.csv:2: 'hold' takes no value, found '3'");
  EXPECT_EQ(error_of("t_s,event,value\n1,feed_override,\n"), "ev.csv:2: 'feed_override' needs a value");
  EXPECT_EQ(error_of("t_s,event,value\n1,feed_override,201\n"), "ev.csv:2: feed_override 201 % must be in [0, 200]");
  EXPECT_EQ(error_of("t_s,event,value\n1,rapid_override,0\n"), "ev.csv:2: rapid_override 0 % must be in [1, 100]");
  EXPECT_EQ(error_of("t_s,event,value\n1,thc,2\n"), "ev.csv:2: thc 2 must be 1 (on) or 0 (off)");
  EXPECT_EQ(error_of("t_s,event,value\n1,torch,0.5\n"), "ev.csv:2: torch 0.5 must be 1 (on) or 0 (off)");
  EXPECT_EQ(error_of("t_s,event,value\n1,recover,0\n"), "ev.csv:2: paused_motion 0 mm asks for nothing");
  EXPECT_EQ(error_of("t_s,event,value\n1,paused_motion,1001\n"), "ev.csv:2: paused_motion 1001 mm must be in [-1000, 1000]");
  EXPECT_EQ(error_of("t_s,event,value\n1,paused_motion_speed,-1.5\n"), "ev.csv:2: paused_motion_speed -1.5 must be in [-1, 1]");
  EXPECT_EQ(error_of("t_s,event,value\n1,paused_motion_speed,\n"), "ev.csv:2: 'paused_motion_speed' needs a value");
  EXPECT_EQ(error_of("t_s,event,value\n2,hold,\n1,start,\n"), "ev.csv:3: time 1 s goes back (previous event: 2 s)");
  EXPECT_EQ(error_of("t_s,event,value\n1,hold,\n1.01,hold,\n"),
            "ev.csv:3: 'hold' pressed again 0.010 s after its last press (at least 0.02 s apart)");
  EXPECT_EQ(error_of("t_s,event,value\nx,hold,\n"), "ev.csv:2: time 'x' is not a number");
  EXPECT_EQ(error_of("t_s,event,value\n1,hold\n"), "ev.csv:2: expected 3 fields (t_s, event, value), found 2");
  EXPECT_EQ(error_of(""), "ev.csv: no header 't_s,event,value'");
}

}  // namespace
}  // namespace machplan::hardware
