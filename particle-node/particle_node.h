// The particle node's work per coupling step, in the order main.cpp calls it:
//
//   ParticleNode node(scene, mesh, run_dir)   locator, DEM setup, placement, step-0 state
//   node.feedback()                           per-cell phi, sources, drag coefficient
//   node.check(fluid)                         the fluid state fits the mesh and is finite
//   node.advance(order, fluid)                N DEM substeps in that flow, deposition
//   node.write_output(step, time)             a particle snapshot
//   node.write_checkpoint()                   the whole state, RUN_DIR/checkpoints/step-<k>/particles
//   node.diagnostics()                        what the coordinator shows and the tests check
//
// A node constructed with resume_step = K > 0 starts from the checkpoint of step K instead of
// placing particles: at step K, time K * interval, feedback and DEM exactly as the node that
// wrote it had them, so that it goes on bit for bit as that node did.
//
// The checkpoint folder (common/checkpoint.h): node.h5 (this class: step, time, interval,
// warnings given, the interval's deposition and the fluid state it was computed in, the mesh
// hash and rank count it fits), engine-rank<r>.h5 per MPI rank (engine_state.h) and, in a
// partitioned exchange, deposition-rank<r>.h5 (each rank's own deposition of its cells; node.h5
// holds their sum).
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "cell_locator.h"
#include "dem_engine.h"
#include "dem_timing.h"
#include "deposition.h"
#include "fluid_sampler.h"
#include "h5_output.h"

#include <mpi.h>
#include <node_port.h>
#include <overlap_map.h>
#include <scene.h>

#include <array>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace hemo::particles {

// Why a node cannot resume (no checkpoint, a damaged one, one of another mesh or rank count):
// thrown alike on every rank, before anything in the run directory was changed.
class CheckpointError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class ParticleNode {
 public:
  // Builds everything for step 0: the locator on the fluid's mesh, LIGGGHTS with the scene's
  // particles placed at random (seeded), their volumes deposited, snapshot 0 written.
  // With resume_step K > 0: everything as at the end of step K from the run directory's
  // checkpoint of step K, particles.h5 cut back to the snapshots of steps <= K, no snapshot
  // written, the LIGGGHTS log appended to; throws CheckpointError when that is not possible.
  // Throws std::exception with a one-line reason when the scene and mesh do not fit together.
  ParticleNode(const Scene& scene, const mesh_t& mesh, const std::string& run_dir, MPI_Comm comm, long resume_step = 0);

  // This rank's box and margin (DemEngine::sub_domain, exchange_margin), for the overlap map; the
  // margin widened by how far a solid-fraction kernel reaches beyond the particles' spheres.
  Box sub_domain() const;
  double exchange_margin() const;
  // The partitioned exchange's map (RankedPort::start_exchange): this rank holds the fluid state
  // of its needed(p) cells only, deposits into those only (checked every step), and its
  // feedback is its own particles' partial sums, which the fluid adds up. Its share of a
  // checkpoint's fluid state comes from the cells it is the lowest rank to hold, and so does
  // each cell's deposition summed so far (placed or resumed). Collective.
  void use_overlap(const OverlapMap& map);
  // dem.load_balance, between two steps: whether the ranks' slabs moved (DemEngine::balance;
  // the same on every rank). Collective.
  bool balance();
  // After the slabs moved: the map of the new boxes from the next step on (held and halo cells),
  // and the particles deposited again on their new ranks, so that what the next interval reads
  // of the cells' solid volume (summed with the ranks now sharing them) is of the new map.
  // Collective.
  void follow_overlap(const OverlapMap& map);
  // The ranks' particle counts, the largest over the mean (collective).
  double particle_imbalance() const { return engine_->particle_imbalance(); }

  // "" when the fluid state can be used, else why not (size, mesh hash, non-finite value).
  std::string check(const fluid_state_t& fluid) const;

  // Runs the DEM over one coupling interval in `fluid`; "" or a one-line error naming the
  // particle and the step.
  std::string advance(const step_order_t& order, const fluid_state_t& fluid);

  // The feedback of the last interval (step 0: volumes only, no forces yet); partitioned, this
  // rank's partial sums (its own particles'), whole-mesh arrays zero outside its cells.
  particle_feedback_t feedback();

  void write_output(long step, double time_s);
  // The whole state as the checkpoint of step(), collective; acknowledged by the next
  // diagnostics (hemo::kCheckpointDiagnostic = step()).
  void write_checkpoint();
  Diagnostics diagnostics();

  long step() const { return step_; }
  // How many "outside the drag law's range" warnings were given (at most one per species).
  int reynolds_warnings() const { return warned_re_[0] + warned_re_[1]; }
  double time() const { return time_; }

 private:
  struct NodeCheckpoint;
  // The cells of the map this rank holds (needed(p)) and speaks for (the lowest rank holding it).
  void hold(const OverlapMap& map);
  // The constructor's steps, in order (start or resume).
  void find_used_species();
  void start();
  void resume(long step);
  void log_particles() const;
  NodeCheckpoint read_checkpoint(long step) const;
  // The DEM's state in a checkpoint folder written on `written_on` ranks: this rank's, or, on
  // another rank count, all of them merged.
  EngineState read_engine_state_for(const std::string& folder, long written_on) const;
  void check_fits(const NodeCheckpoint& saved, long step, const std::string& path) const;
  // The fluid state's fields as node.h5 keeps them: velocity, gradient, pressure gradient,
  // viscous force, whole-mesh on rank 0 (summed from the ranks' own cells); collective.
  std::array<std::vector<double>, 4> whole_fluid_fields();
  // `deposition`: the node's, summed over the ranks (Deposition::data's layout).
  void write_node_checkpoint(const std::string& path, const std::array<std::vector<double>, 4>& fluid,
                             const std::vector<double>& deposition);
  // "" when this rank deposited into none but its held cells, else one line naming the cell.
  std::string deposited_outside_held() const;
  // Partitioned: this rank's own deposition of its held cells, in a checkpoint folder, and its
  // reading at a resume on the same rank counts (false, on every rank, when any rank cannot).
  void write_own_deposition(const std::string& path) const;
  bool take_own_deposition();
  void set_interval(double interval);
  void warn_reynolds();

  // Wall seconds of this rank since the last diagnostics, per phase (the coordinator's profile).
  struct PhaseSeconds {
    double dem = 0;           // LIGGGHTS's step: integration, neighbour lists, contacts, MPI
    double fluid_forces = 0;  // in the DEM step: location, plasma sampling, closures
    double deposition = 0;    // impulses and volumes to cells, the feedback message's fields
    double output = 0;
    double checkpoint = 0;
  };

  Scene scene_;
  std::string mesh_hash_;
  MPI_Comm comm_;
  int rank_ = 0;
  CellLocator locator_;
  FluidSampler fluid_;
  Deposition deposition_;
  std::unique_ptr<DemEngine> engine_;
  std::unique_ptr<H5Output> output_;
  // A resumed node opens particles.h5 at its first snapshot, once the coordinator has heard both
  // nodes start (a resume that fails at start-up, on a full disk say, leaves the file untouched);
  // snapshots after this step are dropped then. -1: not resumed.
  long output_resumes_after_ = -1;
  DemTiming timing_;
  double timing_interval_ = 0;  // the coupling interval timing_ was derived for
  double interval_ = 0;         // of the last advance (0 before the first)
  long step_ = 0;
  double time_ = 0;
  std::string run_dir_;
  bool used_[kSpeciesCount] = {false, false};
  bool warned_re_[kSpeciesCount] = {false, false};
  PhaseSeconds phase_;
  long checkpoint_written_ = -1;  // since the last diagnostics (-1: none)
  // The partitioned exchange's, per cell (empty: not partitioned): this rank holds its fluid
  // state (needed(p)), and it is the lowest rank to.
  std::vector<char> held_, designated_;
  // The checkpoint folder this node resumed from and the ranks that wrote it (none: not resumed).
  std::pair<std::string, long> resumed_from_{"", 0};
};

}  // namespace hemo::particles
