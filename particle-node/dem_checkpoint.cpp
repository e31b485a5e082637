// SPDX-License-Identifier: GPL-3.0-or-later
#include "dem_checkpoint.h"
#include "engine_state_merge.h"

#include "agree.h"

#include <atom.h>
#include <atom_vec.h>
#include <comm.h>
#include <domain.h>
#include <fix.h>
#include <fix_contact_history.h>
#include <fix_property_atom.h>
#include <lammps.h>
#include <modify.h>
#include <neighbor.h>
#include <update.h>

#include <fmt/format.h>

#include <array>
#include <limits>
#include <stdexcept>

#include "dem_fixes.h"
#include "dem_open_ends.h"

namespace hemo::particles {

using namespace dem;

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

}  // namespace

// ---- both ways ----------------------------------------------------------------------------

std::vector<LiggghtsCheckpoint::Column> LiggghtsCheckpoint::carried_columns() const {
  const LiggghtsSession::Fixes& fixes = liggghts_.fixes();
  std::vector<Column> columns = {
      {liggghts_.atom().f, 3}, {liggghts_.atom().torque, 3}, {per_atom(fixes.impulse), values_per_atom(fixes.impulse)}};
  if (fixes.rotation) columns.push_back({per_atom(fixes.rotation), values_per_atom(fixes.rotation)});
  if (fixes.closures) columns.push_back({per_atom(fixes.closures), values_per_atom(fixes.closures)});
  for (auto* history : {fixes.wall_history, fixes.feeder_wall_history})
    if (history) columns.push_back({history->array_atom, history->get_nvalues()});
  return columns;
}

template <class State>
auto LiggghtsCheckpoint::carried_fields(State& state) const {
  std::vector<decltype(&state.force)> fields = {&state.force, &state.torque, &state.impulse};
  if (liggghts_.fixes().rotation) fields.push_back(&state.rotation);
  if (liggghts_.fixes().closures) fields.push_back(&state.closures);
  if (liggghts_.fixes().wall_history) fields.push_back(&state.wall_history);
  if (liggghts_.fixes().feeder_wall_history) fields.push_back(&state.feeder_wall_history);
  return fields;
}

int LiggghtsCheckpoint::carried_width() const {
  int width = 0;
  for (const Column& c : carried_columns()) width += c.width;
  return width;
}

void LiggghtsCheckpoint::scatter_carried(const std::vector<double>& by_tag) {
  const std::vector<Column> columns = carried_columns();  // after the rebuild: arrays may have moved
  const std::size_t width = static_cast<std::size_t>(carried_width());
  const LAMMPS_NS::Atom& atom = liggghts_.atom();
  for (int i = 0; i < atom.nlocal; ++i) {
    const double* row = &by_tag[width * static_cast<std::size_t>(atom.tag[i] - 1)];
    for (const Column& c : columns)
      for (int d = 0; d < c.width; ++d) c.values[i][d] = *row++;
  }
}

LAMMPS_NS::FixContactHistory* LiggghtsCheckpoint::contact_history() const {
  LAMMPS_NS::Modify& modify = *liggghts_.lammps().modify;
  const int ifix = modify.find_fix(kContactHistoryFix);
  if (ifix < 0) throw std::logic_error("LIGGGHTS has no pair contact history yet (no run set up)");
  return static_cast<LAMMPS_NS::FixContactHistory*>(modify.fix[ifix]);
}

// ---- checkpoint ---------------------------------------------------------------------------

void LiggghtsCheckpoint::save(EngineState& s) {
  // The rebuild may move atoms to other ranks, and a set-up may reset fix values: what the next
  // run needs is taken per tag before and put back after.
  rebuild();
  s.particles = liggghts_.particles() + liggghts_.straddling();  // the atoms it holds
  s.created = liggghts_.created();
  s.tag_capacity = liggghts_.tag_capacity();
  if (const auto* open = liggghts_.fixes().open_ends) {
    s.inserted = open->counts().inserted;
    s.left_outlet = open->counts().left_outlet;
    s.left_inlet = open->counts().left_inlet;
  }
  s.type_of = {liggghts_.type_of(kRbc), liggghts_.type_of(kPlatelet)};
  s.dem_step = liggghts_.dem_step();
  s.neighbour_builds = liggghts_.neighbour_builds();
  save_atoms(s);
  save_contact_history(s);
}

void LiggghtsCheckpoint::rebuild(const std::function<void()>& before) {
  const std::vector<double> carried = gather_carried();
  if (before) before();
  liggghts_.rebuild_neighbours();
  scatter_carried(carried);
}

std::vector<double> LiggghtsCheckpoint::gather_carried() const {
  const std::vector<Column> columns = carried_columns();
  const std::size_t width = static_cast<std::size_t>(carried_width());
  const LAMMPS_NS::Atom& atom = liggghts_.atom();
  std::vector<double> by_tag(width * static_cast<std::size_t>(liggghts_.tag_capacity()), 0.0);
  for (int i = 0; i < atom.nlocal; ++i) {
    double* row = &by_tag[width * static_cast<std::size_t>(atom.tag[i] - 1)];
    for (const Column& c : columns)
      for (int d = 0; d < c.width; ++d) *row++ = c.values[i][d];
  }
  if (ranks_of(comm_) > 1)  // each tag on one rank: the sum is a gather
    MPI_Allreduce(MPI_IN_PLACE, by_tag.data(), static_cast<int>(by_tag.size()), MPI_DOUBLE, MPI_SUM, comm_);
  return by_tag;
}

void LiggghtsCheckpoint::save_atoms(EngineState& s) const {
  const LAMMPS_NS::Atom& a = liggghts_.atom();
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

void LiggghtsCheckpoint::save_contact_history(EngineState& s) const {
  // After a rebuild the history is with the atoms (LIGGGHTS copies it there before it migrates
  // atoms and from there into the new lists): each atom's partners by tag and their values.
  LAMMPS_NS::FixContactHistory* history = contact_history();
  const int values = history->get_dnum();
  s.contact_values = values;
  for (int i = 0; i < liggghts_.atom().nlocal; ++i) {
    const int partners = history->n_partner(i);
    s.partner_count.push_back(partners);
    for (int j = 0; j < partners; ++j) {
      s.partner.push_back(history->partner(i, j));
      const double* h = history->contacthistory(i, j);
      s.contact_history.insert(s.contact_history.end(), h, h + values);
    }
  }
}

// ---- restore ------------------------------------------------------------------------------

void LiggghtsCheckpoint::restore(const EngineState& written, LiggghtsSession::OpenEndsListener listener) {
  // Written on another rank count: every rank has all the atoms and keeps those in its own
  // sub-domain (the box is set up), each exactly once.
  const bool other_count = written.ranks != ranks_of(comm_);
  EngineState redistributed;
  if (other_count) agreed([&] { redistributed = atoms_in(written, in_own_sub_domain()); }, comm_);
  const EngineState& s = other_count ? redistributed : written;
  agreed([&] { check_atoms(s); }, comm_);
  liggghts_.set_timestep(s.dt);
  liggghts_.command(fmt::format("reset_timestep {}", s.dem_step));
  create_atoms_as(s);
  liggghts_.set_created(s.created);
  OpenEndsState open{{s.inserted, s.left_outlet, s.left_inlet}, static_cast<long>(s.tag_capacity)};
  agreed([&] { liggghts_.first_init(std::move(listener), liggghts_.open() ? &open : nullptr); }, comm_);
  if (liggghts_.particles() + liggghts_.straddling() != s.particles || liggghts_.tag_capacity() != s.tag_capacity)
    throw std::invalid_argument(fmt::format("the checkpoint's counts make {} particles on {} tags, it has {} on {}",
                                            liggghts_.particles() + liggghts_.straddling(), liggghts_.tag_capacity(), s.particles,
                                            s.tag_capacity));
  restore_contact_history(s);
  liggghts_.rebuild_neighbours();
  scatter_carried(carried_by_tag(s));
  liggghts_.lammps().neighbor->ncalls = s.neighbour_builds;
}

std::function<bool(double, double, double)> LiggghtsCheckpoint::in_own_sub_domain() const {
  // Half-open [sublo, subhi) as LIGGGHTS assigns atoms, open outwards at the box's faces so that
  // an atom on or beyond a face of a non-periodic box still has one owner.
  const LAMMPS_NS::Domain& d = *liggghts_.lammps().domain;
  const LAMMPS_NS::Comm& c = *liggghts_.lammps().comm;
  std::array<double, 3> lo{}, hi{};
  for (int k = 0; k < 3; ++k) {
    lo[k] = c.myloc[k] > 0 ? d.sublo[k] : -std::numeric_limits<double>::infinity();
    hi[k] = c.myloc[k] < c.procgrid[k] - 1 ? d.subhi[k] : std::numeric_limits<double>::infinity();
  }
  return [lo, hi](double x, double y, double z) {
    const double r[3] = {x, y, z};
    for (int k = 0; k < 3; ++k)
      if (r[k] < lo[k] || r[k] >= hi[k]) return false;
    return true;
  };
}

void LiggghtsCheckpoint::check_atoms(const EngineState& s) const {
  const std::size_t n = s.tag.size();
  for (const auto* v : {&s.type, &s.mask, &s.image, &s.partner_count}) expect_size(*v, n, "atoms");
  for (const auto* v : {&s.radius, &s.rmass, &s.density}) expect_size(*v, n, "radius, rmass, density");
  for (const auto* v : {&s.x, &s.v, &s.omega}) expect_size(*v, 3 * n, "x, v, omega");
  const std::vector<Column> columns = carried_columns();  // the fixes' widths, known once the box is set up
  const auto fields = carried_fields(s);
  for (std::size_t c = 0; c < columns.size(); ++c) expect_size(*fields[c], n * columns[c].width, "per-atom values");
  const int rbc = liggghts_.type_of(kRbc), platelet = liggghts_.type_of(kPlatelet);
  for (std::size_t k = 0; k < n; ++k)
    if (s.tag[k] < 1 || s.tag[k] > s.tag_capacity || (s.type[k] != rbc && s.type[k] != platelet) || s.type[k] < 1 ||
        s.partner_count[k] < 0)
      throw std::invalid_argument(fmt::format("the checkpoint's atom {} has tag {}, type {}", k, s.tag[k], s.type[k]));
  std::size_t partners = 0;
  for (const auto count : s.partner_count) partners += static_cast<std::size_t>(count);
  expect_size(s.partner, partners, "partner");
  // Pair and wall contacts have the same model, hence as many history values.
  auto* wall_history = liggghts_.fixes().wall_history;
  const int wall_values = wall_history ? wall_history->get_nvalues() : static_cast<int>(s.contact_values);
  if (s.contact_values != wall_values)
    throw std::invalid_argument(
        fmt::format("the checkpoint's contacts carry {} history values, LIGGGHTS's {}", s.contact_values, wall_values));
  expect_size(s.contact_history, partners * static_cast<std::size_t>(s.contact_values), "contact_history");
}

void LiggghtsCheckpoint::create_atoms_as(const EngineState& s) {
  // As create_atoms does it, with every value as saved and in the saved order (which is this
  // rank's: the atoms are inside its sub-domain, so the rebuild moves none of them).
  LAMMPS_NS::LAMMPS& lmp = liggghts_.lammps();
  LAMMPS_NS::Atom& a = liggghts_.atom();
  for (std::size_t k = 0; k < s.tag.size(); ++k) {
    double x[3] = {s.x[3 * k], s.x[3 * k + 1], s.x[3 * k + 2]};
    a.avec->create_atom(static_cast<int>(s.type[k]), x);
    const int i = a.nlocal - 1;
    for (int f = 0; f < lmp.modify->nfix; ++f)
      if (lmp.modify->fix[f]->create_attribute) {
        lmp.modify->fix[f]->pre_set_arrays();
        lmp.modify->fix[f]->set_arrays(i);
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
  if (liggghts_.count_atoms() != s.particles)
    throw std::runtime_error(
        fmt::format("the checkpoint's ranks hold {} particles, not {}", liggghts_.count_atoms(), s.particles));
}

void LiggghtsCheckpoint::restore_contact_history(const EngineState& s) {
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

std::vector<double> LiggghtsCheckpoint::carried_by_tag(const EngineState& s) const {
  const std::vector<Column> columns = carried_columns();
  const auto fields = carried_fields(s);
  const std::size_t width = static_cast<std::size_t>(carried_width());
  std::vector<double> by_tag(width * static_cast<std::size_t>(liggghts_.tag_capacity()), 0.0);
  for (std::size_t k = 0; k < s.tag.size(); ++k) {
    double* row = &by_tag[width * static_cast<std::size_t>(s.tag[k] - 1)];
    for (std::size_t c = 0; c < columns.size(); ++c)
      for (int d = 0; d < columns[c].width; ++d) *row++ = (*fields[c])[k * columns[c].width + d];
  }
  return by_tag;
}

}  // namespace hemo::particles
