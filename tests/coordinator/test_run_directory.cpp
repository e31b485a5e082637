// The run directory's state (coordinator/run_directory.h, common/run_files.h) as plain
// functions: the secret and the directory refused unless the user's own and private, the lock,
// the signature of the nodes' commands, the checkpoint's SHA-256 seal, metrics.csv's remains of
// a crash skipped. The runs themselves: tests/integration/test_checkpoint.cpp ("RunState").
// SPDX-License-Identifier: GPL-3.0-or-later
#include "run_directory.h"
#include "run_files.h"

#include "checkpoint.h"

#include <gtest/gtest.h>

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <string>

namespace fs = std::filesystem;
using namespace hemo;

namespace {

class RunDirectoryTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char root[] = "/tmp/hemo_rundir_XXXXXX";
    ASSERT_NE(mkdtemp(root), nullptr);
    root_ = root;
    scene_file_ = root_ + "/scene.toml";
    std::ofstream(scene_file_) << "[run]\nname = \"x\"\n";
  }
  void TearDown() override {
    std::error_code ec;
    fs::permissions(root_, fs::perms::owner_all, ec);
    fs::remove_all(root_, ec);
  }
  std::string root_, scene_file_;
};

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

mode_t mode_of(const std::string& path) {
  struct stat st {};
  ::lstat(path.c_str(), &st);
  return st.st_mode & 07777;
}

}  // namespace

// Created private in one step: the directory 0700 and the secret 0600 whatever the umask, and
// the secret 32 bytes that differ from run to run.
TEST_F(RunDirectoryTest, ARunDirectoryAndItsSecretAreTheUsersOnly) {
  const mode_t before = ::umask(0);  // the most open umask there is
  auto [a, ctx_a] = RunDirectory::create(root_ + "/a", scene_file_);
  auto [b, ctx_b] = RunDirectory::create(root_ + "/b", scene_file_);
  ::umask(before);
  EXPECT_EQ(mode_of(a.path), 0700u);
  EXPECT_EQ(mode_of(a.secret_file()), 0600u);
  EXPECT_EQ(ctx_a.secret.size(), 32u);
  EXPECT_NE(ctx_a.secret, ctx_b.secret);
  EXPECT_NE(ctx_a.run_id, ctx_b.run_id);
  EXPECT_EQ(RunDirectory::open(a.path).second.secret, ctx_a.secret);
}

TEST_F(RunDirectoryTest, ASecretOpenToOthersOrASymlinkIsRefused) {
  auto [dir, ctx] = RunDirectory::create(root_ + "/run", scene_file_);
  fs::permissions(dir.secret_file(), fs::perms::group_read | fs::perms::others_read, fs::perm_options::add);
  EXPECT_NE(error_of([&] { RunDirectory::open(dir.path); }).find("has mode 0644, open to others"), std::string::npos);

  // A symlink to a file of the right mode (another user's, say): refused as a link.
  const std::string elsewhere = root_ + "/elsewhere";
  create_private_file(elsewhere, ctx.secret);
  fs::remove(dir.secret_file());
  fs::create_symlink(elsewhere, dir.secret_file());
  EXPECT_NE(error_of([&] { RunDirectory::open(dir.path); }).find("is a symbolic link"), std::string::npos);

  // create_private_file never follows one either.
  EXPECT_NE(error_of([&] { create_private_file(dir.secret_file(), ctx.secret); }).find("cannot create"),
            std::string::npos);
}

// Another user's directory (root may chown one to nobody) or one others may write: refused as
// --out and as a run to resume.
TEST_F(RunDirectoryTest, ARunDirectoryOthersMayWriteIsRefused) {
  const std::string shared = root_ + "/shared";
  fs::create_directory(shared);
  fs::permissions(shared, fs::perms::owner_all | fs::perms::group_all, fs::perm_options::replace);
  EXPECT_NE(error_of([&] { RunDirectory::create(shared, scene_file_); }).find("writable by others"), std::string::npos);
  EXPECT_TRUE(fs::is_empty(shared)) << "nothing written into it";

  auto [dir, ctx] = RunDirectory::create(root_ + "/run", scene_file_);
  fs::permissions(dir.path, fs::perms::others_write, fs::perm_options::add);
  EXPECT_NE(error_of([&] { RunDirectory::open(dir.path); }).find("writable by others"), std::string::npos);

  if (::geteuid() != 0) GTEST_SKIP() << "giving a directory to another user needs root";
  const std::string theirs = root_ + "/theirs";
  fs::create_directory(theirs);
  ASSERT_EQ(::chown(theirs.c_str(), 65534, 65534), 0);
  EXPECT_NE(error_of([&] { RunDirectory::create(theirs, scene_file_); }).find("belongs to uid 65534"),
            std::string::npos);
}

TEST_F(RunDirectoryTest, TheLockIsHeldOnceAndReleasedWithItsHolder) {
  auto [dir, ctx] = RunDirectory::create(root_ + "/run", scene_file_);
  EXPECT_FALSE(RunLock::held(dir.path));
  {
    const RunLock lock(dir.path);
    EXPECT_TRUE(RunLock::held(dir.path));
    EXPECT_NE(error_of([&] { RunLock again(dir.path); }).find("another hemocosim coordinator runs it"),
              std::string::npos);
  }
  EXPECT_FALSE(RunLock::held(dir.path));
}

// A command the coordinator recorded (the scene's at `run`, a swap's) is signed with the run's
// secret; one written into run.toml or the scene copy by anything else is not.
TEST_F(RunDirectoryTest, OnlyCommandsTheRunRecordedAreSigned) {
  auto [dir, ctx] = RunDirectory::create(root_ + "/run", scene_file_);
  Scene scene;
  EXPECT_TRUE(dir.commands_signed(ctx, scene)) << "the built-in nodes need no signature";
  scene.run.particle_command = "/opt/evil.sh";
  EXPECT_FALSE(dir.commands_signed(ctx, scene));
  dir.sign_commands(ctx, scene);
  EXPECT_TRUE(dir.commands_signed(ctx, scene));
  scene.run.particle_command = "/opt/evil.sh --more";
  EXPECT_FALSE(dir.commands_signed(ctx, scene));
  RunContext other = ctx;
  other.secret[0] ^= 1;
  scene.run.particle_command = "/opt/evil.sh";
  EXPECT_FALSE(dir.commands_signed(other, scene)) << "a signature is of this run's secret";
}

// A checkpoint is one to go on from once sealed, and resume refuses it when one value changed.
TEST_F(RunDirectoryTest, ASealedCheckpointWithOneValueChangedIsRefused) {
  auto [dir, ctx] = RunDirectory::create(root_ + "/run", scene_file_);
  for (const char* role : {"fluid", "particles"}) {
    std::ofstream(begin_checkpoint(dir.path, 4, role) + "/state") << "1.25 2.5 " << role << "\n";
    commit_checkpoint(dir.path, 4, role);
  }
  EXPECT_FALSE(dir.last_checkpoint()) << "acknowledged by both, but not sealed yet";
  dir.seal_checkpoint(4);
  ASSERT_EQ(dir.last_checkpoint(), 4);
  EXPECT_EQ(error_of([&] { dir.verify_checkpoint(4); }), "");

  const std::string state = checkpoint_folder(dir.path, 4) + "/fluid/state";
  std::ofstream(state) << "1.25 2.6 fluid\n";
  EXPECT_NE(error_of([&] { dir.verify_checkpoint(4); }).find("fluid/state was changed"), std::string::npos);
  std::ofstream(state) << "1.25 2.5 fluid\n";
  std::ofstream(checkpoint_folder(dir.path, 4) + "/particles/extra") << "\n";
  EXPECT_NE(error_of([&] { dir.verify_checkpoint(4); }).find("particles/extra was added"), std::string::npos);
}

// A crash or a full disk can leave half a row or NUL bytes in metrics.csv: dropped with a
// warning, the rows of the steps kept as they were.
TEST_F(RunDirectoryTest, MalformedMetricsLinesAreSkipped) {
  auto [dir, ctx] = RunDirectory::create(root_ + "/run", scene_file_);
  {
    std::ofstream out(dir.metrics_file(), std::ios::binary);
    out << "step,time_s,node,name,value\n1,0.1,fluid,u,2\n"
        << std::string(4096, '\0') << "\n2,0.2,fl\n"
        << "3,0.3,fluid,u,4\n99999999999999999999999,0,fluid,u,1\n4,0.4,fluid,u,5\n";
  }
  testing::internal::CaptureStderr();
  dir.drop_metrics_after(3);
  const std::string warning = testing::internal::GetCapturedStderr();
  EXPECT_NE(warning.find("dropped 3 malformed lines"), std::string::npos) << warning;
  std::ifstream in(dir.metrics_file());
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(text, "step,time_s,node,name,value\n1,0.1,fluid,u,2\n3,0.3,fluid,u,4\n");
}

// Rows appended whole; a file replaced atomically is private and complete.
TEST_F(RunDirectoryTest, FilesAreReplacedAtomicallyAndPrivate) {
  const std::string file = root_ + "/info.toml";
  std::ofstream(file) << "old\n";
  write_file_atomically(file, "new\n");
  std::ifstream in(file);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(text, "new\n");
  EXPECT_EQ(mode_of(file), 0600u);
  EXPECT_FALSE(fs::exists(file + ".tmp"));
  EXPECT_NE(io_error("write", file, ENOSPC).find("no space left on device"), std::string::npos);
}
