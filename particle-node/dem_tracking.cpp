// SPDX-License-Identifier: GPL-3.0-or-later
#include "dem_tracking.h"

#include <atom.h>
#include <error.h>
#include <fix.h>
#include <traffic.h>

#include <cmath>
#include <limits>
#include <stdexcept>

namespace hemo::particles {

void ParticleTracking::start(const std::vector<const PlacedParticle*>& order) {
  tracked_.assign(order.size() + 1, Tracked{});
  present_.assign(order.size() + 1, 1);
  present_[0] = 0;
  for (std::size_t i = 0; i < order.size(); ++i) tracked_[i + 1].last_z = order[i]->position.z();
}

void ParticleTracking::enter(int tag, double z) {
  const auto t = static_cast<std::size_t>(tag);
  if (t >= tracked_.size()) {
    tracked_.resize(t + 1);
    present_.resize(t + 1, 0);
  }
  tracked_[t] = Tracked{};
  tracked_[t].last_z = z;  // LIGGGHTS's wrapping it into the box counts as a crossing
  present_[t] = 1;
}

double ParticleTracking::unwrap_z(int tag, double z) {
  const double half = 0.5 * locator_->length();
  Tracked& t = tracked_[tag];
  if (std::isnan(t.last_z)) t.last_z = z;  // a new particle: its z is where it starts
  const double dz = z - t.last_z;
  if (dz < -half)
    t.crossings += 1;
  else if (dz > half)
    t.crossings -= 1;
  t.last_z = z;
  return z + t.crossings * locator_->length();
}

int ParticleTracking::cell_of(int tag, const Vec3& x, bool* in_wall_gap) {
  LocateCache& where = tracked_[tag].where;
  int cell = locator_->locate(x, where);
  const bool gap = cell < 0 && (cell = locator_->locate_in_wall_gap(x)) >= 0;
  if (gap) where.cell = cell;  // a good first guess next time; the cache stays invalid
  if (in_wall_gap) *in_wall_gap = gap;
  return cell;
}

void ParticleTracking::share_all(int nlocal, const int* tag, MPI_Comm comm) {
  int size = 1;
  MPI_Comm_size(comm, &size);
  if (size == 1) return;
  // Each rank contributes its own atoms; the sum is everyone's current view.
  std::vector<double> buf(kRecordValues * tracked_.size(), 0.0);
  for (int i = 0; i < nlocal; ++i) pack(tag[i], &buf[kRecordValues * static_cast<std::size_t>(tag[i])]);
  MPI_Allreduce(MPI_IN_PLACE, buf.data(), static_cast<int>(buf.size()), MPI_DOUBLE, MPI_SUM, comm);
  RankTraffic::all_reduce(sizeof(double) * buf.size(), size);
  for (std::size_t t = 0; t < tracked_.size(); ++t)
    if (present_[t]) unpack(static_cast<int>(t), &buf[kRecordValues * t]);
}

// An atom LIGGGHTS moves before the records are made (start, restore: they are then made whole on
// every rank) has none to carry.
void ParticleTracking::pack(int tag, double* buf) const {
  const auto t = static_cast<std::size_t>(tag);
  buf[0] = t < tracked_.size() ? tracked_[t].last_z : std::numeric_limits<double>::quiet_NaN();
  buf[1] = t < tracked_.size() ? tracked_[t].crossings : 0.0;
}

void ParticleTracking::unpack(int tag, const double* buf) {
  const auto t = static_cast<std::size_t>(tag);
  if (t >= tracked_.size()) return;
  tracked_[t].last_z = buf[0];
  tracked_[t].crossings = buf[1];
}

namespace dem {

namespace {

// Holds no per-atom array of its own (the records are by tag): it only rides LIGGGHTS's exchange,
// which calls every fix registered for per-atom data when an atom leaves a rank and arrives at
// another, the arriving atom's tag already unpacked.
class FixTracking : public LAMMPS_NS::Fix {
 public:
  FixTracking(LAMMPS_NS::LAMMPS* lmp, int narg, char** arg) : Fix(lmp, narg, arg) {
    if (narg != 3) error->all(FLERR, "fix hemo/tracking takes no arguments");
    atom->add_callback(0);  // grow, copy, pack and unpack with the atoms
  }
  ~FixTracking() override { atom->delete_callback(id, 0); }
  int setmask() override { return 0; }

  int pack_exchange(int i, double* buf) override {
    if (tracking_ == nullptr) error->one(FLERR, "fix hemo/tracking: no tracking attached");
    tracking_->pack(atom->tag[i], buf);
    return ParticleTracking::kRecordValues;
  }
  int unpack_exchange(int nlocal, double* buf) override {
    if (tracking_ == nullptr) error->one(FLERR, "fix hemo/tracking: no tracking attached");
    tracking_->unpack(atom->tag[nlocal], buf);
    return ParticleTracking::kRecordValues;
  }

  ParticleTracking* tracking_ = nullptr;
};

}  // namespace

LAMMPS_NS::Fix* create_tracking_fix(LAMMPS_NS::LAMMPS* lmp, int narg, char** arg) {
  return new FixTracking(lmp, narg, arg);
}

void attach_tracking(LAMMPS_NS::Fix* fix, ParticleTracking* tracking) {
  auto* ours = dynamic_cast<FixTracking*>(fix);
  if (ours == nullptr) throw std::logic_error("the tracking fix is not hemo/tracking");
  ours->tracking_ = tracking;
}

}  // namespace dem

void ParticleTracking::save(EngineState& s) const {
  s.tracked.reserve(EngineState::kTrackedValues * tracked_.size());
  for (std::size_t k = 0; k < tracked_.size(); ++k) {
    const Tracked& t = tracked_[k];
    s.tracked.insert(s.tracked.end(),
                     {t.where.anchor.x(), t.where.anchor.y(), t.where.anchor.z(), t.where.clearance,
                      static_cast<double>(t.where.cell), t.last_z, t.crossings, static_cast<double>(present_[k])});
  }
}

void ParticleTracking::restore(const EngineState& s, long tags) {
  tracked_.assign(static_cast<std::size_t>(tags) + 1, Tracked{});
  present_.assign(tracked_.size(), 0);
  for (std::size_t t = 0; t < tracked_.size(); ++t) {
    const double* v = &s.tracked[EngineState::kTrackedValues * t];
    tracked_[t].where.anchor = Vec3(v[0], v[1], v[2]);
    tracked_[t].where.clearance = v[3];
    tracked_[t].where.cell = static_cast<int>(v[4]);
    tracked_[t].last_z = v[5];
    tracked_[t].crossings = v[6];
    present_[t] = v[7] != 0;
  }
}

}  // namespace hemo::particles
