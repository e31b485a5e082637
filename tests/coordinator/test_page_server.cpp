// The monitor's page server (coordinator/page_server.h) over real loopback sockets: the page
// answers its user with a thousand idle connections open, idle connections are closed, at most
// max_connections are held, and a request naming another host (DNS rebinding) is refused.
// SPDX-License-Identifier: GPL-3.0-or-later
#include "page_server.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <string>
#include <thread>
#include <vector>

using namespace hemo;

namespace {

int connect_to(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (fd < 0 || ::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    if (fd >= 0) ::close(fd);
    return -1;
  }
  return fd;
}

// Reads until the peer closes or `timeout_s` passes; "" if nothing came.
std::string read_all(int fd, double timeout_s) {
  std::string got;
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - std::chrono::steady_clock::now());
    if (left.count() <= 0) break;
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, static_cast<int>(left.count())) <= 0) break;
    char buf[4096];
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    if (n <= 0) break;
    got.append(buf, static_cast<std::size_t>(n));
  }
  return got;
}

// One GET with the given Host header (none if empty); the whole response.
std::string get(int port, const std::string& path, const std::string& host, double timeout_s = 5) {
  const int fd = connect_to(port);
  if (fd < 0) return "";
  const std::string req =
      "GET " + path + " HTTP/1.1\r\n" + (host.empty() ? "" : "Host: " + host + "\r\n") + "Connection: close\r\n\r\n";
  if (::send(fd, req.data(), req.size(), MSG_NOSIGNAL) != static_cast<ssize_t>(req.size())) return ::close(fd), "";
  std::string res = read_all(fd, timeout_s);
  ::close(fd);
  return res;
}

int status_of(const std::string& response) {
  return response.rfind("HTTP/1.1 ", 0) == 0 ? std::stoi(response.substr(9, 3)) : 0;
}

PageHandler pages() {
  return [](const PageRequest& req) {
    if (req.path == "/rows") return PageResponse{200, "application/json", "{\"since\":" + req.query.at("since") + "}"};
    return PageResponse{200, "text/html", "<p>the page</p>"};
  };
}

}  // namespace

TEST(PageServer, AnswersItsUserWithAThousandIdleConnectionsOpen) {
  PageServerLimits limits;
  limits.max_connections = 64;
  limits.idle_timeout_s = 60;  // longer than the test: only the cap can make room
  // This process holds both ends: a thousand client sockets and the server's; 1024 descriptors
  // (a common soft limit) would not do.
  rlimit files{};
  ::getrlimit(RLIMIT_NOFILE, &files);
  files.rlim_cur = std::max<rlim_t>(files.rlim_cur, std::min<rlim_t>(files.rlim_max, 4096));
  ::setrlimit(RLIMIT_NOFILE, &files);
  if (files.rlim_cur < 1200) GTEST_SKIP() << "fewer than 1200 file descriptors allowed";
  PageServer server("127.0.0.1", 0, pages(), limits);
  const std::string host = "127.0.0.1:" + std::to_string(server.port());
  std::vector<int> idle;
  for (int i = 0; i < 1000; ++i) {
    const int fd = connect_to(server.port());
    ASSERT_GE(fd, 0) << "connection " << i;
    idle.push_back(fd);
  }
  const std::string res = get(server.port(), "/rows?since=12", host);
  EXPECT_EQ(status_of(res), 200) << res;
  EXPECT_NE(res.find("{\"since\":12}"), std::string::npos) << res;
  // The server holds at most its cap: the rest of the idle connections were closed by it.
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  int still_open = 0;
  for (int fd : idle) {
    pollfd p{fd, POLLIN, 0};
    char c;
    const bool closed = ::poll(&p, 1, 0) == 1 && ::recv(fd, &c, 1, MSG_DONTWAIT) == 0;
    still_open += !closed;
    ::close(fd);
  }
  EXPECT_LE(still_open, 64);
  EXPECT_GT(still_open, 0) << "the cap, not a refusal of every idle connection";
}

TEST(PageServer, ClosesAConnectionIdleForItsTimeout) {
  PageServerLimits limits;
  limits.idle_timeout_s = 0.5;
  PageServer server("127.0.0.1", 0, pages(), limits);
  const int fd = connect_to(server.port());
  ASSERT_GE(fd, 0);
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(read_all(fd, 5), "");  // ends when the server closes it
  const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_GE(took, 0.4);
  EXPECT_LT(took, 4.0) << "not closed by the idle timeout";
  ::close(fd);
}

// DNS rebinding: a page of evil.example made to resolve to 127.0.0.1 sends "Host: evil.example".
TEST(PageServer, RefusesARequestForAnotherHost) {
  PageServer server("127.0.0.1", 0, pages());
  const std::string port = std::to_string(server.port());
  EXPECT_EQ(status_of(get(server.port(), "/", "127.0.0.1:" + port)), 200);
  EXPECT_EQ(status_of(get(server.port(), "/", "localhost:" + port)), 200);
  EXPECT_EQ(status_of(get(server.port(), "/", "LocalHost:" + port)), 200);
  const std::string foreign = get(server.port(), "/", "evil.example:" + port);
  EXPECT_EQ(status_of(foreign), 421) << foreign;
  EXPECT_EQ(foreign.find("the page"), std::string::npos) << foreign;
  EXPECT_EQ(status_of(get(server.port(), "/rows?since=0", "evil.example")), 421);
  EXPECT_EQ(status_of(get(server.port(), "/", "127.0.0.1:1")), 421) << "another port is another origin";
  EXPECT_EQ(status_of(get(server.port(), "/", "")), 421) << "no Host header";
}

// A wildcard bind answers for this host's names and addresses, and still not for another site.
TEST(PageServer, AWildcardBindAnswersForThisHostOnly) {
  PageServer server("0.0.0.0", 0, pages());
  const std::string port = std::to_string(server.port());
  char name[256] = {0};
  ::gethostname(name, sizeof name - 1);
  EXPECT_TRUE(server.allowed_hosts().count(std::string(name) + ":" + port));
  EXPECT_EQ(status_of(get(server.port(), "/", "127.0.0.1:" + port)), 200);
  EXPECT_EQ(status_of(get(server.port(), "/", "evil.example:" + port)), 421);
}

TEST(PageServer, AnswersSeveralRequestsOnOneConnection) {
  PageServer server("127.0.0.1", 0, pages());
  const std::string host = "127.0.0.1:" + std::to_string(server.port());
  const int fd = connect_to(server.port());
  ASSERT_GE(fd, 0);
  const std::string two = "GET /rows?since=1 HTTP/1.1\r\nHost: " + host +
                          "\r\n\r\nGET /rows?since=2 HTTP/1.1\r\nHost: " + host + "\r\nConnection: close\r\n\r\n";
  ASSERT_EQ(::send(fd, two.data(), two.size(), MSG_NOSIGNAL), static_cast<ssize_t>(two.size()));
  const std::string res = read_all(fd, 5);
  ::close(fd);
  EXPECT_NE(res.find("{\"since\":1}"), std::string::npos) << res;
  EXPECT_NE(res.find("{\"since\":2}"), std::string::npos) << res;
}
