// DemEngine's checkpoints: the state one coupling step hands to the next (engine_state.h), taken
// right after a neighbour-list rebuild and restored with the same rebuild (see dem_engine.h).
// SPDX-License-Identifier: GPL-3.0-or-later
#include "dem_engine.h"

#include "agree.h"

#include <atom.h>
#include <atom_vec.h>
#include <fix.h>
#include <fix_contact_history.h>
#include <fix_property_atom.h>
#include <lammps.h>
#include <modify.h>
#include <neighbor.h>
#include <update.h>

#include <fmt/format.h>

#include <functional>
#include <stdexcept>

namespace hemo::particles {

namespace {

// Pair gran's store of the pair contacts' history between list builds (made at its first init).
constexpr const char* kContactHistoryFix = "contacthistory";

int values_per_atom(LAMMPS_NS::Fix* fix) { return static_cast<LAMMPS_NS::FixPropertyAtom*>(fix)->get_nvalues(); }

int ranks_of(MPI_Comm comm) {
  int n = 1;
  MPI_Comm_size(comm, &n);
  return n;
}

// This rank's rows of a per-atom array.
std::vector<double> rows(double** array, int nlocal, int width) {
  std::vector<double> out;
  out.reserve(static_cast<std::size_t>(nlocal) * width);
  for (int i = 0; i < nlocal; ++i) out.insert(out.end(), array[i], array[i] + width);
  return out;
}

template <class T>
void expect_size(const std::vector<T>& values, std::size_t expected, const char* name) {
  if (values.size() != expected)
    throw std::invalid_argument(
        fmt::format("the checkpoint's '{}' holds {} values, not {}", name, values.size(), expected));
}

}  // namespace

// ---- both ways ----------------------------------------------------------------------------

void DemEngine::rebuild_neighbours() {
  const auto builds = lmp_->neighbor->ncalls;  // a set-up zeroes it; our overlap diagnostic reads it
  rebuilding_ = true;
  command("run 0 pre yes post no");
  rebuilding_ = false;
  lmp_->neighbor->ncalls = builds;
}

std::vector<DemEngine::Column> DemEngine::carried_columns() {
  std::vector<Column> columns = {
      {lmp_->atom->f, 3}, {lmp_->atom->torque, 3}, {per_atom(impulse_fix_), values_per_atom(impulse_fix_)}};
  if (rotation_fix_) columns.push_back({per_atom(rotation_fix_), values_per_atom(rotation_fix_)});
  if (closure_fix_) columns.push_back({per_atom(closure_fix_), values_per_atom(closure_fix_)});
  columns.push_back({wall_history_fix_->array_atom, wall_history_fix_->get_nvalues()});
  return columns;
}

template <class State>
auto DemEngine::carried_fields(State& state) const {
  std::vector<decltype(&state.force)> fields = {&state.force, &state.torque, &state.impulse};
  if (rotation_fix_) fields.push_back(&state.rotation);
  if (closure_fix_) fields.push_back(&state.closures);
  fields.push_back(&state.wall_history);
  return fields;
}

int DemEngine::carried_width() {
  int width = 0;
  for (const Column& c : carried_columns()) width += c.width;
  return width;
}

void DemEngine::scatter_carried(const std::vector<double>& by_tag) {
  const std::vector<Column> columns = carried_columns();  // after the rebuild: arrays may have moved
  const std::size_t width = static_cast<std::size_t>(carried_width());
  for (int i = 0; i < lmp_->atom->nlocal; ++i) {
    const double* row = &by_tag[width * static_cast<std::size_t>(lmp_->atom->tag[i] - 1)];
    for (const Column& c : columns)
      for (int d = 0; d < c.width; ++d) c.values[i][d] = *row++;
  }
}

LAMMPS_NS::FixContactHistory* DemEngine::contact_history() const {
  const int ifix = lmp_->modify->find_fix(kContactHistoryFix);
  if (ifix < 0) throw std::logic_error("LIGGGHTS has no pair contact history yet (no run set up)");
  return static_cast<LAMMPS_NS::FixContactHistory*>(lmp_->modify->fix[ifix]);
}

// ---- checkpoint ---------------------------------------------------------------------------

EngineState DemEngine::checkpoint_state() {
  // The rebuild may move atoms to other ranks, and a set-up may reset fix values: what the next
  // run needs is taken per tag before and put back after.
  const std::vector<double> carried = gather_carried();
  rebuild_neighbours();
  scatter_carried(carried);
  EngineState state;
  save_globals(state);
  save_atoms(state);
  save_contact_history(state);
  save_tracking(state);
  return state;
}

std::vector<double> DemEngine::gather_carried() {
  const std::vector<Column> columns = carried_columns();
  const std::size_t width = static_cast<std::size_t>(carried_width());
  std::vector<double> by_tag(width * static_cast<std::size_t>(n_particles_), 0.0);
  for (int i = 0; i < lmp_->atom->nlocal; ++i) {
    double* row = &by_tag[width * static_cast<std::size_t>(lmp_->atom->tag[i] - 1)];
    for (const Column& c : columns)
      for (int d = 0; d < c.width; ++d) *row++ = c.values[i][d];
  }
  if (ranks_of(comm_) > 1)  // each tag on one rank: the sum is a gather
    MPI_Allreduce(MPI_IN_PLACE, by_tag.data(), static_cast<int>(by_tag.size()), MPI_DOUBLE, MPI_SUM, comm_);
  return by_tag;
}

void DemEngine::save_globals(EngineState& s) const {
  s.ranks = ranks_of(comm_);
  s.particles = n_particles_;
  s.type_of = {type_of_[kRbc], type_of_[kPlatelet]};
  s.dem_step = lmp_->update->ntimestep;
  s.dt = dt_;
  s.last_rotation_step = last_rotation_step_;
  s.rotation_dt = rotation_dt_;
  s.neighbour_builds = lmp_->neighbor->ncalls;
  s.max_reynolds.assign(max_re_.begin(), max_re_.end());
  s.min_relaxation_time = min_relaxation_time_;
  s.outside_total = outside_total_;
  s.lost = lost_;
  for (const auto& [tag, q] : pending_orientation_) {
    s.pending_tags.push_back(tag);
    s.pending_orientations.insert(s.pending_orientations.end(), {q.w(), q.x(), q.y(), q.z()});
  }
}

void DemEngine::save_atoms(EngineState& s) {
  const LAMMPS_NS::Atom& a = *lmp_->atom;
  const int n = a.nlocal;
  for (int i = 0; i < n; ++i) {
    s.tag.push_back(a.tag[i]);
    s.type.push_back(a.type[i]);
    s.mask.push_back(a.mask[i]);
    s.image.push_back(a.image[i]);
    s.radius.push_back(a.radius[i]);
    s.rmass.push_back(a.rmass[i]);
    s.density.push_back(a.density[i]);
  }
  s.x = rows(a.x, n, 3);
  s.v = rows(a.v, n, 3);
  s.omega = rows(a.omega, n, 3);
  const std::vector<Column> columns = carried_columns();
  const auto fields = carried_fields(s);
  for (std::size_t k = 0; k < columns.size(); ++k) *fields[k] = rows(columns[k].values, n, columns[k].width);
}

void DemEngine::save_contact_history(EngineState& s) const {
  // After a rebuild the history is with the atoms (LIGGGHTS copies it there before it migrates
  // atoms and from there into the new lists): each atom's partners by tag and their values.
  LAMMPS_NS::FixContactHistory* history = contact_history();
  const int values = history->get_dnum();
  s.contact_values = values;
  for (int i = 0; i < lmp_->atom->nlocal; ++i) {
    const int partners = history->n_partner(i);
    s.partner_count.push_back(partners);
    for (int j = 0; j < partners; ++j) {
      s.partner.push_back(history->partner(i, j));
      const double* h = history->contacthistory(i, j);
      s.contact_history.insert(s.contact_history.end(), h, h + values);
    }
  }
}

void DemEngine::save_tracking(EngineState& s) const {
  s.tracked.reserve(EngineState::kTrackedValues * tracked_.size());
  for (const Tracked& t : tracked_)
    s.tracked.insert(s.tracked.end(), {t.where.anchor.x(), t.where.anchor.y(), t.where.anchor.z(), t.where.clearance,
                                       static_cast<double>(t.where.cell), t.last_z, t.crossings});
}

// ---- restore ------------------------------------------------------------------------------

void DemEngine::restore(const EngineState& s) {
  if (n_particles_ > 0 || type_of_[kRbc] + type_of_[kPlatelet] > 0)
    throw std::logic_error("particles were already created");
  agreed([&] { check_globals(s); });
  setup_box({s.type_of[kRbc] > 0, s.type_of[kPlatelet] > 0});
  agreed([&] { check_atoms(s); });
  command(fmt::format("timestep {:.17g}", s.dt));
  command(fmt::format("reset_timestep {}", s.dem_step));
  create_atoms_as(s);
  lmp_->init();  // pair gran makes its contact history store at its first init
  restore_contact_history(s);
  rebuild_neighbours();
  scatter_carried(carried_by_tag(s));
  lmp_->neighbor->ncalls = s.neighbour_builds;
  restore_globals(s);
}

void DemEngine::agreed(const std::function<void()>& check) const {
  // A damaged file may be one rank's only: every rank stops alike, before a collective step the
  // others would wait in for ever.
  std::string error;
  try {
    check();
  } catch (const std::invalid_argument& e) {
    error = e.what();
  }
  error = agree_on_error(error, comm_);
  if (!error.empty()) throw std::invalid_argument(error);
}

void DemEngine::check_globals(const EngineState& s) const {
  if (s.ranks != ranks_of(comm_))
    throw std::invalid_argument(
        fmt::format("the checkpoint was written on {} MPI ranks, this engine runs on {}", s.ranks, ranks_of(comm_)));
  expect_size(s.type_of, kSpeciesCount, "type_of");
  for (int sp = 0; sp < kSpeciesCount; ++sp)
    if (s.type_of[sp] > 0 && !forces_[sp])
      throw std::invalid_argument(
          fmt::format("the checkpoint has {} particles, the scene has none", sp == kRbc ? "red cell" : "platelet"));
  if (s.particles < 1) throw std::invalid_argument("the checkpoint has no particles");
  expect_size(s.tracked, EngineState::kTrackedValues * static_cast<std::size_t>(s.particles + 1), "tracked");
  expect_size(s.max_reynolds, kSpeciesCount, "max_reynolds");
  expect_size(s.pending_orientations, 4 * s.pending_tags.size(), "pending_orientations");
}

void DemEngine::check_atoms(const EngineState& s) {
  const std::size_t n = s.tag.size();
  for (const auto* v : {&s.type, &s.mask, &s.image, &s.partner_count}) expect_size(*v, n, "atoms");
  for (const auto* v : {&s.radius, &s.rmass, &s.density}) expect_size(*v, n, "radius, rmass, density");
  for (const auto* v : {&s.x, &s.v, &s.omega}) expect_size(*v, 3 * n, "x, v, omega");
  const std::vector<Column> columns = carried_columns();  // the fixes' widths, known once the box is set up
  const auto fields = carried_fields(s);
  for (std::size_t c = 0; c < columns.size(); ++c) expect_size(*fields[c], n * columns[c].width, "per-atom values");
  for (std::size_t k = 0; k < n; ++k)
    if (s.tag[k] < 1 || s.tag[k] > s.particles || (s.type[k] != type_of_[kRbc] && s.type[k] != type_of_[kPlatelet]) ||
        s.type[k] < 1 || s.partner_count[k] < 0)
      throw std::invalid_argument(fmt::format("the checkpoint's atom {} has tag {}, type {}", k, s.tag[k], s.type[k]));
  std::size_t partners = 0;
  for (const auto count : s.partner_count) partners += static_cast<std::size_t>(count);
  expect_size(s.partner, partners, "partner");
  // Pair and wall contacts have the same model, hence as many history values.
  if (s.contact_values != wall_history_fix_->get_nvalues())
    throw std::invalid_argument(fmt::format("the checkpoint's contacts carry {} history values, LIGGGHTS's {}",
                                            s.contact_values, wall_history_fix_->get_nvalues()));
  expect_size(s.contact_history, partners * static_cast<std::size_t>(s.contact_values), "contact_history");
}

void DemEngine::create_atoms_as(const EngineState& s) {
  // As create_atoms does it, with every value as saved and in the saved order (which is this
  // rank's: the atoms are inside its sub-domain, so the rebuild moves none of them).
  LAMMPS_NS::Atom& a = *lmp_->atom;
  for (std::size_t k = 0; k < s.tag.size(); ++k) {
    double x[3] = {s.x[3 * k], s.x[3 * k + 1], s.x[3 * k + 2]};
    a.avec->create_atom(static_cast<int>(s.type[k]), x);
    const int i = a.nlocal - 1;
    for (int f = 0; f < lmp_->modify->nfix; ++f)
      if (lmp_->modify->fix[f]->create_attribute) {
        lmp_->modify->fix[f]->pre_set_arrays();
        lmp_->modify->fix[f]->set_arrays(i);
      }
    a.tag[i] = static_cast<int>(s.tag[k]);
    a.mask[i] = static_cast<int>(s.mask[k]);
    a.image[i] = static_cast<LAMMPS_NS::tagint>(s.image[k]);
    a.radius[i] = s.radius[k];
    a.rmass[i] = s.rmass[k];
    a.density[i] = s.density[k];
    for (int d = 0; d < 3; ++d) {
      a.v[i][d] = s.v[3 * k + d];
      a.omega[i][d] = s.omega[3 * k + d];
    }
  }
  std::int64_t local = a.nlocal, total = 0;
  MPI_Allreduce(&local, &total, 1, MPI_INT64_T, MPI_SUM, comm_);
  a.natoms = total;
  a.nghost = 0;
  a.map_init();
  a.map_set();
  n_particles_ = static_cast<long>(total);
  if (n_particles_ != s.particles)
    throw std::runtime_error(
        fmt::format("the checkpoint's ranks hold {} particles, not {}", n_particles_, s.particles));
}

void DemEngine::restore_contact_history(const EngineState& s) {
  LAMMPS_NS::FixContactHistory* history = contact_history();
  const int values = history->get_dnum();
  if (s.contact_values != values)  // the same on every rank (check_atoms)
    throw std::invalid_argument(
        fmt::format("the checkpoint's pair contacts carry {} history values, LIGGGHTS's {}", s.contact_values, values));
  // LIGGGHTS's own format for an atom arriving from another rank: count, then per partner its tag
  // and values (integers as bit patterns in doubles).
  using Bits = LAMMPS_NS::Fix::ubuf;
  std::size_t p = 0;
  std::vector<double> buf;
  for (std::size_t k = 0; k < s.partner_count.size(); ++k) {
    const std::int64_t partners = s.partner_count[k];
    buf.assign(1, Bits(partners).d);
    for (std::int64_t j = 0; j < partners; ++j, ++p) {
      buf.push_back(Bits(s.partner[p]).d);
      buf.insert(buf.end(), &s.contact_history[p * values], &s.contact_history[p * values] + values);
    }
    history->unpack_exchange(static_cast<int>(k), buf.data());
  }
}

std::vector<double> DemEngine::carried_by_tag(const EngineState& s) {
  const std::vector<Column> columns = carried_columns();
  const auto fields = carried_fields(s);
  const std::size_t width = static_cast<std::size_t>(carried_width());
  std::vector<double> by_tag(width * static_cast<std::size_t>(n_particles_), 0.0);
  for (std::size_t k = 0; k < s.tag.size(); ++k) {
    double* row = &by_tag[width * static_cast<std::size_t>(s.tag[k] - 1)];
    for (std::size_t c = 0; c < columns.size(); ++c)
      for (int d = 0; d < columns[c].width; ++d) *row++ = (*fields[c])[k * columns[c].width + d];
  }
  return by_tag;
}

void DemEngine::restore_globals(const EngineState& s) {
  dt_ = s.dt;
  first_run_ = false;  // the next run carries the last force over (`pre no`), as it would have
  last_rotation_step_ = s.last_rotation_step;
  rotation_dt_ = s.rotation_dt;
  for (int sp = 0; sp < kSpeciesCount; ++sp) max_re_[sp] = s.max_reynolds[sp];
  min_relaxation_time_ = s.min_relaxation_time;
  outside_total_ = static_cast<long>(s.outside_total);
  lost_ = static_cast<long>(s.lost);
  pending_orientation_.clear();
  for (std::size_t k = 0; k < s.pending_tags.size(); ++k) {
    const double* q = &s.pending_orientations[4 * k];
    pending_orientation_[static_cast<int>(s.pending_tags[k])] = Quat(q[0], q[1], q[2], q[3]);
  }
  tracked_.assign(static_cast<std::size_t>(n_particles_) + 1, Tracked{});
  for (std::size_t t = 0; t < tracked_.size(); ++t) {
    const double* v = &s.tracked[EngineState::kTrackedValues * t];
    tracked_[t].where.anchor = Vec3(v[0], v[1], v[2]);
    tracked_[t].where.clearance = v[3];
    tracked_[t].where.cell = static_cast<int>(v[4]);
    tracked_[t].last_z = v[5];
    tracked_[t].crossings = v[6];
  }
}

}  // namespace hemo::particles
