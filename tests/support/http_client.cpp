#include "tests/support/http_client.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <random>

namespace machplan::test {
namespace {

int connect_loopback(int port, double timeout_s) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return -1;
  timeval tv{};
  tv.tv_sec = static_cast<long>(timeout_s);
  tv.tv_usec = static_cast<long>((timeout_s - static_cast<double>(tv.tv_sec)) * 1e6);
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

bool send_all(int fd, const std::string& s) {
  std::size_t at = 0;
  while (at < s.size()) {
    const ssize_t n = ::send(fd, s.data() + at, s.size() - at, MSG_NOSIGNAL);
    if (n <= 0) return false;
    at += static_cast<std::size_t>(n);
  }
  return true;
}

std::string read_all(int fd) {
  std::string out;
  char buf[65536];
  for (ssize_t n; (n = ::recv(fd, buf, sizeof buf, 0)) > 0;) out.append(buf, static_cast<std::size_t>(n));
  return out;
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

HttpResponse parse(const std::string& raw) {
  HttpResponse r;
  const std::size_t end = raw.find("\r\n\r\n");
  if (raw.rfind("HTTP/1.", 0) != 0 || end == std::string::npos) return r;
  r.status = std::atoi(raw.c_str() + 9);
  std::size_t at = raw.find("\r\n") + 2;
  while (at < end) {
    const std::size_t eol = raw.find("\r\n", at);
    const std::string line = raw.substr(at, eol - at);
    const std::size_t colon = line.find(':');
    if (colon != std::string::npos) {
      std::string v = line.substr(colon + 1);
      v.erase(0, v.find_first_not_of(' '));
      r.headers[lower(line.substr(0, colon))] = v;
    }
    at = eol + 2;
  }
  r.body = raw.substr(end + 4);
  return r;
}

}  // namespace

HttpResponse http(int port, const std::string& method, const std::string& path, const Headers& headers,
                  const std::string& body, double timeout_s) {
  const int fd = connect_loopback(port, timeout_s);
  if (fd < 0) return {};
  const bool has_host = std::any_of(headers.begin(), headers.end(), [](const auto& h) { return lower(h.first) == "host"; });
  std::string req = method + " " + path + " HTTP/1.1\r\n" +
                    (has_host ? std::string() : "Host: 127.0.0.1:" + std::to_string(port) + "\r\n") + "Connection: close\r\n";
  for (const auto& [k, v] : headers) req += k + ": " + v + "\r\n";
  if (!body.empty() || method == "POST") req += "Content-Length: " + std::to_string(body.size()) + "\r\n";
  req += "\r\n" + body;
  HttpResponse r;
  if (send_all(fd, req)) r = parse(read_all(fd));
  ::close(fd);
  return r;
}

std::string send_raw(int port, const std::string& bytes, double timeout_s) {
  const int fd = connect_loopback(port, timeout_s);
  if (fd < 0) return {};
  send_all(fd, bytes);
  ::shutdown(fd, SHUT_WR);
  std::string out = read_all(fd);
  ::close(fd);
  return out;
}

StalledClient::StalledClient(int port, const std::string& bytes) {
  fd_ = connect_loopback(port, 5.0);
  if (fd_ >= 0 && !send_all(fd_, bytes)) {
    ::close(fd_);
    fd_ = -1;
  }
}

StalledClient::~StalledClient() {
  if (fd_ >= 0) ::close(fd_);
}

bool StalledClient::send(const std::string& bytes) { return fd_ >= 0 && send_all(fd_, bytes); }

bool StalledClient::closed_within(double timeout_s) {
  if (fd_ < 0) return true;
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  char buf[4096];
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(until - std::chrono::steady_clock::now()).count();
    pollfd p{fd_, POLLIN, 0};
    const int n = ::poll(&p, 1, static_cast<int>(std::max<long long>(left, 0)));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;  // nothing within the time
    const ssize_t got = ::recv(fd_, buf, sizeof buf, MSG_DONTWAIT);
    if (got == 0 || (got < 0 && errno != EAGAIN && errno != EINTR)) return true;
  }
}

WsClient::WsClient(int port, const std::string& path, const Headers& headers, double timeout_s) {
  fd_ = connect_loopback(port, timeout_s);
  if (fd_ < 0) return;
  std::string req = "GET " + path + " HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(port) +
                    "\r\nUpgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n"
                    "Sec-WebSocket-Version: 13\r\n";
  for (const auto& [k, v] : headers) req += k + ": " + v + "\r\n";
  req += "\r\n";
  if (!send_all(fd_, req)) return;
  // The answer's head, byte by byte up to the blank line (frames may follow at once).
  char c;
  while (response_.find("\r\n\r\n") == std::string::npos && ::recv(fd_, &c, 1, 0) == 1) response_ += c;
  ok_ = response_.rfind("HTTP/1.1 101", 0) == 0;
  if (!ok_) {
    response_ += read_all(fd_);
  }
}

WsClient::~WsClient() {
  if (fd_ >= 0) {
    if (ok_) {
      const char close_frame[] = {static_cast<char>(0x88), static_cast<char>(0x80), 0, 0, 0, 0};
      ::send(fd_, close_frame, sizeof close_frame, MSG_NOSIGNAL);
    }
    ::close(fd_);
  }
}

bool WsClient::read_exact(char* out, std::size_t n) {
  std::size_t have = 0;
  while (have < n) {
    const ssize_t r = ::recv(fd_, out + have, n - have, 0);
    if (r <= 0) return false;
    have += static_cast<std::size_t>(r);
  }
  return true;
}

std::string WsClient::next_text() {
  if (!ok_) return {};
  for (int frames = 0; frames < 10000; ++frames) {
    unsigned char h[2];
    if (!read_exact(reinterpret_cast<char*>(h), 2)) return {};
    // A server never masks its frames (RFC 6455, 5.1): a masked one ends the connection, as a
    // browser ends it.
    if (h[1] & 0x80) return {};
    const int opcode = h[0] & 0x0f;
    std::uint64_t len = h[1] & 0x7f;
    if (len == 126) {
      unsigned char e[2];
      if (!read_exact(reinterpret_cast<char*>(e), 2)) return {};
      len = (std::uint64_t{e[0]} << 8) | e[1];
    } else if (len == 127) {
      unsigned char e[8];
      if (!read_exact(reinterpret_cast<char*>(e), 8)) return {};
      len = 0;
      for (unsigned char b : e) len = (len << 8) | b;
    }
    if (len > (64u << 20)) return {};
    std::string payload(len, '\0');
    if (len && !read_exact(payload.data(), len)) return {};
    if (opcode == 0x1) return payload;
    if (opcode == 0x8) return {};
    if (opcode == 0x9) {  // ping: answer with a masked pong
      std::string pong = {static_cast<char>(0x8a), static_cast<char>(0x80 | payload.size()), 0, 0, 0, 0};
      pong += payload;
      send_all(fd_, pong);
    }
  }
  return {};
}

}  // namespace machplan::test
