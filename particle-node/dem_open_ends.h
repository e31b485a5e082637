// An open vessel's ends in the DEM: cells leave through the outlet, and enter through the inlet as
// copies of the cells that cross the end of a periodic feeder tube beside the vessel (the practice
// of resolved blood-flow codes: the inflow carries a developed suspension, its cell-free layer
// and its orientations). A LIGGGHTS fix of ours, `hemo/open_ends` (docs/design.md, "Open ends").
//
// The box. LIGGGHTS has one box, periodic along z with period P; the vessel occupies
// z in [zlo, outlet_z] (outlet_z = zlo + its length) at x < split_x, the feeder the whole period
// at x >= split_x, its axis shift_x from the vessel's. P exceeds the vessel's length by a gap
// that holds the cells straddling the outlets and the inlet (below) and a pair's reach plus the
// neighbour skin between them, so no cell leaving at the outlet sees, through the periodic
// images, one entering at the inlet.
//
// The outlets. Each is a plane through its cap's centre c with the outward normal n: a vessel atom
// at x is past it when n . (x - c) >= 0 (the straight vessel's one outlet: z >= outlet_z). A
// vessel with several (a bifurcation's daughters) has them apart: no vessel point is past one
// outlet's plane but through another's cap.
//
// A cell crosses an end over several steps, as its volume does (docs/design.md, "Open ends"):
// it stays in the DEM while any of it can reach the vessel's fluid cells, and the particle node
// deposits only the share of it on the inside of the end's plane (particle-node/deposition.h).
// REACH, per radius, is how far that is: 1 for a sphere's volume, the kernel's reach for a
// Gaussian solid fraction (model/solid_fraction_names.h); 0 hands a cell over the step its centre
// crosses. So
//   - a vessel atom leaves the DEM once its centre is past an outlet plane (or, backwards, before
//     the inlet) by REACH radii, and
//   - a feeder atom whose leading edge (centre + REACH radii) reaches the feeder's end gets a copy
//     at (x - shift_x, y, z - P), its centre before the inlet by as much as the source's is short
//     of the end: the copy replays its source (its position, velocity and replayed values) while it
//     straddles the inlet and over the inlet buffer after, so its inside share grows from 0 as the
//     source moves on. A copy whose source draws back out of reach is removed.
// LIGGGHTS wraps z into the box, so a vessel atom before the inlet sits at the box's top, above
// the vessel (TOP, its highest z): one period down in the vessel's frame (place()). The gap
// between TOP and the box's top holds both the cells leaving past the outlets and those entering,
// and a pair's reach between them (the session refuses a feeder too short for it).
//
// Counting: by centres. A cell is in the vessel while its centre is inside every end's plane; its
// centre crossing an end's plane counts: inward at the inlet as inserted, outward at the inlet as
// left through the inlet, outward at outlet o as left through it, back inward at outlet o as minus
// one of those (so each count is the net number of centres through that plane, what the flux
// observables read). Present in the vessel = created there + inserted - left, at every step; the
// atoms whose centres are past an end (straddling, still in the DEM) are counted apart
// (straddling()). Each DEM step, after the positions moved and before LIGGGHTS decides on a list
// build (post_integrate), every atom's crossing is counted (one reduction over the ranks), and the
// fix asks for a build in the same step when an atom is to leave the DEM or a copy to be made, so
// that no force of that step sees it. At every build, before LIGGGHTS wraps and migrates the
// atoms (pre_exchange), it
//   - removes each vessel atom past an end by REACH radii, and
//   - inserts, for each feeder atom in reach of the end without a copy, its copy: the same type,
//     size, mass, velocity, angular velocity and the values of the per-atom fixes it is told to
//     copy (orientation, impulse, held closures); no contact history (its contacts start afresh,
//     as between a cell and a wall the first time it touches one).
// The copies get the smallest tags free (a removed atom's tag is free again), in the order of
// their sources' tags, so tags stay in 1..capacity, the insertions are the same whatever the
// number of ranks, and per-tag arrays keep their size. The decision and the tags are agreed over
// the ranks (one reduction a step, one gather of the hand-overs at each list build).
//
// The inlet buffer. A copy enters at the inlet plane, where the vessel's cells ahead of it have
// moved on since their own sources, beside it in the feeder, pushed them: left free, a copy can
// land on a cell ahead (overlaps of 10 % of a diameter were measured) and be thrown back through
// the inlet. So over the vessel's first BUFFER of length (one largest cell diameter) each copy
// replays its source: its position (shifted by -shift_x in x, at the same z) and velocity are its
// source's at every step, the inflow the feeder's developed suspension exactly, until the source
// passes the buffer's end; from then on the copy moves freely. The vessel's initial cells in the
// buffer that are copies of feeder cells (placement puts them there: model/placement.h) replay
// theirs too: a run's set-up links each vessel atom in the buffer to the feeder atom at its
// position shifted by shift_x, if any (which also finds a checkpoint's links again). A replayed
// copy is a moving boundary to the cells beyond it: their contacts and the fluid push on it
// without moving it, as on the feeder's cells.
//
// Counts per atom type: inserted, left through each outlet, left through the inlet (above). A
// listener sees each build's events, the same on every rank, in the order: removals from the DEM
// (by tag; the kind says beyond which end), insertions (by new tag).
//
// Order among fixes: LIGGGHTS's pair contact history, made at its first set-up (after this fix),
// moves its lists' histories onto the atoms in its own pre_exchange, by the lists' atom indices.
// So no atom changes its index here: copies are appended (LIGGGHTS's own insertions do the same),
// and a leaving atom is put beyond the box across x, where LIGGGHTS's exchange drops it right after
// (the box is not periodic across x and has one rank across it).
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "open_ends_events.h"

#include <fix.h>

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace hemo::particles::dem {

constexpr const char* kOpenEndsFix = "hemo_open_ends";
constexpr const char* kOpenEndsStyle = "hemo/open_ends";

struct OpenEndsLayout {
  struct Outlet {
    std::array<double, 3> centre{}, normal{};  // m; unit, out of the vessel
    // m: past the outlet the vessel goes on as a tube of this radius about the normal through the
    // centre, which holds the cells straddling it (0: nothing holds them)
    double radius = 0;
  };
  std::vector<Outlet> outlets;  // the vessel's (its inlet is the box's lower z bound)
  double split_x = 0;           // m, atoms at x >= split_x are the feeder's
  double shift_x = 0;           // m, the feeder's axis from the vessel's inlet centre, along x
  double buffer = 0;            // m, the inlet buffer's length (0: none)
  double reach = 0;             // per radius: how far past an end's plane a centre leaves the DEM (above)
  double top = 0;               // m, the vessel's highest z (at least its outlets' highest centre)
};

class FixOpenEnds : public LAMMPS_NS::Fix {
 public:
  // fix ID all hemo/open_ends SPLIT_X SHIFT_X BUFFER REACH TOP N (CX CY CZ NX NY NZ R) x N
  FixOpenEnds(LAMMPS_NS::LAMMPS* lmp, int narg, char** arg);
  ~FixOpenEnds() override;

  int setmask() override;
  void post_integrate() override;
  // A run's set-up: which tags are free, from the atoms as they are; the inlet buffer's links;
  // then any crossing.
  void setup_pre_exchange() override {
    find_free_tags();
    find_links();
    find_places();
    hand_over();
  }
  void pre_exchange() override { hand_over(); }
  // A new run's first hand-over, before its first step: the feeder's cells in reach of its end at
  // the start get their copies now, so that the first deposition has their shares (a restored
  // run's copies are in its checkpoint). Made at the first step instead, their shares all came at
  // once and pushed the plasma aside (Courant 1.23 at step 2 of scenes/bifurcation-30.toml, 80:20).
  void start() {
    find_free_tags();
    find_links();
    hand_over();
  }
  // A step's last word on the buffer's copies: their velocities are their sources' (the final
  // half kick gave each its own).
  void end_of_step() override { replay_sources(); }

  // Counts since the run started, per atom type (index 0 unused), the same on every rank.
  using Counts = OpenEndsCounts;
  const Counts& counts() const { return counts_; }
  // Atoms whose centres are past an end, still in the DEM (the same on every rank).
  long straddling() const { return straddling_; }

  // Where an atom's centre is against the vessel's ends. A feeder atom: end kNone, beyond -inf. A
  // vessel atom: the end whose plane it is furthest past (or least inside), the centre's signed
  // distance past it (m; < 0 inside), that plane's outward unit normal, and the centre in the
  // vessel's frame (z wrapped into the box, and one period down when before the inlet).
  static constexpr int kNone = -3, kInlet = -1, kOutlet = 0;  // an end: kInlet, or kOutlet + its index
  struct Place {
    int end = kNone;
    double beyond = -1e300;
    double normal[3] = {0, 0, 0};
    double centre[3] = {0, 0, 0};
    // A point of the end's plane inside the vessel: an outlet's centre; for the inlet, the point
    // of its plane beside the centre (a copy straddling it replays a source inside the feeder).
    double inside[3] = {0, 0, 0};
  };
  Place place(const double* x) const;
  // Whether a vessel atom's centre is past that end (on the inlet's plane counts as inside).
  static bool outside(const Place& p) { return p.end != kNone && (p.end == kInlet ? p.beyond > 0 : p.beyond >= 0); }
  double reach() const { return layout_.reach; }

  // Tags in use are within 1..capacity (the largest tag ever given); the free ones are reused.
  long tag_capacity() const { return capacity_; }

  using State = OpenEndsState;
  State state() const { return {counts_, capacity_}; }
  // Before the set-up of the restored atoms; throws std::invalid_argument when the counts are not
  // per type of this box.
  void restore(const State& state);

  // Per-atom fixes (fix property/atom) whose values an inserted copy takes from its source, and
  // of those, the ones it goes on taking from it every step while it replays it in the buffer.
  void copy_values_of(std::vector<LAMMPS_NS::Fix*> fixes, std::vector<LAMMPS_NS::Fix*> replayed) {
    copied_ = std::move(fixes);
    replayed_ = std::move(replayed);
  }
  // Called at each build that moved any atom, with its events (on every rank).
  void on_events(std::function<void(const std::vector<OpenEndsEvent>&)> listener) { listener_ = std::move(listener); }

  // The feeder atom a vessel atom in the inlet buffer replays (its tag; 0: none), by local index.
  int source_of(int i) const { return source_[i]; }

  // Per-atom storage of the links (LAMMPS's per-atom fix protocol: they move with the atoms).
  void grow_arrays(int nmax) override;
  void copy_arrays(int i, int j, int delflag) override;
  void set_arrays(int i) override { source_[i] = 0, phase_[i] = kNone; }
  int pack_exchange(int i, double* buf) override;
  int unpack_exchange(int nlocal, double* buf) override;
  double memory_usage() override;

 private:
  static constexpr int kFeederEnd = -2;
  // The phase of a vessel atom at `p`: the end its centre is past, or kNone (inside); kNone for a
  // feeder atom.
  static int phase(const Place& p) { return outside(p) ? p.end : kNone; }
  // Whether feeder atom i is in reach of the feeder's end (its copy due, if it has none).
  bool in_reach_of_end(int i) const;
  // The tags of the feeder atoms this rank's vessel atoms replay.
  std::vector<int> linked_sources() const;
  // Counts a centre's crossing from phase `from` to `to` (of atom type `type`) into `delta`
  // (straddling, inserted, left_inlet, left_outlet per outlet, each per type).
  void count_crossing(int from, int to, int type, std::vector<std::int64_t>& delta) const;
  void apply(const std::vector<std::int64_t>& delta);
  // Every atom's phase from its position, and the straddling count; `count`: as crossings from
  // inside (the atoms as made), else none counted (a set-up of atoms already counted).
  void find_places(bool count = false);
  void hand_over();
  void find_free_tags();
  int take_free_tag();
  // Appends the copy of feeder atom `source` with this tag; returns its z.
  double insert_copy(int source, int tag);
  void find_links();
  // Past an outlet no wall of the vessel's holds a straddling cell: the tube of the outlet's radius
  // does, its centre kept a radius inside it and its velocity out of it taken away (a wall without
  // friction or rebound; the vessel goes on past its outlet, as the outlet's zero gradient says).
  void hold_past_outlets();
  // The inlet buffer: each linked copy takes its source's position and velocity, or is let go
  // (after the positions moved, and at the step's end).
  void replay_sources();

  OpenEndsLayout layout_;
  Counts counts_;
  long straddling_ = 0;
  double before_inlet_from_ = 0;  // m: a vessel atom at this z or above (wrapped) is before the inlet
  long capacity_ = 0;
  std::vector<int> free_;  // free tags, largest first (the smallest is taken from the back)
  std::vector<LAMMPS_NS::Fix*> copied_, replayed_;
  static void copy_values(const std::vector<LAMMPS_NS::Fix*>& fixes, int from, int to);
  int* source_ = nullptr;  // per local atom: the source tag it replays (0: none)
  int* phase_ = nullptr;   // per local atom: phase() when last counted
  std::function<void(const std::vector<OpenEndsEvent>&)> listener_;
};

// The command that defines the fix.
std::string open_ends_command(const OpenEndsLayout& layout);

// Makes the style known to a LIGGGHTS instance (dem_fix_styles.cpp).
LAMMPS_NS::Fix* create_open_ends(LAMMPS_NS::LAMMPS* lmp, int narg, char** arg);

}  // namespace hemo::particles::dem
