// SPDX-License-Identifier: GPL-3.0-or-later
#include "cell_partition.h"

#include <cstddef>
#include <stdexcept>

namespace hemo {

std::vector<double> slice_cells(const std::vector<double>& local, int per_cell, const std::vector<int>& local_index) {
  const std::size_t k = static_cast<std::size_t>(per_cell);
  const std::size_t n_local = k > 0 ? local.size() / k : 0;
  std::vector<double> out;
  out.reserve(k * local_index.size());
  for (int i : local_index) {
    if (i < 0 || static_cast<std::size_t>(i) >= n_local)
      throw std::invalid_argument("local cell " + std::to_string(i) + " is outside the rank's " +
                                  std::to_string(n_local) + " cells");
    out.insert(out.end(), local.begin() + static_cast<std::ptrdiff_t>(k * i),
               local.begin() + static_cast<std::ptrdiff_t>(k * i + k));
  }
  return out;
}

std::string cell_list_problem(const std::vector<int>& received, const std::vector<int>& expected) {
  std::size_t e = 0;
  for (std::size_t r = 0; r < received.size(); ++r) {
    const int cell = received[r];
    if (r > 0 && cell == received[r - 1]) return "cell " + std::to_string(cell) + " received twice";
    if (r > 0 && cell < received[r - 1])
      return "cell " + std::to_string(cell) + " received after cell " + std::to_string(received[r - 1]) +
             " (the cells must be ascending)";
    while (e < expected.size() && expected[e] < cell) ++e;
    if (e == expected.size() || expected[e] != cell) return "cell " + std::to_string(cell) + " was not expected";
    ++e;
  }
  if (received.size() == expected.size()) return {};
  // Every received cell is expected and they are distinct: some expected ones are missing.
  std::size_t r = 0;
  for (int cell : expected) {
    if (r < received.size() && received[r] == cell) {
      ++r;
      continue;
    }
    const std::size_t missing = expected.size() - received.size();
    return "cell " + std::to_string(cell) + " is missing" +
           (missing > 1 ? " (and " + std::to_string(missing - 1) + " more)" : std::string());
  }
  return {};  // not reached: more received than expected needs an unexpected or repeated cell
}

namespace {

template <class Put>
void put_cells(const std::vector<int>& cells, const std::vector<double>& values, int per_cell,
               std::vector<double>& whole, const Put& put) {
  const std::size_t k = static_cast<std::size_t>(per_cell);
  if (values.size() != k * cells.size())
    throw std::invalid_argument(std::to_string(values.size()) + " values for " + std::to_string(cells.size()) +
                                " cells of " + std::to_string(per_cell) + " values each");
  const std::size_t n_whole = k > 0 ? whole.size() / k : 0;
  for (int cell : cells)  // all checked before any is written: a refused message leaves `whole` as it was
    if (cell < 0 || static_cast<std::size_t>(cell) >= n_whole)
      throw std::invalid_argument("cell " + std::to_string(cell) + " is outside the mesh of " +
                                  std::to_string(n_whole) + " cells");
  for (std::size_t i = 0; i < cells.size(); ++i) {
    for (std::size_t j = 0; j < k; ++j) put(whole[k * static_cast<std::size_t>(cells[i]) + j], values[k * i + j]);
  }
}

}  // namespace

void assemble_cells(const std::vector<int>& cells, const std::vector<double>& values, int per_cell,
                    std::vector<double>& whole) {
  put_cells(cells, values, per_cell, whole, [](double& to, double v) { to = v; });
}

void add_cells(const std::vector<int>& cells, const std::vector<double>& values, int per_cell,
               std::vector<double>& whole) {
  put_cells(cells, values, per_cell, whole, [](double& to, double v) { to += v; });
}

}  // namespace hemo
