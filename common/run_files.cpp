// SPDX-License-Identifier: GPL-3.0-or-later
#include "run_files.h"

#include <fmt/format.h>
#include <openssl/evp.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <utility>

namespace hemo {

namespace {
struct Fd {
  int fd;
  ~Fd() {
    if (fd >= 0) ::close(fd);
  }
};

// Writes all of `n` bytes or returns the errno of the write that failed.
int write_all(int fd, const char* p, std::size_t n) {
  while (n > 0) {
    const ssize_t w = ::write(fd, p, n);
    if (w < 0) {
      if (errno == EINTR) continue;
      return errno;
    }
    p += w;
    n -= static_cast<std::size_t>(w);
  }
  return 0;
}

std::string mode_text(mode_t m) { return fmt::format("{:04o}", m & 07777); }

std::string hex(const unsigned char* p, std::size_t n) {
  std::string s;
  for (std::size_t i = 0; i < n; ++i) s += fmt::format("{:02x}", p[i]);
  return s;
}
}  // namespace

std::string io_error(const std::string& doing, const std::string& path, int err) {
  return fmt::format("cannot {} {}: {}", doing, path, err == ENOSPC ? "no space left on device" : std::strerror(err));
}

std::vector<std::uint8_t> read_private_file(const std::string& path, const std::string& what) {
  // O_NOFOLLOW and the checks on the descriptor opened: what is checked is what is read.
  Fd f{::open(path.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC | O_NONBLOCK)};
  if (f.fd < 0) {
    if (errno == ELOOP) throw std::runtime_error(fmt::format("{} {} is a symbolic link: refusing it", what, path));
    throw std::runtime_error(io_error("read the " + what, path, errno));
  }
  struct stat st {};
  if (::fstat(f.fd, &st) != 0) throw std::runtime_error(io_error("read the " + what, path, errno));
  if (!S_ISREG(st.st_mode))
    throw std::runtime_error(fmt::format("{} {} is not a regular file: refusing it", what, path));
  if (st.st_uid != ::geteuid())
    throw std::runtime_error(fmt::format("{} {} belongs to uid {}, not to this user (uid {}): refusing it", what, path,
                                         st.st_uid, ::geteuid()));
  if ((st.st_mode & 077) != 0)
    throw std::runtime_error(fmt::format("{} {} has mode {}, open to others: refusing it (it must be 0600)", what, path,
                                         mode_text(st.st_mode)));
  std::vector<std::uint8_t> data(static_cast<std::size_t>(st.st_size));
  std::size_t got = 0;
  while (got < data.size()) {
    const ssize_t r = ::read(f.fd, data.data() + got, data.size() - got);
    if (r < 0 && errno == EINTR) continue;
    if (r < 0) throw std::runtime_error(io_error("read the " + what, path, errno));
    if (r == 0) break;
    got += static_cast<std::size_t>(r);
  }
  data.resize(got);
  return data;
}

void create_private_file(const std::string& path, const std::vector<std::uint8_t>& data) {
  Fd f{::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0600)};
  if (f.fd < 0) throw std::runtime_error(io_error("create", path, errno));
  if (const int err = write_all(f.fd, reinterpret_cast<const char*>(data.data()), data.size()))
    throw std::runtime_error(io_error("write", path, err));
  if (::fsync(f.fd) != 0) throw std::runtime_error(io_error("write", path, errno));
}

void check_own_directory(const std::string& path, const std::string& what) {
  struct stat st {};
  if (::lstat(path.c_str(), &st) != 0) throw std::runtime_error(io_error("use the " + what, path, errno));
  if (S_ISLNK(st.st_mode)) throw std::runtime_error(fmt::format("{} {} is a symbolic link: refusing it", what, path));
  if (!S_ISDIR(st.st_mode)) throw std::runtime_error(fmt::format("{} {} is not a directory", what, path));
  if (st.st_uid != ::geteuid())
    throw std::runtime_error(fmt::format("{} {} belongs to uid {}, not to this user (uid {}): refusing it", what, path,
                                         st.st_uid, ::geteuid()));
  if ((st.st_mode & 022) != 0)
    throw std::runtime_error(
        fmt::format("{} {} has mode {}, writable by others: refusing it", what, path, mode_text(st.st_mode)));
}

void write_file_atomically(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".tmp";
  ::unlink(tmp.c_str());  // what an earlier failure left
  {
    Fd f{::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0600)};
    if (f.fd < 0) throw std::runtime_error(io_error("write", path, errno));
    int err = write_all(f.fd, text.data(), text.size());
    if (!err && ::fsync(f.fd) != 0) err = errno;
    if (err) {
      ::unlink(tmp.c_str());
      throw std::runtime_error(io_error("write", path, err));
    }
  }
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    throw std::runtime_error(io_error("write", path, err));
  }
  const std::string dir = std::filesystem::path(path).parent_path().string();
  Fd d{::open(dir.empty() ? "." : dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC)};
  if (d.fd >= 0) ::fsync(d.fd);
}

std::uintmax_t free_bytes(const std::string& path) {
  struct statvfs s {};
  if (::statvfs(path.c_str(), &s) != 0) throw std::runtime_error(io_error("look at", path, errno));
  return static_cast<std::uintmax_t>(s.f_bavail) * s.f_frsize;
}

AppendFile::AppendFile(const std::string& path, bool fresh, const std::string& header) : path_(path) {
  fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_NOFOLLOW | O_CLOEXEC | (fresh ? O_TRUNC : 0), 0600);
  if (fd_ < 0) throw std::runtime_error(io_error("open", path, errno));
  if (fresh) append(header);
}

AppendFile::AppendFile(AppendFile&& o) noexcept : fd_(std::exchange(o.fd_, -1)), path_(std::move(o.path_)) {}

AppendFile& AppendFile::operator=(AppendFile&& o) noexcept {
  if (this != &o) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = std::exchange(o.fd_, -1);
    path_ = std::move(o.path_);
  }
  return *this;
}

AppendFile::~AppendFile() {
  if (fd_ >= 0) ::close(fd_);
}

void AppendFile::append(const std::string& lines) {
  if (lines.empty()) return;
  const off_t before = ::lseek(fd_, 0, SEEK_END);
  if (const int err = write_all(fd_, lines.data(), lines.size())) {
    // The rows written in part go (best effort: the disk that failed the write may fail this too).
    [[maybe_unused]] const int cut = before >= 0 ? ::ftruncate(fd_, before) : 0;
    throw std::runtime_error(io_error("write", path_, err));
  }
}

std::string sha256_file(const std::string& path) {
  Fd f{::open(path.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC)};
  if (f.fd < 0) throw std::runtime_error(io_error("read", path, errno));
  std::unique_ptr<EVP_MD_CTX, decltype(&EVP_MD_CTX_free)> ctx(EVP_MD_CTX_new(), EVP_MD_CTX_free);
  if (!ctx || !EVP_DigestInit_ex(ctx.get(), EVP_sha256(), nullptr)) throw std::runtime_error("SHA-256 unavailable");
  std::array<char, 1 << 16> buf;
  for (;;) {
    const ssize_t r = ::read(f.fd, buf.data(), buf.size());
    if (r < 0 && errno == EINTR) continue;
    if (r < 0) throw std::runtime_error(io_error("read", path, errno));
    if (r == 0) break;
    EVP_DigestUpdate(ctx.get(), buf.data(), static_cast<std::size_t>(r));
  }
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned int n = 0;
  EVP_DigestFinal_ex(ctx.get(), md, &n);
  return hex(md, n);
}

std::string sha256_text(const std::string& text) {
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned int n = 0;
  if (EVP_Digest(text.data(), text.size(), md, &n, EVP_sha256(), nullptr) != 1)
    throw std::runtime_error("SHA-256 unavailable");
  return hex(md, n);
}

std::string hmac_hex(const std::vector<std::uint8_t>& key, const std::string& text) {
  unsigned char md[EVP_MAX_MD_SIZE];
  std::size_t n = 0;
  if (!EVP_Q_mac(nullptr, "HMAC", nullptr, "SHA256", nullptr, key.data(), key.size(),
                 reinterpret_cast<const unsigned char*>(text.data()), text.size(), md, sizeof md, &n))
    throw std::runtime_error("HMAC-SHA256 unavailable");
  return hex(md, n);
}

}  // namespace hemo
