// Validation of the particles' feedback before the fluid uses it: a bad message must stop
// the fluid with one line that names the cause, never feed garbage into the solver.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <hemo/particle_feedback_t.hpp>

#include <string>

namespace hemo {

// Empty when the feedback fits this mesh and every value is usable; otherwise the reason, one
// line: wrong mesh hash, wrong sizes (n_cells, or n_source_values not 3 n_cells), non-finite
// values, solid fraction outside [0, max_solid), negative drag coefficient.
std::string feedback_problem(const particle_feedback_t& feedback, const std::string& mesh_hash, int n_cells,
                             double max_solid_fraction = 1.0);

}  // namespace hemo
