// SPDX-License-Identifier: GPL-3.0-or-later
#include "dem_open_ends.h"

#include <atom.h>
#include <atom_vec.h>
#include <domain.h>
#include <error.h>
#include <fix_property_atom.h>
#include <fmt/format.h>
#include <lammps.h>
#include <modify.h>
#include <mpi.h>
#include <update.h>

#include <algorithm>
#include <array>
#include <cstdlib>
#include <functional>

namespace hemo::particles::dem {

namespace {

constexpr int kRemoveOutlet = 0, kRemoveInlet = 1, kInsert = 2;

// Every rank's rows of `per` ints, in rank order (collective).
std::vector<int> gather_all(const std::vector<int>& mine, MPI_Comm comm) {
  int ranks = 1;
  MPI_Comm_size(comm, &ranks);
  std::vector<int> sizes(ranks), offsets(ranks, 0);
  const int n = static_cast<int>(mine.size());
  MPI_Allgather(&n, 1, MPI_INT, sizes.data(), 1, MPI_INT, comm);
  for (int r = 1; r < ranks; ++r) offsets[r] = offsets[r - 1] + sizes[r - 1];
  std::vector<int> all(offsets.back() + sizes.back());
  MPI_Allgatherv(mine.data(), n, MPI_INT, all.data(), sizes.data(), offsets.data(), MPI_INT, comm);
  return all;
}

}  // namespace

FixOpenEnds::FixOpenEnds(LAMMPS_NS::LAMMPS* lmp, int narg, char** arg) : Fix(lmp, narg, arg) {
  if (narg != 6) error->all(FLERR, "fix hemo/open_ends needs OUTLET_Z SPLIT_X SHIFT_X");
  layout_.outlet_z = std::atof(arg[3]);
  layout_.split_x = std::atof(arg[4]);
  layout_.shift_x = std::atof(arg[5]);
  if (!(layout_.outlet_z > domain->boxlo[2] && layout_.outlet_z < domain->boxhi[2]))
    error->all(FLERR, "fix hemo/open_ends: the outlet must lie inside the box, short of its upper z bound");
  if (!(layout_.shift_x > 0) || !(layout_.split_x > 0 && layout_.split_x < layout_.shift_x))
    error->all(FLERR, "fix hemo/open_ends: SPLIT_X must lie between the vessel's axis and the feeder's");
  force_reneighbor = 1;
  next_reneighbor = -1;
  const std::size_t types = static_cast<std::size_t>(atom->ntypes) + 1;
  counts_ = {std::vector<std::int64_t>(types, 0), std::vector<std::int64_t>(types, 0),
             std::vector<std::int64_t>(types, 0)};
}

int FixOpenEnds::setmask() { return LAMMPS_NS::FixConst::POST_INTEGRATE | LAMMPS_NS::FixConst::PRE_EXCHANGE; }

void FixOpenEnds::set_counts(const Counts& counts) {
  const std::size_t types = counts_.inserted.size();
  if (counts.inserted.size() != types || counts.left_outlet.size() != types || counts.left_inlet.size() != types)
    error->all(FLERR, "fix hemo/open_ends: counts for another number of atom types");
  counts_ = counts;
}

void FixOpenEnds::post_integrate() {
  const double zlo = domain->boxlo[2], zhi = domain->boxhi[2];
  double** x = atom->x;
  int crossed = 0;
  for (int i = 0; i < atom->nlocal && !crossed; ++i)
    crossed = in_feeder(x[i]) ? x[i][2] >= zhi : (x[i][2] >= layout_.outlet_z || x[i][2] < zlo);
  MPI_Allreduce(MPI_IN_PLACE, &crossed, 1, MPI_INT, MPI_MAX, world);
  if (crossed) next_reneighbor = update->ntimestep;
}

void FixOpenEnds::hand_over() {
  const double zlo = domain->boxlo[2], zhi = domain->boxhi[2];
  // This rank's crossings, as (what, tag, type) rows; an insertion names its source.
  std::vector<int> mine;
  std::vector<int> leaving;                  // local indices
  std::vector<std::array<int, 2>> spawning;  // (tag, local index) of this rank's feeder atoms crossing
  double** x = atom->x;
  for (int i = 0; i < atom->nlocal; ++i) {
    int what = -1;
    if (in_feeder(x[i]))
      what = x[i][2] >= zhi ? kInsert : -1;
    else if (x[i][2] >= layout_.outlet_z)
      what = kRemoveOutlet;
    else if (x[i][2] < zlo)
      what = kRemoveInlet;
    if (what < 0) continue;
    mine.insert(mine.end(), {what, atom->tag[i], atom->type[i]});
    if (what == kInsert)
      spawning.push_back({atom->tag[i], i});
    else
      leaving.push_back(i);
  }
  const std::vector<int> all = gather_all(mine, world);
  if (all.empty()) return;
  if (!free_known_) find_free_tags();

  std::vector<OpenEndsEvent> events;
  std::vector<std::array<int, 2>> sources;  // (source tag, type) of the insertions
  for (std::size_t k = 0; k < all.size(); k += 3) {
    const int what = all[k], tag = all[k + 1], type = all[k + 2];
    if (what == kInsert) {
      sources.push_back({tag, type});
      continue;
    }
    const bool outlet = what == kRemoveOutlet;
    events.push_back({outlet ? OpenEndsEvent::Kind::left_outlet : OpenEndsEvent::Kind::left_inlet, tag, type, 0});
    ++(outlet ? counts_.left_outlet : counts_.left_inlet)[type];
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
  if (capacity_ > atom->map_tag_max) {  // the tag map must reach the new tags (as LIGGGHTS's insertions do)
    atom->nghost = 0;
    atom->map_init();
    atom->map_set();
  }
  if (listener_) listener_(events);
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
  free_known_ = true;
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
  for (LAMMPS_NS::Fix* fix : copied_) {
    auto* values = static_cast<LAMMPS_NS::FixPropertyAtom*>(fix);
    if (values->array_atom == nullptr)
      values->vector_atom[m] = values->vector_atom[source];
    else
      std::copy(values->array_atom[source], values->array_atom[source] + values->get_nvalues(), values->array_atom[m]);
  }
}

std::string open_ends_command(const OpenEndsLayout& layout) {
  return fmt::format("fix {} all {} {:.17g} {:.17g} {:.17g}", kOpenEndsFix, kOpenEndsStyle, layout.outlet_z,
                     layout.split_x, layout.shift_x);
}

LAMMPS_NS::Fix* create_open_ends(LAMMPS_NS::LAMMPS* lmp, int narg, char** arg) {
  return new FixOpenEnds(lmp, narg, arg);
}

}  // namespace hemo::particles::dem
