// The panel's front end: HTTP, the JSON API and the WebSocket live stream (Boost.Beast on
// Boost.Asio), in front of a Panel (cli/panel/panel.h). docs/panel.md is the API's manual.
//
// Security, on by default:
//   * it binds 127.0.0.1 unless told otherwise (ServerOptions::bind; `serve` needs
//     --allow-remote for any other address and warns);
//   * a fresh random token (32 bytes from the kernel's getrandom, hex) is needed by every API
//     call and the WebSocket: `Authorization: Bearer TOKEN`, or the cookie the page's login
//     (POST /api/login with the bearer header) sets (HttpOnly, SameSite=Strict). A wrong or
//     missing token is 401 with nothing else; tokens are compared in constant time. The page's
//     static files need no token (they hold nothing secret);
//   * one client holds control at a time (the X-Machplan-Client header names a client; POST
//     /api/control takes it explicitly). Commands from another client get 409; watching,
//     GET requests and the E-stop (POST /api/estop) are open to every authenticated client;
//   * the WebSocket's Origin must be this server (http://HOST as the client asked for it) when
//     the client sends one (browsers always do); a POST authenticated by the cookie must carry
//     an Origin of this server too and a JSON content type (no cross-site form can);
//   * request bodies are limited (max_body_bytes; a job's program max_job_bytes): larger is
//     413 before reading; bad JSON or a wrong type is 400 with a message; unknown routes 404;
//     nothing a client sends reaches the tick except through the Panel's operator inputs;
//   * live frames go to each viewer through a mailbox of one frame: a slow viewer skips
//     frames (they are counted), it never holds the others back; at most max_viewers;
//   * slow or many clients cannot stall it: a request's head must arrive within
//     head_timeout_s and its body within body_timeout_s; a peer (an IP address) holds at most
//     max_connections_per_peer connections and the server max_connections (at the limit the
//     oldest connection still sending its head is closed to make room); reading costs no
//     thread, so clients that send slowly hold none.
//
// Threading: one I/O thread runs every socket and never blocks; requests run on `threads`
// workers, except the E-stop and the status, which have a thread each so that no other request
// is ever ahead of them; one more thread reads the Panel's live state at frame_hz, hands the
// frame to every viewer and calls Panel::service().
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "cli/panel/panel.h"

namespace machplan::panel {

struct ServerOptions {
  std::string bind = "127.0.0.1";
  int port = 8090;                 // 0: any free port (port() tells which)
  bool allow_remote = false;       // a bind address other than loopback needs this
  std::string token;               // "" : a fresh random one
  std::string web_root;            // "" : found (web_root_folder())
  double frame_hz = 50.0;          // live stream, 30 .. 200
  int max_viewers = 64;            // WebSocket clients at once
  int threads = 8;                 // workers for requests (the E-stop and the status have their own)
  double head_timeout_s = 5.0;     // a request's head must arrive within this
  double body_timeout_s = 60.0;    // and its body within this after the head
  int max_connections = 1024;      // open at once (within the process's file limit)
  int max_connections_per_peer = 64;
  std::size_t max_body_bytes = 64 * 1024;
  std::size_t max_job_bytes = 32 * 1024 * 1024;  // POST /api/job (a program's text)
  void validate() const;           // InputError::field naming the field
};

// Where the page's files are: beside an installed machplan (PREFIX/share/machplan/panel), the
// configured install prefix, or the source tree for a program of the build tree.
std::string web_root_folder();

// The token: 64 hex digits from getrandom(2).
std::string random_token();

class Server {
 public:
  // Starts listening; throws InputError naming the field (bind, port) when it cannot.
  Server(Panel& panel, ServerOptions options);
  ~Server();  // stops the stream, closes every connection, joins every thread
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  int port() const;
  const std::string& token() const;
  // http://HOST:PORT/?token=TOKEN (the page logs in from it).
  std::string url() const;

  // Live stream counters: frames handed over, frames a viewer skipped, viewers now; connections
  // closed to make room for another (evicted) and connections refused at the limits.
  struct Counters {
    std::uint64_t frames = 0, skipped = 0, sent = 0, evicted = 0, refused = 0;
    int viewers = 0;
  };
  Counters counters() const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace machplan::panel
