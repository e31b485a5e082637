// The per-cell values of the partitioned exchange (docs/notes/partitioned-exchange.md): a fluid
// rank sends each particle rank the cells it takes from it (from[p][f] of model/overlap_map.h),
// as the cells' ids (the whole mesh's, ascending) and, per field, k values per cell in that
// order; the particle rank checks the ids against what it expects and writes the values into
// whole-mesh arrays, where the rest of the node finds them at their global index as before.
// The feedback goes back the same way, its partial sums added where the state's values are
// written.
// Engine-free and message-free: plain ids and flat arrays (k values per cell, cell c's at
// [k c, k c + k), as the messages carry them: messages/cell_fields.h).
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <string>
#include <vector>

namespace hemo {

// The values of the cells at `local_index` of a rank's own arrays (k = per_cell values per local
// cell), in that order. Throws std::invalid_argument with one line on an index outside `local`.
std::vector<double> slice_cells(const std::vector<double>& local, int per_cell, const std::vector<int>& local_index);

// Empty when `received` is `expected` (ascending) cell for cell; else one line naming the first
// difference: a cell received twice, one out of order, one not expected, or one missing (with how
// many more are missing).
std::string cell_list_problem(const std::vector<int>& received, const std::vector<int>& expected);

// Writes `values` (per_cell values for each of `cells`, in that order) into `whole` (per_cell
// values per cell of the mesh) at the cells' places; the rest of `whole` is left as it is. Throws
// std::invalid_argument with one line when the values do not fit the cells or a cell is outside
// the mesh.
void assemble_cells(const std::vector<int>& cells, const std::vector<double>& values, int per_cell,
                    std::vector<double>& whole);
// The same, adding `values` to what `whole` holds at the cells' places (the feedback's partial
// sums, one per particle rank, coming together on a fluid rank).
void add_cells(const std::vector<int>& cells, const std::vector<double>& values, int per_cell,
               std::vector<double>& whole);

}  // namespace hemo
