// SPDX-License-Identifier: GPL-3.0-or-later
#include "page_server.h"

#include <arpa/inet.h>
#include <fmt/format.h>
#include <ifaddrs.h>
#include <netdb.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <map>
#include <stdexcept>
#include <vector>

namespace hemo {

namespace {
double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t"), e = s.find_last_not_of(" \t\r");
  return b == std::string::npos ? "" : s.substr(b, e - b + 1);
}

// "name:port", "[v6]:port", and the bare name where the port is HTTP's default.
void add_host_forms(std::set<std::string>& hosts, std::string name, int port) {
  if (name.empty()) return;
  name = lower(name);
  if (name.find(':') != std::string::npos && name.front() != '[') name = "[" + name + "]";
  hosts.insert(fmt::format("{}:{}", name, port));
  if (port == 80) hosts.insert(name);
}

std::set<std::string> hosts_for(const std::string& bind, int port) {
  std::set<std::string> hosts;
  for (const char* local : {"127.0.0.1", "localhost", "::1"}) add_host_forms(hosts, local, port);
  const bool wildcard = bind.empty() || bind == "0.0.0.0" || bind == "::" || bind == "*";
  if (!wildcard) {
    add_host_forms(hosts, bind, port);
    return hosts;
  }
  // Listening on every interface: the names and addresses by which this host is reached.
  char name[256] = {0};
  if (::gethostname(name, sizeof name - 1) == 0) add_host_forms(hosts, name, port);
  ifaddrs* ifs = nullptr;
  if (::getifaddrs(&ifs) == 0) {
    for (auto* i = ifs; i; i = i->ifa_next) {
      if (!i->ifa_addr || (i->ifa_addr->sa_family != AF_INET && i->ifa_addr->sa_family != AF_INET6)) continue;
      char text[INET6_ADDRSTRLEN] = {0};
      const void* addr = i->ifa_addr->sa_family == AF_INET
                             ? static_cast<const void*>(&reinterpret_cast<sockaddr_in*>(i->ifa_addr)->sin_addr)
                             : static_cast<const void*>(&reinterpret_cast<sockaddr_in6*>(i->ifa_addr)->sin6_addr);
      if (::inet_ntop(i->ifa_addr->sa_family, addr, text, sizeof text)) add_host_forms(hosts, text, port);
    }
    ::freeifaddrs(ifs);
  }
  return hosts;
}

const char* reason(int status) {
  switch (status) {
    case 200:
      return "OK";
    case 400:
      return "Bad Request";
    case 404:
      return "Not Found";
    case 405:
      return "Method Not Allowed";
    case 421:
      return "Misdirected Request";
    case 431:
      return "Request Header Fields Too Large";
    default:
      return "Error";
  }
}

struct Connection {
  int fd = -1;
  std::string in, out;
  double last_active = 0;  // when bytes last moved
  bool close_after_write = false;
  bool answering() const { return !out.empty(); }
};

// One request head (request line and headers, without the blank line) to a response; `keep`
// tells whether the connection may stay open after it.
std::string answer(const std::string& head, const std::set<std::string>& hosts, const PageHandler& handler,
                   bool& keep) {
  PageResponse res;
  const auto line_end = head.find("\r\n");
  const std::string request_line = head.substr(0, line_end);
  std::map<std::string, std::string> headers;
  for (std::size_t at = line_end; at != std::string::npos && at < head.size();) {
    const auto next = head.find("\r\n", at + 2);
    const std::string h = head.substr(at + 2, next == std::string::npos ? std::string::npos : next - at - 2);
    const auto colon = h.find(':');
    if (colon != std::string::npos) headers[lower(trim(h.substr(0, colon)))] = trim(h.substr(colon + 1));
    at = next;
  }
  const auto sp1 = request_line.find(' '), sp2 = request_line.rfind(' ');
  const std::string method = request_line.substr(0, sp1);
  const std::string version = sp2 != std::string::npos ? request_line.substr(sp2 + 1) : "";
  keep = version == "HTTP/1.1" && lower(headers["connection"]) != "close";
  const auto host = headers.find("host");
  if (sp1 == std::string::npos || sp1 == sp2 || version.rfind("HTTP/1.", 0) != 0) {
    res.status = 400;
    res.body = "not an HTTP/1 request\n";
    keep = false;
  } else if (host == headers.end() || !hosts.count(lower(host->second))) {
    res.status = 421;  // DNS rebinding: another site's name resolved to this address
    res.body = "this server answers requests for the address it listens on only\n";
    keep = false;
  } else if (method != "GET" && method != "HEAD") {
    res.status = 405;
    res.body = "GET only\n";
  } else {
    PageRequest req;
    const std::string target = request_line.substr(sp1 + 1, sp2 - sp1 - 1);
    const auto q = target.find('?');
    req.path = target.substr(0, q);
    if (q != std::string::npos) {
      const std::string query = target.substr(q + 1);
      for (std::size_t at = 0; at <= query.size();) {
        const auto amp = std::min(query.find('&', at), query.size());
        const std::string pair = query.substr(at, amp - at);
        const auto eq = pair.find('=');
        if (!pair.empty()) req.query[pair.substr(0, eq)] = eq == std::string::npos ? "" : pair.substr(eq + 1);
        at = amp + 1;
      }
    }
    try {
      res = handler(req);
    } catch (const std::exception&) {
      res = PageResponse{400, "text/plain; charset=utf-8", "bad request\n"};
    }
    if (method == "HEAD") res.body.clear();
  }
  std::string out = fmt::format(
      "HTTP/1.1 {} {}\r\nContent-Type: {}\r\nContent-Length: {}\r\nX-Content-Type-Options: nosniff\r\n{}{}\r\n",
      res.status, reason(res.status), res.content_type, res.body.size(),
      res.no_store ? "Cache-Control: no-store\r\n" : "", keep ? "" : "Connection: close\r\n");
  return out + res.body;
}
}  // namespace

PageServer::PageServer(const std::string& bind, int port, PageHandler handler, PageServerLimits limits)
    : handler_(std::move(handler)), limits_(limits) {
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE | AI_NUMERICSERV;
  addrinfo* found = nullptr;
  const std::string service = std::to_string(port);
  if (::getaddrinfo(bind.empty() ? nullptr : bind.c_str(), service.c_str(), &hints, &found) != 0 || !found)
    throw std::runtime_error(fmt::format("cannot serve the monitor's page on {}:{}: not an address here", bind, port));
  for (auto* a = found; a && listen_fd_ < 0; a = a->ai_next) {
    const int fd = ::socket(a->ai_family, a->ai_socktype | SOCK_NONBLOCK | SOCK_CLOEXEC, a->ai_protocol);
    if (fd < 0) continue;
    const int one = 1;
    ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    if (::bind(fd, a->ai_addr, a->ai_addrlen) == 0 && ::listen(fd, SOMAXCONN) == 0)
      listen_fd_ = fd;
    else
      ::close(fd);
  }
  ::freeaddrinfo(found);
  if (listen_fd_ < 0)
    throw std::runtime_error(
        fmt::format("cannot serve the monitor's page on {}:{} (address in use or not ours?)", bind, port));
  sockaddr_storage addr{};
  socklen_t len = sizeof addr;
  ::getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&addr), &len);
  port_ = ntohs(addr.ss_family == AF_INET6 ? reinterpret_cast<sockaddr_in6*>(&addr)->sin6_port
                                           : reinterpret_cast<sockaddr_in*>(&addr)->sin_port);
  allowed_hosts_ = hosts_for(bind, port_);
  wake_fd_ = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  thread_ = std::thread([this] { serve(); });
}

PageServer::~PageServer() {
  const std::uint64_t one = 1;
  if (::write(wake_fd_, &one, sizeof one) < 0) {
  }
  if (thread_.joinable()) thread_.join();
  ::close(wake_fd_);
  ::close(listen_fd_);
}

void PageServer::serve() {
  std::vector<Connection> conns;
  auto close_at = [&](std::size_t i) {
    ::close(conns[i].fd);
    conns.erase(conns.begin() + static_cast<std::ptrdiff_t>(i));
  };
  for (;;) {
    std::vector<pollfd> fds{{wake_fd_, POLLIN, 0}, {listen_fd_, POLLIN, 0}};
    for (const auto& c : conns) fds.push_back({c.fd, static_cast<short>(c.out.empty() ? POLLIN : POLLOUT), 0});
    const bool failed = ::poll(fds.data(), fds.size(), 250) < 0 && errno != EINTR;
    if (failed || fds[0].revents) {  // stopped
      for (const auto& c : conns) ::close(c.fd);
      return;
    }
    const double t = now();
    // Who is due first: the connections as they were polled (those accepted below wait a turn).
    std::vector<bool> gone(conns.size(), false);
    for (std::size_t i = 0; i < conns.size(); ++i) {
      auto& c = conns[i];
      const short ev = fds[i + 2].revents;
      if (ev & (POLLERR | POLLNVAL)) {
        gone[i] = true;
        continue;
      }
      if (ev & (POLLIN | POLLHUP)) {
        char buf[4096];
        const ssize_t n = ::recv(c.fd, buf, sizeof buf, 0);
        if (n <= 0) {
          gone[i] = n == 0 || (errno != EAGAIN && errno != EINTR);
          continue;
        }
        c.in.append(buf, static_cast<std::size_t>(n));
        c.last_active = t;
        const auto end = c.in.find("\r\n\r\n");
        if (end == std::string::npos) {
          if (c.in.size() > limits_.max_request_bytes) {
            c.out = "HTTP/1.1 431 Request Header Fields Too Large\r\nContent-Length: 0\r\nConnection: close\r\n\r\n";
            c.in.clear();
            c.close_after_write = true;
          }
          continue;
        }
        bool keep = false;
        c.out = answer(c.in.substr(0, end), allowed_hosts_, handler_, keep);
        c.in.erase(0, end + 4);  // GET has no body; a pipelined next request waits for this answer
        c.close_after_write = !keep;
      }
      if (!c.out.empty() && (fds[i + 2].revents & POLLOUT)) {
        const ssize_t n = ::send(c.fd, c.out.data(), c.out.size(), MSG_NOSIGNAL);
        if (n < 0) {
          gone[i] = errno != EAGAIN && errno != EINTR;
          continue;
        }
        c.out.erase(0, static_cast<std::size_t>(n));
        c.last_active = t;
        if (c.out.empty() && c.close_after_write) gone[i] = true;
      }
      if (t - c.last_active > limits_.idle_timeout_s) gone[i] = true;
    }
    for (std::size_t i = conns.size(); i-- > 0;)
      if (gone[i]) close_at(i);
    // A pipelined request already read is answered on the next turn: make it due now.
    for (auto& c : conns)
      if (c.out.empty() && c.in.find("\r\n\r\n") != std::string::npos) {
        bool keep = false;
        const auto end = c.in.find("\r\n\r\n");
        c.out = answer(c.in.substr(0, end), allowed_hosts_, handler_, keep);
        c.in.erase(0, end + 4);
        c.close_after_write = !keep;
      }
    if (!(fds[1].revents & POLLIN)) continue;
    for (;;) {
      const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
      if (fd < 0) break;  // EAGAIN: all taken; EMFILE and the like: the backlog waits for a turn
      if (conns.size() >= limits_.max_connections) {
        // Full: the connection quiet the longest goes (idle, or dribbling a request: a real
        // browser sends its request at once); if every one is being answered, the newcomer does.
        auto oldest = conns.end();
        for (auto it = conns.begin(); it != conns.end(); ++it)
          if (!it->answering() && (oldest == conns.end() || it->last_active < oldest->last_active)) oldest = it;
        if (oldest == conns.end()) {
          ::close(fd);
          continue;
        }
        close_at(static_cast<std::size_t>(oldest - conns.begin()));
      }
      conns.push_back({fd, "", "", t, false});
    }
  }
}

}  // namespace hemo
