// Files of a run directory that must stay the user's own and whole through crashes and full
// disks: the secret (read and created only as a private regular file), the run directory
// itself (the user's, writable by no one else), files replaced atomically (temp, fsync,
// rename) and rows appended whole. Errors are one line and name the cause ("no space left on
// device"). docs/architecture.md "Run state".
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace hemo {

// "cannot <doing> <path>: <strerror(err)>", e.g. "cannot write run.toml: No space left on device".
std::string io_error(const std::string& doing, const std::string& path, int err);

// Reads a file that must be a regular file (not a symlink) owned by this user and readable by
// no one else (mode 0600 or 0400); throws a one-line reason otherwise. `what` names it.
std::vector<std::uint8_t> read_private_file(const std::string& path, const std::string& what);

// Creates `path` as a new private file (O_CREAT | O_EXCL | O_NOFOLLOW, mode 0600: never a moment
// when another user may open it) holding `data`; refuses an existing file or symlink.
void create_private_file(const std::string& path, const std::vector<std::uint8_t>& data);

// Throws a one-line reason unless `path` is a directory (not a symlink) owned by this user and
// writable by no one else.
void check_own_directory(const std::string& path, const std::string& what);

// Replaces `path` with `text` so that a reader, a crash or a full disk leaves either the old
// file or the new one, never a truncated one: written to a temp file beside it, fsynced,
// renamed over it, the directory fsynced. The new file is private (0600).
void write_file_atomically(const std::string& path, const std::string& text);

// Bytes free to this user on the file system holding `path`.
std::uintmax_t free_bytes(const std::string& path);

// A file that rows are appended to whole: each append is one write of complete lines, and a
// write the disk could not take whole is cut back off, so that the file never ends in half a
// row. Throws io_error (ENOSPC named) when it fails.
class AppendFile {
 public:
  AppendFile() = default;
  // Opens `path` for appending; `fresh`: a new file holding `header` only.
  AppendFile(const std::string& path, bool fresh, const std::string& header);
  AppendFile(const AppendFile&) = delete;
  AppendFile& operator=(const AppendFile&) = delete;
  AppendFile(AppendFile&& o) noexcept;
  AppendFile& operator=(AppendFile&& o) noexcept;
  ~AppendFile();
  void append(const std::string& lines);
  bool is_open() const { return fd_ >= 0; }

 private:
  int fd_ = -1;
  std::string path_;
};

// SHA-256 of a file's bytes, in hex.
std::string sha256_file(const std::string& path);
// The SHA-256 of `text`, as lowercase hex.
std::string sha256_text(const std::string& text);
// HMAC-SHA256 of `text` under `key`, in hex.
std::string hmac_hex(const std::vector<std::uint8_t>& key, const std::string& text);

}  // namespace hemo
