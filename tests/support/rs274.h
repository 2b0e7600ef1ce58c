// LinuxCNC's own reading of a program beside machplan's, for the tests that say a written
// program is G-code LinuxCNC reads to the same moves.
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace machplan::test {

using FeedEnds = std::vector<std::pair<double, double>>;  // (X, Y) where each feed move ends

// The end points of the feed moves (STRAIGHT_FEED, ARC_FEED) LinuxCNC's rs274 reads from the
// program, in order. rs274 runs in the program's folder (its output goes there), one at a time
// across test processes. Empty, with a test failure, when rs274 refuses the program.
FeedEnds rs274_feeds(const std::string& program);

// The end points of the lines and arcs `machplan program --json` reads from it, in order.
FeedEnds machplan_feeds(const std::string& program, const std::string& dialect = "linuxcnc");

// Both readings hold the same feed moves, each end within `tol_mm` in X and Y (a test failure per
// move that differs, naming it).
void expect_same_feeds(const FeedEnds& rs274, const FeedEnds& machplan, double tol_mm = 1e-4);

}  // namespace machplan::test
