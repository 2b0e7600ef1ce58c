// Slow and many clients against the panel's server: a head or body that does not arrive in
// time closes its connection, a peer at its connection limit makes room by closing its oldest
// unfinished head, and the status and the E-stop are answered meanwhile.
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "engine/common/error.h"
#include "tests/panel/panel_test_rig.h"

namespace machplan {
namespace {

using test::PanelRig;

const std::string kUnfinishedHead = "GET /api/status HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Slow: ";

TEST(PanelClients, AHeadOrABodyThatDoesNotArriveInTimeClosesItsConnection) {
  PanelRig rig(0, "thermal_gantry", {}, [](panel::ServerOptions& so) {
    so.head_timeout_s = 0.5;
    so.body_timeout_s = 1.0;
  });
  rig.take_control();
  test::StalledClient head(rig.port, kUnfinishedHead);
  ASSERT_TRUE(head.connected());
  // One byte a while keeps no connection open past the deadline.
  ASSERT_TRUE(head.send("a"));
  EXPECT_TRUE(head.closed_within(20.0));
  test::StalledClient body(rig.port, "POST /api/override HTTP/1.1\r\nHost: 127.0.0.1\r\nAuthorization: Bearer " + rig.token +
                                         "\r\nX-Machplan-Client: client-one\r\nContent-Type: application/json\r\n"
                                         "Content-Length: 40\r\n\r\n{\"feed\": 1");
  ASSERT_TRUE(body.connected());
  EXPECT_TRUE(body.closed_within(20.0));
  // A client that sends its request whole is still served, and the half-sent override was not applied.
  EXPECT_EQ(rig.status()["overrides"]["feed_pct"], 100.0);
}

TEST(PanelClients, UnfinishedHeadsBeyondThePeersLimitHoldNeitherTheStatusNorTheEstopBack) {
  constexpr int kLimit = 16, kStalled = 200;
  PanelRig rig(0, "thermal_gantry", {}, [](panel::ServerOptions& so) {
    so.max_connections_per_peer = kLimit;
    so.head_timeout_s = 600;  // they stay until made room for
    so.threads = 1;
  });
  rig.take_control();
  std::vector<std::unique_ptr<test::StalledClient>> stalled;
  for (int i = 0; i < kStalled; ++i) {
    stalled.push_back(std::make_unique<test::StalledClient>(rig.port, kUnfinishedHead));
    ASSERT_TRUE(stalled.back()->connected());
  }
  for (int i = 0; i < 10; ++i) EXPECT_EQ(rig.get("/api/status").status, 200);
  const test::HttpResponse estop = rig.post("/api/estop");
  ASSERT_EQ(estop.status, 200) << estop.body;
  EXPECT_EQ(rig.status()["estop"], true);
  // Room was made by closing unfinished heads, oldest first: the first ones are gone, and the
  // peer never held more than its limit.
  const panel::Server::Counters c = rig.server->counters();
  EXPECT_GE(c.evicted, static_cast<std::uint64_t>(kStalled - kLimit));
  EXPECT_TRUE(stalled.front()->closed_within(5.0));
  EXPECT_EQ(c.refused, 0u);
  ASSERT_EQ(rig.post("/api/reset").status, 200);
  EXPECT_EQ(rig.status()["estop"], false);
}

TEST(PanelClients, TheLimitsAreCheckedAsOptions) {
  panel::ServerOptions so;
  so.head_timeout_s = 0;
  EXPECT_THROW(so.validate(), InputError);
  so = {};
  so.max_connections_per_peer = so.max_connections + 1;
  EXPECT_THROW(so.validate(), InputError);
  so = {};
  so.threads = 0;
  EXPECT_THROW(so.validate(), InputError);
  so = {};
  EXPECT_NO_THROW(so.validate());
}

}  // namespace
}  // namespace machplan
