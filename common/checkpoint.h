// Where a run's checkpoints live, and how a node writes one so that a crash mid-write never
// leaves a checkpoint that looks complete (docs/design.md "Checkpoint, restart, swap").
//
//   RUN_DIR/checkpoints/step-<k>/<role>/   the node's whole state at the end of step k
//
// A node writes into <role>.partial and renames it to <role> when everything is on disk; only
// then does it tell the coordinator (diagnostic "checkpoint_step" = k in its step-done report).
// Once both have, the coordinator seals the step (RUN_DIR/checkpoints/step-<k>/SHA256SUMS, the
// SHA-256 of each file; coordinator/run_directory.h), keeps it and removes older ones.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <fmt/format.h>

#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace hemo {

// The diagnostic with which a node acknowledges checkpoint k.
inline constexpr const char* kCheckpointDiagnostic = "checkpoint_step";
// The coordinator's seal of a step both nodes acknowledged (sha256sum's format).
inline constexpr const char* kCheckpointManifest = "SHA256SUMS";

inline std::string checkpoint_folder(const std::string& run_dir, long step) {
  return fmt::format("{}/checkpoints/step-{}", run_dir, step);
}

// The complete checkpoint of `role` at `step`; throws with a one-line reason when there is none.
inline std::string checkpoint_of(const std::string& run_dir, long step, const std::string& role) {
  const std::string path = checkpoint_folder(run_dir, step) + "/" + role;
  if (!std::filesystem::is_directory(path))
    throw std::runtime_error(fmt::format("no {} checkpoint of step {} in {}", role, step, run_dir));
  return path;
}

// The steps of the run's checkpoint folders, complete or not (RUN_DIR/checkpoints/step-<k>).
inline std::vector<long> checkpoint_steps(const std::string& run_dir) {
  namespace fs = std::filesystem;
  std::vector<long> steps;
  const fs::path root = fs::path(run_dir) / "checkpoints";
  std::error_code ec;
  if (!fs::is_directory(root, ec)) return steps;
  for (const auto& entry : fs::directory_iterator(root, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("step-", 0) != 0 || name.size() == 5) continue;
    if (name.find_first_not_of("0123456789", 5) == std::string::npos) steps.push_back(std::stol(name.substr(5)));
  }
  return steps;
}

// The newest step of which both nodes wrote a complete checkpoint, sealed by the coordinator:
// where a run can resume.
inline std::optional<long> last_complete_checkpoint(const std::string& run_dir) {
  namespace fs = std::filesystem;
  std::optional<long> last;
  for (const long k : checkpoint_steps(run_dir)) {
    const std::string folder = checkpoint_folder(run_dir, k);
    if (fs::is_directory(folder + "/fluid") && fs::is_directory(folder + "/particles") &&
        fs::exists(folder + "/" + kCheckpointManifest) && (!last || k > *last))
      last = k;
  }
  return last;
}

// An empty folder to write `role`'s checkpoint of `step` into (what a failed write left is
// removed first).
inline std::string begin_checkpoint(const std::string& run_dir, long step, const std::string& role) {
  const std::string partial = checkpoint_folder(run_dir, step) + "/" + role + ".partial";
  std::filesystem::remove_all(partial);
  std::filesystem::create_directories(partial);
  return partial;
}

// Makes the checkpoint begun by begin_checkpoint complete (one rename).
inline void commit_checkpoint(const std::string& run_dir, long step, const std::string& role) {
  const std::string folder = checkpoint_folder(run_dir, step);
  std::filesystem::remove_all(folder + "/" + role);
  std::filesystem::rename(folder + "/" + role + ".partial", folder + "/" + role);
}

}  // namespace hemo
