// The monitor's page server: a small HTTP/1.1 server for GET requests, bounded against idle
// connections and checked against DNS rebinding (docs/design.md, "Monitor").
//
// One thread polls every connection, so an idle connection costs a file descriptor and a few
// bytes, never a worker: Debian's cpp-httplib (0.11) gives each connection a worker thread until
// its keep-alive ends, and a thousand idle sockets kept the page's one real user waiting for
// minutes. Here at most `max_connections` are open at once; a new one beyond closes the one idle
// the longest, and a connection without a complete request for `idle_timeout_s` is closed.
//
// A request whose Host header is not the address the server listens on (127.0.0.1, localhost
// or [::1] with its port; the bind address; for a wildcard bind, this host's names and
// addresses) is refused with 421: a page of another site that a browser was made to resolve to
// this address (DNS rebinding) names its own host, and reads nothing of the run.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <atomic>
#include <cstddef>
#include <functional>
#include <map>
#include <set>
#include <string>
#include <thread>

namespace hemo {

struct PageRequest {
  std::string path;                          // "/rows"
  std::map<std::string, std::string> query;  // "since" -> "12" (no percent-decoding: the page's are plain)
};

struct PageResponse {
  int status = 200;
  std::string content_type = "text/plain; charset=utf-8";
  std::string body;
  bool no_store = false;  // Cache-Control: no-store
};

using PageHandler = std::function<PageResponse(const PageRequest&)>;

struct PageServerLimits {
  std::size_t max_connections = 64;       // open at once (a browser opens about six)
  double idle_timeout_s = 10;             // without a complete request, or with output not taken
  std::size_t max_request_bytes = 16384;  // request line and headers; more is refused (431)
};

class PageServer {
 public:
  // Listens on bind:port (port 0: any free one) and serves `handler` from a thread of its own;
  // throws a one-line error when it cannot listen.
  PageServer(const std::string& bind, int port, PageHandler handler, PageServerLimits limits = {});
  ~PageServer();
  PageServer(const PageServer&) = delete;
  PageServer& operator=(const PageServer&) = delete;

  int port() const { return port_; }
  // The Host header values it answers.
  const std::set<std::string>& allowed_hosts() const { return allowed_hosts_; }

 private:
  void serve();

  PageHandler handler_;
  PageServerLimits limits_;
  int listen_fd_ = -1;
  int wake_fd_ = -1;  // an eventfd: written to stop the thread
  int port_ = -1;
  std::set<std::string> allowed_hosts_;
  std::thread thread_;
};

}  // namespace hemo
