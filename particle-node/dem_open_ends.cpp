// SPDX-License-Identifier: GPL-3.0-or-later
#include "dem_open_ends.h"

#include "dem_fixes.h"

#include <atom.h>
#include <atom_vec.h>
#include <domain.h>
#include <error.h>
#include <fix_property_atom.h>
#include <fmt/format.h>
#include <lammps.h>
#include <memory.h>
#include <modify.h>
#include <mpi.h>
#include <update.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <stdexcept>

namespace hemo::particles::dem {

FixOpenEnds::FixOpenEnds(LAMMPS_NS::LAMMPS* lmp, int narg, char** arg) : Fix(lmp, narg, arg) {
  const int outlets = narg >= 7 ? std::atoi(arg[6]) : 0;
  if (outlets < 1 || narg != 7 + 6 * outlets)
    error->all(FLERR, "fix hemo/open_ends needs SPLIT_X SHIFT_X BUFFER N and N outlets (CX CY CZ NX NY NZ)");
  layout_.split_x = std::atof(arg[3]);
  layout_.shift_x = std::atof(arg[4]);
  layout_.buffer = std::atof(arg[5]);
  for (int o = 0; o < outlets; ++o) {
    OpenEndsLayout::Outlet outlet;
    for (int d = 0; d < 3; ++d) {
      outlet.centre[d] = std::atof(arg[7 + 6 * o + d]);
      outlet.normal[d] = std::atof(arg[10 + 6 * o + d]);
    }
    const double* c = outlet.centre.data();
    if (!(c[0] > domain->boxlo[0] && c[0] < domain->boxhi[0] && c[1] > domain->boxlo[1] && c[1] < domain->boxhi[1] &&
          c[2] > domain->boxlo[2] && c[2] < domain->boxhi[2]))
      error->all(FLERR, "fix hemo/open_ends: an outlet must lie inside the box, short of its upper z bound");
    if (!(layout_.buffer >= 0 && layout_.buffer < c[2] - domain->boxlo[2]))
      error->all(FLERR, "fix hemo/open_ends: the inlet buffer must end before every outlet");
    layout_.outlets.push_back(outlet);
  }
  if (!(layout_.shift_x > 0) || !(layout_.split_x < layout_.shift_x))
    error->all(FLERR, "fix hemo/open_ends: SPLIT_X must lie between the vessel and the feeder's axis");
  force_reneighbor = 1;
  next_reneighbor = -1;
  create_attribute = 1;  // set_arrays for atoms made by create_atom (ours and LIGGGHTS's)
  grow_arrays(atom->nmax);
  atom->add_callback(0);
  for (int i = 0; i < atom->nlocal; ++i) source_[i] = 0;  // the atoms made before this fix
  // LIGGGHTS's first set-up after a fix is made calls set_arrays on every atom, after
  // setup_pre_exchange: it would clear the links just found.
  just_created = 0;
  const std::size_t types = static_cast<std::size_t>(atom->ntypes) + 1;
  counts_.inserted.assign(types, 0);
  counts_.left_inlet.assign(types, 0);
  counts_.left_outlet.assign(types * layout_.outlets.size(), 0);
}

FixOpenEnds::~FixOpenEnds() {
  atom->delete_callback(id, 0);
  memory->destroy(source_);
}

void FixOpenEnds::grow_arrays(int nmax) { memory->grow(source_, nmax, "hemo/open_ends:source"); }

void FixOpenEnds::copy_arrays(int i, int j, int) { source_[j] = source_[i]; }

int FixOpenEnds::pack_exchange(int i, double* buf) {
  buf[0] = source_[i];
  return 1;
}

int FixOpenEnds::unpack_exchange(int nlocal, double* buf) {
  source_[nlocal] = static_cast<int>(buf[0]);
  return 1;
}

double FixOpenEnds::memory_usage() { return static_cast<double>(atom->nmax) * sizeof(int); }

int FixOpenEnds::setmask() {
  return LAMMPS_NS::FixConst::POST_INTEGRATE | LAMMPS_NS::FixConst::PRE_EXCHANGE | LAMMPS_NS::FixConst::END_OF_STEP;
}

int FixOpenEnds::crossing(const double* x) const {
  if (x[0] >= layout_.split_x) return x[2] >= domain->boxhi[2] ? kFeederEnd : kNone;
  for (std::size_t o = 0; o < layout_.outlets.size(); ++o) {
    const auto& [c, n] = layout_.outlets[o];
    if (n[0] * (x[0] - c[0]) + n[1] * (x[1] - c[1]) + n[2] * (x[2] - c[2]) >= 0) return kOutlet + static_cast<int>(o);
  }
  return x[2] < domain->boxlo[2] ? kInlet : kNone;
}

void FixOpenEnds::post_integrate() {
  replay_sources();
  double** x = atom->x;
  int crossed = 0;
  for (int i = 0; i < atom->nlocal && !crossed; ++i) crossed = crossing(x[i]) != kNone;
  MPI_Allreduce(MPI_IN_PLACE, &crossed, 1, MPI_INT, MPI_MAX, world);
  if (crossed) next_reneighbor = update->ntimestep;
}

void FixOpenEnds::hand_over() {
  // This rank's crossings, as (crossing, tag, type) rows; an insertion names its source.
  std::vector<int> mine;
  std::vector<int> leaving;                  // local indices
  std::vector<std::array<int, 2>> spawning;  // (tag, local index) of this rank's feeder atoms crossing
  double** x = atom->x;
  for (int i = 0; i < atom->nlocal; ++i) {
    const int what = crossing(x[i]);
    if (what == kNone) continue;
    mine.insert(mine.end(), {what, atom->tag[i], atom->type[i]});
    if (what == kFeederEnd)
      spawning.push_back({atom->tag[i], i});
    else
      leaving.push_back(i);
  }
  const std::vector<int> all = gather_all(mine, world);
  if (all.empty()) return;

  std::vector<OpenEndsEvent> events;
  std::vector<std::array<int, 2>> sources;  // (source tag, type) of the insertions
  for (std::size_t k = 0; k < all.size(); k += 3) {
    const int what = all[k], tag = all[k + 1], type = all[k + 2];
    if (what == kFeederEnd) {
      sources.push_back({tag, type});
      continue;
    }
    if (what >= kOutlet) {
      events.push_back({OpenEndsEvent::Kind::left_outlet, tag, type, 0, what - kOutlet});
      ++counts_.left_through(static_cast<std::size_t>(what - kOutlet), static_cast<std::size_t>(type));
    } else {
      events.push_back({OpenEndsEvent::Kind::left_inlet, tag, type, 0});
      ++counts_.left_inlet[type];
    }
    free_.push_back(tag);
  }
  std::sort(events.begin(), events.end(), [](const auto& a, const auto& b) { return a.tag < b.tag; });
  std::sort(free_.begin(), free_.end(), std::greater<>());
  std::sort(sources.begin(), sources.end());
  const std::size_t removed = events.size();
  for (const auto& [source, type] : sources) {
    events.push_back({OpenEndsEvent::Kind::inserted, take_free_tag(), type, source});
    ++counts_.inserted[type];
  }

  // No atom changes its index here (the fixes after this one, LIGGGHTS's contact history among
  // them, still read the lists' indices): the copies are appended, and the atoms leaving are put
  // beyond the box across x (not periodic, one rank across: `processors 1 1 *`), where LIGGGHTS's
  // exchange, next, drops them.
  for (std::size_t e = removed; e < events.size(); ++e) {
    const auto local =
        std::find_if(spawning.begin(), spawning.end(), [&](const auto& s) { return s[0] == events[e].source_tag; });
    if (local != spawning.end()) insert_copy((*local)[1], events[e].tag);
  }
  const double beyond = domain->boxhi[0] + (domain->boxhi[0] - domain->boxlo[0]);
  for (const int i : leaving) atom->x[i][0] = beyond;
  atom->natoms += static_cast<LAMMPS_NS::bigint>(sources.size()) - static_cast<LAMMPS_NS::bigint>(removed);
  // The copies were appended over the first ghost slots: the map is made anew from the owned
  // atoms alone (the ghosts are built again after the exchange), reaching the new tags, as
  // LIGGGHTS's own insertions do. Left as it was, the exchange would clear the map through
  // ghost slots past the copies, beyond what LIGGGHTS holds.
  if (!sources.empty()) {
    atom->nghost = 0;
    atom->map_init();
    atom->map_set();
  }
  if (listener_) listener_(events);
}

void FixOpenEnds::restore(const State& state) {
  const std::size_t types = counts_.inserted.size();
  for (const auto* v : {&state.counts.inserted, &state.counts.left_inlet})
    if (v->size() != types)
      throw std::invalid_argument(
          fmt::format("open ends: {} counts, not one per atom type and a 0 ({})", v->size(), types));
  if (state.counts.left_outlet.size() != counts_.left_outlet.size())
    throw std::invalid_argument(fmt::format("open ends: {} outlet counts, not one per outlet and atom type ({})",
                                            state.counts.left_outlet.size(), counts_.left_outlet.size()));
  counts_ = state.counts;
  capacity_ = state.capacity;
}

void FixOpenEnds::replay_sources() {
  // A copy and its source have the same z, so one rank owns both (the box is split along z
  // only); a source found nowhere here lets its copy go.
  const double end = domain->boxlo[2] + layout_.buffer;
  double** x = atom->x;
  double** v = atom->v;
  double** omega = atom->omega;
  for (int i = 0; i < atom->nlocal; ++i) {
    if (source_[i] == 0) continue;
    const int j = atom->map(source_[i]);
    if (j < 0 || j >= atom->nlocal || x[j][2] >= end || x[j][2] < domain->boxlo[2]) {
      source_[i] = 0;
      continue;
    }
    x[i][0] = x[j][0] - layout_.shift_x;
    x[i][1] = x[j][1];
    x[i][2] = x[j][2];
    for (int d = 0; d < 3; ++d) {
      v[i][d] = v[j][d];
      omega[i][d] = omega[j][d];
    }
    copy_values(replayed_, j, i);
  }
}

void FixOpenEnds::copy_values(const std::vector<LAMMPS_NS::Fix*>& fixes, int from, int to) {
  for (LAMMPS_NS::Fix* fix : fixes) {
    auto* values = static_cast<LAMMPS_NS::FixPropertyAtom*>(fix);
    if (values->array_atom == nullptr)
      values->vector_atom[to] = values->vector_atom[from];
    else
      std::copy(values->array_atom[from], values->array_atom[from] + values->get_nvalues(), values->array_atom[to]);
  }
}

void FixOpenEnds::find_links() {
  // Vessel atoms in the buffer and feeder atoms at the same heights, over all ranks: a pair at
  // the same position but for the shift is a copy and its source.
  const double end = domain->boxlo[2] + layout_.buffer;
  std::vector<double> mine;  // (tag, x, y, z) of either kind
  double** x = atom->x;
  for (int i = 0; i < atom->nlocal; ++i) {
    source_[i] = 0;
    if (x[i][2] < end && x[i][2] >= domain->boxlo[2])
      mine.insert(mine.end(), {static_cast<double>(atom->tag[i]), x[i][0], x[i][1], x[i][2]});
  }
  const std::vector<double> all = gather_all(mine, world);
  const double tolerance = 1e-9 * layout_.buffer;
  for (int i = 0; i < atom->nlocal; ++i) {
    if (x[i][0] >= layout_.split_x || x[i][2] >= end || x[i][2] < domain->boxlo[2]) continue;
    for (std::size_t k = 0; k < all.size(); k += 4)
      if (all[k + 1] >= layout_.split_x && std::abs(all[k + 1] - layout_.shift_x - x[i][0]) <= tolerance &&
          std::abs(all[k + 2] - x[i][1]) <= tolerance && std::abs(all[k + 3] - x[i][2]) <= tolerance) {
        source_[i] = static_cast<int>(all[k]);
        break;
      }
  }
}

void FixOpenEnds::find_free_tags() {
  int largest = 0;
  for (int i = 0; i < atom->nlocal; ++i) largest = std::max(largest, atom->tag[i]);
  MPI_Allreduce(MPI_IN_PLACE, &largest, 1, MPI_INT, MPI_MAX, world);
  capacity_ = std::max<long>(capacity_, largest);
  std::vector<int> present(static_cast<std::size_t>(capacity_) + 1, 0);
  for (int i = 0; i < atom->nlocal; ++i) present[atom->tag[i]] = 1;
  MPI_Allreduce(MPI_IN_PLACE, present.data(), static_cast<int>(present.size()), MPI_INT, MPI_MAX, world);
  free_.clear();
  for (long t = capacity_; t >= 1; --t)
    if (!present[t]) free_.push_back(static_cast<int>(t));
}

int FixOpenEnds::take_free_tag() {
  if (free_.empty()) return static_cast<int>(++capacity_);
  const int tag = free_.back();
  free_.pop_back();
  return tag;
}

void FixOpenEnds::insert_copy(int source, int tag) {
  const double period = domain->boxhi[2] - domain->boxlo[2];
  double at[3] = {atom->x[source][0] - layout_.shift_x, atom->x[source][1], atom->x[source][2] - period};
  atom->avec->create_atom(atom->type[source], at);  // may move LIGGGHTS's arrays
  const int m = atom->nlocal - 1;
  atom->tag[m] = tag;
  atom->mask[m] = atom->mask[source];
  for (int d = 0; d < 3; ++d) {
    atom->v[m][d] = atom->v[source][d];
    atom->omega[m][d] = atom->omega[source][d];
  }
  atom->radius[m] = atom->radius[source];
  atom->density[m] = atom->density[source];
  atom->rmass[m] = atom->rmass[source];
  for (int f = 0; f < modify->nfix; ++f)
    if (modify->fix[f]->create_attribute) modify->fix[f]->set_arrays(m);
  if (layout_.buffer > 0) source_[m] = atom->tag[source];
  copy_values(copied_, source, m);
}

std::string open_ends_command(const OpenEndsLayout& layout) {
  std::string line = fmt::format("fix {} all {} {:.17g} {:.17g} {:.17g} {}", kOpenEndsFix, kOpenEndsStyle,
                                 layout.split_x, layout.shift_x, layout.buffer, layout.outlets.size());
  for (const auto& [c, n] : layout.outlets)
    line += fmt::format(" {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g}", c[0], c[1], c[2], n[0], n[1], n[2]);
  return line;
}

LAMMPS_NS::Fix* create_open_ends(LAMMPS_NS::LAMMPS* lmp, int narg, char** arg) {
  return new FixOpenEnds(lmp, narg, arg);
}

}  // namespace hemo::particles::dem
