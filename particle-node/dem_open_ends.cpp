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
  const int outlets = narg >= 9 ? std::atoi(arg[8]) : 0;
  if (outlets < 1 || narg != 9 + 7 * outlets)
    error->all(FLERR, "fix hemo/open_ends needs SPLIT_X SHIFT_X BUFFER REACH TOP N and N outlets (CX CY CZ NX NY NZ R)");
  layout_.split_x = std::atof(arg[3]);
  layout_.shift_x = std::atof(arg[4]);
  layout_.buffer = std::atof(arg[5]);
  layout_.reach = std::atof(arg[6]);
  layout_.top = std::atof(arg[7]);
  double highest = -1e300;
  for (int o = 0; o < outlets; ++o) {
    OpenEndsLayout::Outlet outlet;
    for (int d = 0; d < 3; ++d) {
      outlet.centre[d] = std::atof(arg[9 + 7 * o + d]);
      outlet.normal[d] = std::atof(arg[12 + 7 * o + d]);
    }
    outlet.radius = std::atof(arg[15 + 7 * o]);
    const double* c = outlet.centre.data();
    if (!(c[0] > domain->boxlo[0] && c[0] < domain->boxhi[0] && c[1] > domain->boxlo[1] && c[1] < domain->boxhi[1] &&
          c[2] > domain->boxlo[2] && c[2] < domain->boxhi[2]))
      error->all(FLERR, "fix hemo/open_ends: an outlet must lie inside the box, short of its upper z bound");
    if (!(layout_.buffer >= 0 && layout_.buffer < c[2] - domain->boxlo[2]))
      error->all(FLERR, "fix hemo/open_ends: the inlet buffer must end before every outlet");
    highest = std::max(highest, c[2]);
    layout_.outlets.push_back(outlet);
  }
  if (!(layout_.shift_x > 0) || !(layout_.split_x < layout_.shift_x))
    error->all(FLERR, "fix hemo/open_ends: SPLIT_X must lie between the vessel and the feeder's axis");
  if (!(layout_.reach >= 0)) error->all(FLERR, "fix hemo/open_ends: REACH must not be negative");
  layout_.top = std::max(layout_.top, highest);  // a surface's top is its outlet's centre, to rounding
  if (!(layout_.top < domain->boxhi[2])) error->all(FLERR, "fix hemo/open_ends: TOP must lie below the box's upper z bound");
  // Midway through the gap: the cells leaving past the outlets below, those entering above.
  before_inlet_from_ = 0.5 * (layout_.top + domain->boxhi[2]);
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
  // The atoms made outside an end count as gone through it (a restored engine's counts are then
  // the checkpoint's: restore()).
  find_places(true);
}

FixOpenEnds::~FixOpenEnds() {
  atom->delete_callback(id, 0);
  memory->destroy(source_);
  memory->destroy(phase_);
}

void FixOpenEnds::grow_arrays(int nmax) {
  memory->grow(source_, nmax, "hemo/open_ends:source");
  memory->grow(phase_, nmax, "hemo/open_ends:phase");
}

void FixOpenEnds::copy_arrays(int i, int j, int) {
  source_[j] = source_[i];
  phase_[j] = phase_[i];
}

int FixOpenEnds::pack_exchange(int i, double* buf) {
  buf[0] = source_[i];
  buf[1] = phase_[i];
  return 2;
}

int FixOpenEnds::unpack_exchange(int nlocal, double* buf) {
  source_[nlocal] = static_cast<int>(buf[0]);
  phase_[nlocal] = static_cast<int>(buf[1]);
  return 2;
}

double FixOpenEnds::memory_usage() { return 2.0 * static_cast<double>(atom->nmax) * sizeof(int); }

int FixOpenEnds::setmask() {
  return LAMMPS_NS::FixConst::POST_INTEGRATE | LAMMPS_NS::FixConst::PRE_EXCHANGE | LAMMPS_NS::FixConst::END_OF_STEP;
}

FixOpenEnds::Place FixOpenEnds::place(const double* x) const {
  Place p;
  const double lo = domain->boxlo[2], hi = domain->boxhi[2], period = hi - lo;
  double z = x[2];
  if (z >= hi)
    z -= period;
  else if (z < lo)
    z += period;
  p.centre[0] = x[0];
  p.centre[1] = x[1];
  p.centre[2] = z;
  if (x[0] >= layout_.split_x) return p;
  if (z >= before_inlet_from_) p.centre[2] = z - period;
  p.end = kInlet;
  p.beyond = lo - p.centre[2];
  p.normal[2] = -1;
  p.inside[0] = p.centre[0];
  p.inside[1] = p.centre[1];
  p.inside[2] = lo;
  for (std::size_t o = 0; o < layout_.outlets.size(); ++o) {
    const auto& [c, n, radius] = layout_.outlets[o];
    const double s = n[0] * (p.centre[0] - c[0]) + n[1] * (p.centre[1] - c[1]) + n[2] * (p.centre[2] - c[2]);
    if (s > p.beyond) {
      p.end = kOutlet + static_cast<int>(o);
      p.beyond = s;
      for (int d = 0; d < 3; ++d) {
        p.normal[d] = n[d];
        p.inside[d] = c[d];
      }
    }
  }
  return p;
}

bool FixOpenEnds::in_reach_of_end(int i) const {
  // Unwrapped, as LIGGGHTS has it: a feeder atom past the end is wrapped at the build that follows.
  return atom->x[i][2] + layout_.reach * atom->radius[i] >= domain->boxhi[2];
}

std::vector<int> FixOpenEnds::linked_sources() const {
  std::vector<int> linked;
  for (int i = 0; i < atom->nlocal; ++i)
    if (source_[i] != 0) linked.push_back(source_[i]);
  std::sort(linked.begin(), linked.end());
  return linked;
}

void FixOpenEnds::count_crossing(int from, int to, int type, std::vector<std::int64_t>& delta) const {
  // delta: straddling, then per type inserted, left_inlet, and left_outlet per outlet.
  const std::size_t types = counts_.types(), t = static_cast<std::size_t>(type);
  auto left_outlet = [&](int end) { return 1 + 2 * types + static_cast<std::size_t>(end - kOutlet) * types + t; };
  if (from != kNone) {  // back inside through `from`
    --delta[0];
    if (from == kInlet)
      ++delta[1 + t];
    else
      --delta[left_outlet(from)];
  }
  if (to != kNone) {  // out through `to`
    ++delta[0];
    if (to == kInlet)
      ++delta[1 + types + t];
    else
      ++delta[left_outlet(to)];
  }
}

void FixOpenEnds::apply(const std::vector<std::int64_t>& delta) {
  const std::size_t types = counts_.types();
  straddling_ += delta[0];
  for (std::size_t t = 0; t < types; ++t) {
    counts_.inserted[t] += delta[1 + t];
    counts_.left_inlet[t] += delta[1 + types + t];
  }
  for (std::size_t k = 0; k < counts_.left_outlet.size(); ++k) counts_.left_outlet[k] += delta[1 + 2 * types + k];
}

void FixOpenEnds::find_places(bool count) {
  std::vector<std::int64_t> delta(1 + 2 * counts_.types() + counts_.left_outlet.size(), 0);
  for (int i = 0; i < atom->nlocal; ++i) {
    phase_[i] = phase(place(atom->x[i]));
    count_crossing(kNone, phase_[i], atom->type[i], delta);
  }
  MPI_Allreduce(MPI_IN_PLACE, delta.data(), static_cast<int>(delta.size()), MPI_INT64_T, MPI_SUM, world);
  if (count) apply(delta);
  straddling_ = delta[0];
}

void FixOpenEnds::post_integrate() {
  replay_sources();
  hold_past_outlets();
  // The step's crossings of centres, counted; and whether an atom is to leave the DEM or a copy
  // to be made (the last slot).
  std::vector<std::int64_t> delta(1 + 2 * counts_.types() + counts_.left_outlet.size() + 1, 0);
  std::int64_t& due = delta.back();
  const std::vector<int> linked = linked_sources();
  double** x = atom->x;
  for (int i = 0; i < atom->nlocal; ++i) {
    const Place p = place(x[i]);
    if (p.end == kNone) {
      due += in_reach_of_end(i) && !std::binary_search(linked.begin(), linked.end(), atom->tag[i]);
      continue;
    }
    const int now = phase(p);
    if (now != phase_[i]) {
      count_crossing(phase_[i], now, atom->type[i], delta);
      phase_[i] = now;
    }
    due += now != kNone && p.beyond >= layout_.reach * atom->radius[i];
  }
  MPI_Allreduce(MPI_IN_PLACE, delta.data(), static_cast<int>(delta.size()), MPI_INT64_T, MPI_SUM, world);
  apply(delta);
  if (due) next_reneighbor = update->ntimestep;
}

void FixOpenEnds::hand_over() {
  // This rank's hand-overs, as (what, tag, type, inside) rows: an atom to leave the DEM (what: the
  // end it is past), or a feeder atom to copy (kFeederEnd; inside: its copy's centre is inside).
  std::vector<int> mine;
  std::vector<int> leaving;                  // local indices
  std::vector<std::array<int, 2>> spawning;  // (tag, local index) of this rank's feeder atoms to copy
  const std::vector<int> linked = linked_sources();
  const double period = domain->boxhi[2] - domain->boxlo[2];
  double** x = atom->x;
  for (int i = 0; i < atom->nlocal; ++i) {
    const Place p = place(x[i]);
    if (p.end == kNone) {
      if (!in_reach_of_end(i) || std::binary_search(linked.begin(), linked.end(), atom->tag[i])) continue;
      const double at[3] = {x[i][0] - layout_.shift_x, x[i][1], x[i][2] - period};
      mine.insert(mine.end(), {kFeederEnd, atom->tag[i], atom->type[i], outside(place(at)) ? 0 : 1});
      spawning.push_back({atom->tag[i], i});
    } else if (outside(p) && p.beyond >= layout_.reach * atom->radius[i]) {
      mine.insert(mine.end(), {p.end, atom->tag[i], atom->type[i], 0});
      leaving.push_back(i);
    }
  }
  const std::vector<int> all = gather_all(mine, world);
  if (all.empty()) return;

  std::vector<OpenEndsEvent> events;
  std::vector<std::array<int, 3>> sources;  // (source tag, type, inside) of the insertions
  for (std::size_t k = 0; k < all.size(); k += 4) {
    const int what = all[k], tag = all[k + 1], type = all[k + 2];
    if (what == kFeederEnd) {
      sources.push_back({tag, type, all[k + 3]});
      continue;
    }
    // Its centre's crossing was counted when it happened (post_integrate, or this set-up's places).
    if (what >= kOutlet)
      events.push_back({OpenEndsEvent::Kind::left_outlet, tag, type, 0, what - kOutlet});
    else
      events.push_back({OpenEndsEvent::Kind::left_inlet, tag, type, 0});
    --straddling_;
    free_.push_back(tag);
  }
  std::sort(events.begin(), events.end(), [](const auto& a, const auto& b) { return a.tag < b.tag; });
  std::sort(free_.begin(), free_.end(), std::greater<>());
  std::sort(sources.begin(), sources.end());
  const std::size_t removed = events.size();
  for (const auto& [source, type, inside] : sources) {
    events.push_back({OpenEndsEvent::Kind::inserted, take_free_tag(), type, source});
    // A copy made with its centre inside (REACH 0) has crossed the inlet; else it straddles.
    if (inside)
      ++counts_.inserted[type];
    else
      ++straddling_;
  }

  // No atom changes its index here (the fixes after this one, LIGGGHTS's contact history among
  // them, still read the lists' indices): the copies are appended, and the atoms leaving are put
  // beyond the box across x (not periodic, one rank across: `processors 1 1 *`), where LIGGGHTS's
  // exchange, next, drops them.
  for (std::size_t e = removed; e < events.size(); ++e) {
    const auto local =
        std::find_if(spawning.begin(), spawning.end(), [&](const auto& s) { return s[0] == events[e].source_tag; });
    if (local != spawning.end()) events[e].z = insert_copy((*local)[1], events[e].tag);
  }
  // Every rank's listener gets the copies' z (each copy is made on one rank).
  std::vector<double> z(events.size() - removed, 0.0);
  for (std::size_t e = removed; e < events.size(); ++e) z[e - removed] = events[e].z;
  MPI_Allreduce(MPI_IN_PLACE, z.data(), static_cast<int>(z.size()), MPI_DOUBLE, MPI_SUM, world);
  for (std::size_t e = removed; e < events.size(); ++e) events[e].z = z[e - removed];
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
  // only); a source found nowhere here lets its copy go. A copy replays its source while the
  // source is in reach of the feeder's end (the copy straddles the inlet) and over the buffer.
  const double end = domain->boxlo[2] + layout_.buffer;
  double** x = atom->x;
  double** v = atom->v;
  double** omega = atom->omega;
  for (int i = 0; i < atom->nlocal; ++i) {
    if (source_[i] == 0) continue;
    const int j = atom->map(source_[i]);
    if (j < 0 || j >= atom->nlocal ||
        !(in_reach_of_end(j) || (x[j][2] < end && x[j][2] >= domain->boxlo[2]))) {
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

void FixOpenEnds::hold_past_outlets() {
  double** x = atom->x;
  double** v = atom->v;
  for (int i = 0; i < atom->nlocal; ++i) {
    const Place p = place(x[i]);
    if (p.end < kOutlet || p.beyond < 0) continue;
    const auto& [c, n, radius] = layout_.outlets[static_cast<std::size_t>(p.end - kOutlet)];
    const double room = radius - atom->radius[i];
    if (!(radius > 0 && room > 0)) continue;
    double off[3];  // from the outlet's axis
    for (int d = 0; d < 3; ++d) off[d] = p.centre[d] - c[d] - p.beyond * n[d];
    const double r = std::sqrt(off[0] * off[0] + off[1] * off[1] + off[2] * off[2]);
    if (r <= room) continue;
    const double out = (v[i][0] * off[0] + v[i][1] * off[1] + v[i][2] * off[2]) / r;
    for (int d = 0; d < 3; ++d) {
      x[i][d] -= (1 - room / r) * off[d];
      if (out > 0) v[i][d] -= out * off[d] / r;
    }
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
  // Vessel atoms in the buffer or before the inlet, and feeder atoms at the same heights, over all
  // ranks: a pair at the same position but for the shift is a copy and its source (a copy has
  // its source's z as LIGGGHTS has it, wrapped or not, since it replays it).
  // In the vessel's frame (place()): LIGGGHTS wraps a copy and its source at the next build, not
  // at the step they cross the feeder's end.
  const double end = domain->boxlo[2] + layout_.buffer;
  auto replaying = [&](const double* x) { return place(x).centre[2] < end; };
  std::vector<double> mine;  // (tag, x, y, z) of either kind
  double** x = atom->x;
  for (int i = 0; i < atom->nlocal; ++i) {
    source_[i] = 0;
    if (replaying(x[i]) || (x[i][0] >= layout_.split_x && in_reach_of_end(i)))
      mine.insert(mine.end(), {static_cast<double>(atom->tag[i]), x[i][0], x[i][1], x[i][2]});
  }
  const std::vector<double> all = gather_all(mine, world);
  const double period = domain->boxhi[2] - domain->boxlo[2], tolerance = 1e-9 * period;
  // Along z to the period: a copy made since the last build is a period below its source.
  auto same_z = [&](double a, double b) { return std::abs(a - b - period * std::round((a - b) / period)) <= tolerance; };
  for (int i = 0; i < atom->nlocal; ++i) {
    if (x[i][0] >= layout_.split_x || !replaying(x[i])) continue;
    for (std::size_t k = 0; k < all.size(); k += 4)
      if (all[k + 1] >= layout_.split_x && std::abs(all[k + 1] - layout_.shift_x - x[i][0]) <= tolerance &&
          std::abs(all[k + 2] - x[i][1]) <= tolerance && same_z(all[k + 3], x[i][2])) {
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

double FixOpenEnds::insert_copy(int source, int tag) {
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
  source_[m] = atom->tag[source];
  phase_[m] = phase(place(at));
  copy_values(copied_, source, m);
  return at[2];
}

std::string open_ends_command(const OpenEndsLayout& layout) {
  std::string line =
      fmt::format("fix {} all {} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {}", kOpenEndsFix, kOpenEndsStyle,
                  layout.split_x, layout.shift_x, layout.buffer, layout.reach, layout.top, layout.outlets.size());
  for (const auto& [c, n, radius] : layout.outlets)
    line += fmt::format(" {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g} {:.17g}", c[0], c[1], c[2], n[0], n[1], n[2],
                        radius);
  return line;
}

LAMMPS_NS::Fix* create_open_ends(LAMMPS_NS::LAMMPS* lmp, int narg, char** arg) {
  return new FixOpenEnds(lmp, narg, arg);
}

}  // namespace hemo::particles::dem
