// A small HTTP/1.1 and WebSocket client for the panel's tests and bench: blocking sockets on
// loopback, every read bounded by a timeout (SO_RCVTIMEO), one request per connection.
//
//     test::HttpResponse r = test::http(port, "GET", "/api/status", {{"Authorization", "Bearer " + token}});
//     test::WsClient ws(port, "/api/live", {{"Authorization", "Bearer " + token}});
//     std::string frame = ws.next_text();   // "" on timeout or close
#pragma once

#include <map>
#include <string>
#include <utility>
#include <vector>

namespace machplan::test {

using Headers = std::vector<std::pair<std::string, std::string>>;

struct HttpResponse {
  int status = 0;                              // 0: no answer (connection refused, timeout, closed)
  std::map<std::string, std::string> headers;  // names lower-cased
  std::string body;
};

// One well-formed request on its own connection (Host and Content-Length filled in unless
// given); malformed requests go through send_raw.
HttpResponse http(int port, const std::string& method, const std::string& path, const Headers& headers = {},
                  const std::string& body = {}, double timeout_s = 30.0);
// Sends `bytes` as they are and returns what came back until the server closed or the timeout.
std::string send_raw(int port, const std::string& bytes, double timeout_s = 5.0);

// A client that sends `bytes` (a request cut short, say) and then neither sends nor reads
// until it is destroyed: a slow or stalled client.
class StalledClient {
 public:
  StalledClient(int port, const std::string& bytes);
  ~StalledClient();
  StalledClient(const StalledClient&) = delete;
  StalledClient& operator=(const StalledClient&) = delete;
  bool connected() const { return fd_ >= 0; }
  // Sends more bytes: false when the connection is gone.
  bool send(const std::string& bytes);
  // Whether the server closes the connection within `timeout_s` (whatever it sends first, an
  // answer say, is read and dropped).
  bool closed_within(double timeout_s);

 private:
  int fd_ = -1;
};

class WsClient {
 public:
  // Opens the connection and sends the upgrade request. ok() tells whether the server agreed
  // (101); response() is the server's answer head (and body when it refused).
  WsClient(int port, const std::string& path, const Headers& headers = {}, double timeout_s = 10.0);
  ~WsClient();
  WsClient(const WsClient&) = delete;
  WsClient& operator=(const WsClient&) = delete;
  bool ok() const { return ok_; }
  const std::string& response() const { return response_; }
  // The next text frame (pings are answered); "" on timeout, when the connection closed, or
  // when the server sent a masked frame (which no browser accepts).
  std::string next_text();
  // The socket: a test of slow clients stops reading it.
  int fd() const { return fd_; }

 private:
  bool read_exact(char* out, std::size_t n);
  int fd_ = -1;
  bool ok_ = false;
  std::string response_, pending_;
};

}  // namespace machplan::test
