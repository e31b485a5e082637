// SPDX-License-Identifier: GPL-3.0-or-later
// The open vessel's ends in the DEM (particle-node/dem_open_ends.h), in LIGGGHTS itself with no
// fluid: cells streaming along z leave the vessel through its outlet the step they cross it, and
// the feeder's cells that cross its end enter the vessel as copies, with the velocity, place and
// per-atom values of their source, on the tags the leavers freed; present = created + inserted -
// left at every step; with a reach, a cell straddles each end, in the DEM until its centre is that
// far past it, counted as its centre crosses; over the inlet buffer a copy replays its source, so a cell in its way is
// pushed on rather than the copy thrown back through the inlet; on one rank and on two (ctest
// particles.OpenEnds.ranks2: the box split along z, the copies made on the rank of their source and owned by the rank
// of the inlet).
#include "dem_fix_styles.h"
#include "dem_fixes.h"
#include "dem_open_ends.h"

#include <atom.h>
#include <domain.h>
#include <fix_property_atom.h>
#include <input.h>
#include <lammps.h>
#include <modify.h>
#include <mpi.h>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <string>
#include <vector>

using namespace hemo::particles::dem;

namespace {

constexpr double kRadius = 20e-6;       // vessel and feeder
constexpr double kOutlet = 80e-6;       // the vessel over z in [0, 80) um
constexpr double kPeriod = 100e-6;      // the box, and the feeder's length
constexpr double kShift = 3 * kRadius;  // the feeder's axis
constexpr double kDiameter = 5.56e-6;   // a red cell's placeholder sphere
constexpr double kSpeed = 0.5;          // m/s along z: 50 nm a DEM step
constexpr double kDt = 1e-7;

struct Atom {
  int tag, type;
  double x[3], v[3];
  double value;  // the copied per-atom fix's first column
};

class OpenEndsBox {
 public:
  OpenEndsBox() {
    std::vector<std::string> args = {"open-ends", "-screen", "none", "-log", "none"};
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    lmp_ = new LAMMPS_NS::LAMMPS(static_cast<int>(argv.size()), argv.data(), MPI_COMM_WORLD);
    register_fix_styles(*lmp_);
    for (const std::string& line :
         std::vector<std::string>{"units si",
                                  "atom_style granular",
                                  "atom_modify map array",
                                  "boundary f f p",
                                  "newton off",
                                  "communicate single vel yes",
                                  "soft_particles yes",
                                  "processors 1 1 *",
                                  "thermo_modify lost ignore",
                                  fmt::format("region box block {} {} {} {} 0 {} units box", -1.5 * kRadius,
                                              kShift + 1.5 * kRadius, -1.5 * kRadius, 1.5 * kRadius, kPeriod),
                                  "create_box 2 box",
                                  "neighbor 1.4e-6 bin",
                                  "neigh_modify delay 0",
                                  "fix m1 all property/global youngsModulus peratomtype 7.5e5 7.5e5",
                                  "fix m2 all property/global poissonsRatio peratomtype 0.45 0.45",
                                  "fix m3 all property/global coefficientRestitution peratomtypepair 2 0.5 0.5 0.5 0.5",
                                  "fix m4 all property/global coefficientFriction peratomtypepair 2 0.1 0.1 0.1 0.1",
                                  "pair_style gran model hertz tangential history",
                                  "pair_coeff * *",
                                  fmt::format("timestep {}", kDt),
                                  "fix integrate all nve/sphere",
                                  "fix values all property/atom hemoValues vector yes no no 0 0"})
      command(line);
  }
  ~OpenEndsBox() { delete lmp_; }

  void command(const std::string& line) { lmp_->input->one(line.c_str()); }
  void create(int type, double x, double y, double z) {
    command(fmt::format("create_atoms {} single {:.17g} {:.17g} {:.17g} units box", type, x, y, z));
  }
  // Sizes, the common velocity, each atom's own value (its tag), LIGGGHTS's set-up and the fix.
  // The outlets: the plane z = kOutlet unless told.
  void start(double buffer = 0, std::vector<OpenEndsLayout::Outlet> outlets = {{{0, 0, kOutlet}, {0, 0, 1}}},
             double reach = 0) {
    command(fmt::format("set group all diameter {} density 1100", kDiameter));
    command(fmt::format("velocity all set 0 0 {} units box", kSpeed));
    auto* values = static_cast<LAMMPS_NS::FixPropertyAtom*>(fix("values"));
    for (int i = 0; i < lmp_->atom->nlocal; ++i) values->array_atom[i][0] = lmp_->atom->tag[i];
    command("run 0 pre yes post no");  // LIGGGHTS makes its contact history fix (before ours)
    command(open_ends_command({std::move(outlets), 1.5 * kRadius, kShift, buffer, reach}));
    open_ = static_cast<FixOpenEnds*>(fix(kOpenEndsFix));
    open_->copy_values_of({values}, {values});  // a copy takes them, and replays them in the buffer
    open_->on_events([this](const std::vector<OpenEndsEvent>& events) {
      for (const auto& e : events) {
        Atom source{};
        if (e.kind == OpenEndsEvent::Kind::inserted && feeder_atom(e.source_tag, source))
          before_insertion_.push_back(source);
        this->events.push_back(e);
      }
    });
  }
  void step(bool first) { command(fmt::format("run 1 pre {} post no", first ? "yes" : "no")); }

  LAMMPS_NS::Fix* fix(const char* id) const {
    const int i = lmp_->modify->find_fix(id);
    EXPECT_GE(i, 0) << id;
    return lmp_->modify->fix[i];
  }
  // The atoms LIGGGHTS holds now, on every rank, by tag.
  std::map<int, Atom> atoms() const {
    const auto& a = *lmp_->atom;
    auto* values = static_cast<LAMMPS_NS::FixPropertyAtom*>(fix("values"));
    constexpr int kPer = 9;
    std::vector<double> mine;
    for (int i = 0; i < a.nlocal; ++i)
      mine.insert(mine.end(), {double(a.tag[i]), double(a.type[i]), a.x[i][0], a.x[i][1], a.x[i][2], a.v[i][0],
                               a.v[i][1], a.v[i][2], values->array_atom[i][0]});
    const std::vector<double> every = gather_all(mine, MPI_COMM_WORLD);
    std::map<int, Atom> all;
    for (std::size_t k = 0; k < every.size(); k += kPer) {
      const double* r = &every[k];
      Atom at{int(r[0]), int(r[1]), {r[2], r[3], r[4]}, {r[5], r[6], r[7]}, r[8]};
      EXPECT_TRUE(all.emplace(at.tag, at).second) << "tag " << at.tag << " twice";
    }
    return all;
  }
  // The feeder atom of a tag on this rank, while a hand-over is under way (a leaver and a copy may
  // share a tag then); false on the ranks that do not hold it.
  bool feeder_atom(int tag, Atom& out) const {
    const auto& a = *lmp_->atom;
    for (int i = 0; i < a.nlocal; ++i)
      if (a.tag[i] == tag && a.x[i][0] >= 1.5 * kRadius && a.x[i][0] <= lmp_->domain->boxhi[0]) {
        out = {tag, a.type[i], {a.x[i][0], a.x[i][1], a.x[i][2]}, {a.v[i][0], a.v[i][1], a.v[i][2]}, 0};
        return true;
      }
    return false;
  }
  long natoms() const { return static_cast<long>(lmp_->atom->natoms); }
  // Sets the per-atom value of the atom with this tag (on the rank that holds it).
  void set_value(int tag, double value) {
    auto* values = static_cast<LAMMPS_NS::FixPropertyAtom*>(fix("values"));
    for (int i = 0; i < lmp_->atom->nlocal; ++i)
      if (lmp_->atom->tag[i] == tag && lmp_->atom->x[i][0] < 1.5 * kRadius) values->array_atom[i][0] = value;
  }
  const FixOpenEnds& open() const { return *open_; }

  std::vector<OpenEndsEvent> events;
  std::vector<Atom> before_insertion_;  // each insertion's source this rank held, as the listener saw it

 private:
  LAMMPS_NS::LAMMPS* lmp_ = nullptr;
  FixOpenEnds* open_ = nullptr;
};

long sum(const std::vector<std::int64_t>& v) {
  long s = 0;
  for (auto x : v) s += x;
  return s;
}

}  // namespace

TEST(OpenEnds, CellsLeaveAtTheOutletAndEnterAsTheFeedersCopiesAndEveryStepCountsBalance) {
  OpenEndsBox box;
  // The vessel: a column of cells 8 um apart (out of reach of each other), the first to leave at
  // 79 um; the feeder: cells the same, its first to cross the end at 99 um, 1 um after the
  // vessel's first left (20 DEM steps later).
  const int vessel = 9, feeder = 11;
  for (int k = 0; k < vessel; ++k) box.create(1, 0.3 * kRadius, 0, 79e-6 - 8e-6 * k);
  for (int k = 0; k < feeder; ++k) box.create(2, kShift - 0.4 * kRadius, 0.1 * kRadius, 99e-6 - 8e-6 * k);
  box.start();
  const long created = vessel + feeder;
  const int steps = 400;  // 20 um: the first three of each leave or cross, by the positions above
  for (int s = 0; s < steps; ++s) {
    box.step(s == 0);
    const auto& c = box.open().counts();
    const long present = created + sum(c.inserted) - sum(c.left_outlet) - sum(c.left_inlet);
    ASSERT_EQ(box.natoms(), present) << "step " << s;
    const auto atoms = box.atoms();
    ASSERT_EQ(static_cast<long>(atoms.size()), present) << "step " << s;
    for (const auto& [tag, a] : atoms) {
      ASSERT_LE(tag, box.open().tag_capacity());
      if (a.x[0] < 1.5 * kRadius) {
        ASSERT_LT(a.x[2], kOutlet) << "a vessel cell past the outlet at step " << s;
      }
    }
  }
  const auto& c = box.open().counts();
  // The vessel's cells at 79, 71, 63 um move 20 um: three leave; the feeder's at 99, 91, 83 um
  // cross its end, their copies entering at 0..1, 0..9, 0..17 um (none reaches the outlet).
  EXPECT_EQ(c.left_outlet[1], 3);
  EXPECT_EQ(c.left_inlet[1] + c.left_inlet[2] + c.left_outlet[2], 0);
  EXPECT_EQ(c.inserted[2], 3);
  EXPECT_EQ(box.natoms(), created);
  // The copies took the tags the leavers freed, smallest first, in their crossing order.
  std::vector<int> left, inserted;
  for (const auto& e : box.events) (e.kind == OpenEndsEvent::Kind::inserted ? inserted : left).push_back(e.tag);
  ASSERT_EQ(left.size(), 3u);
  ASSERT_EQ(inserted.size(), 3u);
  EXPECT_EQ(std::set<int>(left.begin(), left.end()), std::set<int>(inserted.begin(), inserted.end()));
  EXPECT_EQ(box.open().tag_capacity(), created);
  // Each copy now: where its source was at the hand-over, moved by the feeder's offset and one
  // period, then streamed with it; the same velocity and per-atom value as its source.
  const auto now = box.atoms();
  for (const auto& e : box.events) {
    if (e.kind != OpenEndsEvent::Kind::inserted) continue;
    const Atom& copy = now.at(e.tag);
    const Atom& source = now.at(e.source_tag);
    EXPECT_EQ(copy.type, 2);
    EXPECT_NEAR(copy.x[0], source.x[0] - kShift, 1e-15);
    EXPECT_NEAR(copy.x[1], source.x[1], 1e-15);
    EXPECT_NEAR(copy.x[2], source.x[2], 1e-12);  // the source wrapped by one period, as the copy
    EXPECT_EQ(copy.v[2], source.v[2]);
    EXPECT_EQ(copy.value, source.value);  // the source's tag, its value since the start
    EXPECT_NE(copy.value, copy.tag);
  }
  for (const Atom& source : box.before_insertion_) EXPECT_GE(source.x[2], kPeriod);  // crossed, not yet wrapped
  int seen = static_cast<int>(box.before_insertion_.size());
  MPI_Allreduce(MPI_IN_PLACE, &seen, 1, MPI_INT, MPI_SUM, MPI_COMM_WORLD);
  EXPECT_EQ(seen, 3);  // each source on exactly one rank
}

// Two outlets, as a bifurcation's daughters have: planes through one point on the axis, their
// normals 30 degrees either side of it in the x-z plane. A cell 10 um off the axis towards +x is
// past the first plane from z = 80 - 10 tan 30 = 74.23 um, the second only from 85.77 um, and
// leaves through the first; one towards -x through the second. Each leaver is counted at its own
// outlet, and the counts balance at every step.
TEST(OpenEnds, EachOutletCountsTheCellsThatLeaveThroughIt) {
  OpenEndsBox box;
  const double s = std::sin(30 * M_PI / 180), c = std::cos(30 * M_PI / 180);
  std::map<int, int> side;  // tag: +1 or -1 (its x)
  int tag = 0;
  for (int k = 0; k < 5; ++k)
    for (const int sign : {+1, -1}) {
      box.create(1, sign * 0.5 * kRadius, 0, 76e-6 - 8e-6 * k - (sign > 0 ? 0 : 4e-6));
      side[++tag] = sign;
    }
  box.start(0, {{{0, 0, kOutlet}, {s, 0, c}}, {{0, 0, kOutlet}, {-s, 0, c}}});
  const long created = tag;
  for (int step = 0; step < 300; ++step) {
    box.step(step == 0);
    const auto& counts = box.open().counts();
    ASSERT_EQ(counts.outlets(), 2u);
    ASSERT_EQ(box.natoms(), created - counts.left_outlets(1)) << "step " << step;
  }
  const auto& counts = box.open().counts();
  std::array<int, 2> by_side{};
  for (const auto& e : box.events) {
    ASSERT_EQ(e.kind, OpenEndsEvent::Kind::left_outlet);
    EXPECT_EQ(e.outlet, side.at(e.tag) > 0 ? 0 : 1) << "tag " << e.tag;
    ++by_side[side.at(e.tag) > 0 ? 0 : 1];
  }
  // 15 um in 300 steps: on the +x side the cells from 76, 68 and 60 um pass 74.23 um (the first
  // at the set-up), on the -x side those from 72 and 64 um.
  EXPECT_EQ(counts.left_through(0, 1), 3);
  EXPECT_EQ(counts.left_through(1, 1), 2);
  EXPECT_EQ(by_side[0], 3);
  EXPECT_EQ(by_side[1], 2);
}

// A cell at rest just inside the inlet, where a copy enters overlapping it by a fifth of a
// diameter. With an inlet buffer the copy replays its source, at its position shifted and with its
// velocity, step by step, pushing the cell on, even when stopped by hand; past the buffer's end it
// is let go, and a stop holds it. Without a buffer the same contact throws the copy back out
// through the inlet.
TEST(OpenEnds, OverTheInletBufferACopyReplaysItsSourceAndIsNotThrownBack) {
  for (const double buffer : {kDiameter, 0.0}) {
    OpenEndsBox box;
    box.create(1, 0, 0, 0.8 * kDiameter);                   // tag 1, in the copy's way
    box.create(2, kShift, 0, kPeriod - 10 * kSpeed * kDt);  // crosses the feeder's end at step 10
    box.start(buffer);
    box.command("group still id 1");
    box.command("velocity still set 0 0 0 units box");
    int replayed = 0, stopped_inside = 0, stopped_outside = 0;
    for (int s = 0; s < 200; ++s) {
      box.step(s == 0);
      if (box.events.empty() || box.events.back().kind != OpenEndsEvent::Kind::inserted) continue;
      const OpenEndsEvent e = box.events.back();
      const auto atoms = box.atoms();
      if (!atoms.count(e.tag)) continue;  // thrown back
      const Atom& copy = atoms.at(e.tag);
      const Atom& source = atoms.at(e.source_tag);
      const bool inside = source.x[2] < buffer;
      if (inside) {
        ++replayed;
        ASSERT_NEAR(copy.x[0], source.x[0] - kShift, 1e-15) << "step " << s;
        ASSERT_EQ(copy.x[1], source.x[1]) << "step " << s;
        ASSERT_EQ(copy.x[2], source.x[2]) << "step " << s;
        ASSERT_EQ(copy.v[2], source.v[2]) << "step " << s;
      }
      // Stop the copy by hand, and change its replayed value (as a platelet's spin), once inside
      // the buffer and once past it: the next step tells.
      if ((inside && stopped_inside == 0 && replayed == 20) || (!inside && buffer > 0 && stopped_outside == 0)) {
        box.command(fmt::format("group copy{} id {}", s, e.tag));
        box.command(fmt::format("velocity copy{} set 0 0 0 units box", s));
        box.set_value(e.tag, -1);
        box.step(false);
        const auto after = box.atoms();
        const double lag = after.at(e.source_tag).x[2] - after.at(e.tag).x[2];
        if (inside) {
          stopped_inside = 1;
          EXPECT_EQ(lag, 0.0) << "a copy in the buffer is its source's";
          EXPECT_EQ(after.at(e.tag).value, after.at(e.source_tag).value) << "and so are its replayed values";
        } else {
          stopped_outside = 1;
          EXPECT_GT(lag, 0.9 * kSpeed * kDt) << "a copy past the buffer moves on its own";
          EXPECT_EQ(after.at(e.tag).value, -1) << "and keeps its own values";
        }
      }
    }
    const auto& c = box.open().counts();
    EXPECT_EQ(c.inserted[2], 1) << "buffer " << buffer;
    if (buffer > 0) {
      EXPECT_GT(replayed, 50);  // ~110 steps cross one diameter
      EXPECT_EQ(stopped_inside + stopped_outside, 2);
      EXPECT_EQ(c.left_inlet[2], 0);
      EXPECT_GT(box.atoms().at(1).x[2], 0.8 * kDiameter);  // pushed on
    } else {
      EXPECT_EQ(c.left_inlet[2], 1);  // what the buffer prevents
    }
  }
}

// With a reach (one radius here, a sphere's), a cell straddles each end over the steps its sphere
// crosses it: the vessel's cell is counted out the step its centre passes the outlet and leaves the
// DEM only once its centre is a radius past it; the feeder's cell gets its copy the step its leading
// edge reaches the feeder's end, the copy replaying it from a radius before the inlet, and is
// counted in the step its centre crosses the inlet. LIGGGHTS holds the cells present and those
// straddling at every step.
TEST(OpenEnds, WithAReachACellStraddlesEachEndAndIsCountedAsItsCentreCrosses) {
  OpenEndsBox box;
  const double r = kDiameter / 2, step = kSpeed * kDt;
  box.create(1, 0.3 * kRadius, 0, 79e-6);            // tag 1: its centre passes the outlet at step 20
  box.create(2, kShift - 0.4 * kRadius, 0, 95e-6);   // tag 2: its leading edge reaches the end at step ~44
  box.start(0, {{{0, 0, kOutlet}, {0, 0, 1}}}, 1.0);
  const long created = 2;
  double last_z = 0;
  int copy_seen = 0;
  for (int s = 0; s < 200; ++s) {
    box.step(s == 0);
    const auto& c = box.open().counts();
    const long present = created + sum(c.inserted) - sum(c.left_outlet) - sum(c.left_inlet);
    ASSERT_EQ(box.natoms(), present + box.open().straddling()) << "step " << s;
    const auto atoms = box.atoms();
    long straddling = 0;
    if (atoms.count(1)) {
      last_z = atoms.at(1).x[2];
      ASSERT_EQ(c.left_outlet[1], last_z >= kOutlet ? 1 : 0) << "step " << s;
      straddling += last_z >= kOutlet;
    } else {
      ASSERT_EQ(c.left_outlet[1], 1) << "step " << s;
    }
    const Atom& source = atoms.at(2);
    bool copy = false;
    for (const auto& [tag, a] : atoms) {
      if (tag <= 2) continue;
      copy = true;
      ++copy_seen;
      ASSERT_NEAR(a.x[0], source.x[0] - kShift, 1e-15) << "step " << s;
      ASSERT_EQ(a.x[2], source.x[2]) << "a straddling copy replays its source, step " << s;
    }
    // The source past the feeder's end (wrapped by now, or not yet): the copy's centre is inside.
    const bool entered = source.x[2] < kOutlet || source.x[2] >= kPeriod;
    ASSERT_EQ(c.inserted[2], entered ? 1 : 0) << "step " << s;
    if (copy && !entered) {
      ++straddling;
      ASSERT_GE(source.x[2] + r, kPeriod - 1.5 * step) << "copied before its leading edge reached the end";
    }
    if (!copy) {
      ASSERT_LT(source.x[2] + r, kPeriod) << "its leading edge reached the end uncopied, step " << s;
    }
    ASSERT_EQ(box.open().straddling(), straddling) << "step " << s;
  }
  const auto& c = box.open().counts();
  EXPECT_EQ(c.left_outlet[1], 1);
  EXPECT_EQ(c.inserted[2], 1);
  EXPECT_GE(last_z, kOutlet + r - 1.5 * step) << "it left the DEM before it was a radius past the outlet";
  EXPECT_LT(last_z, kOutlet + r) << "it was kept a step longer than its reach";
  EXPECT_GT(copy_seen, static_cast<int>(2 * r / step));  // present before and after it entered
}

// Past an outlet the vessel goes on as a tube of the outlet's radius: a straddling cell moving
// out sideways is held a radius inside it (its centre at most R - r off the outlet's axis, its
// velocity out of the tube taken away), where no wall of the vessel's is; inside the vessel it
// moves freely.
TEST(OpenEnds, PastAnOutletTheOutletsTubeHoldsAStraddlingCell) {
  OpenEndsBox box;
  const double R = 10e-6, r = kDiameter / 2;
  box.create(1, 0, 0, 79e-6);  // past the outlet from step 20, moving 200 nm a step sideways
  box.start(0, {{{0, 0, kOutlet}, {0, 0, 1}, R}}, 1.0);
  box.command(fmt::format("velocity all set {} 0 {} units box", 4 * kSpeed, kSpeed));
  double widest_inside = 0, widest_past = 0;
  int past = 0;
  for (int s = 0; s < 110; ++s) {
    box.step(s == 0);
    const auto atoms = box.atoms();
    if (!atoms.count(1)) break;
    const Atom& a = atoms.at(1);
    if (a.x[2] < kOutlet) {
      widest_inside = std::max(widest_inside, a.x[0]);
      continue;
    }
    ++past;
    widest_past = std::max(widest_past, a.x[0]);
    ASSERT_LE(a.x[0], R - r + 1e-15) << "step " << s;
    if (a.x[0] > R - r - 1e-12) {
      ASSERT_EQ(a.v[0], 0.0) << "its velocity out of the tube, at step " << s;
    }
  }
  EXPECT_GT(past, 50);
  EXPECT_NEAR(widest_inside, 80 * kSpeed * kDt, 8 * kSpeed * kDt);  // free inside: 4 um in 20 steps
  EXPECT_NEAR(widest_past, R - r, 1e-12);                            // held past it
}
