// The fluid mesh of a vessel given as a closed surface (model/surface.h; docs/design.md, "Surface
// vessels"), made by OpenFOAM's own tools run as processes: blockMesh fills a box around the
// surface with cubes of the asked size, snappyHexMesh keeps the cubes of the vessel's side
// (castellation, from a point inside it) and snaps their outer faces onto the surface; each of
// the surface's regions becomes the patch of its name ("wall" a wall, the others open ends). The
// result is read back into a PolyMesh, so that the node's case writer and mesh message treat it
// as they treat the O-grid.
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include "vessel_mesh.h"

#include <surface.h>

#include <string>

namespace hemo {

struct SurfaceMeshSpec {
  double cell_size = 0;            // m, the background box's cubes (no refinement at the surface)
  Vec3 location_in_mesh{0, 0, 0};  // a point inside the vessel, off the box's cell faces
};

// Writes the surface as constant/triSurface/vessel.stl and system/{controlDict, blockMeshDict,
// snappyHexMeshDict, fvSchemes, fvSolution} under `case_dir`, runs blockMesh and
// snappyHexMesh -overwrite there (their output in log.blockMesh, log.snappyHexMesh), and returns
// the mesh they made: every region of the surface a non-empty patch of its name, type "wall" for
// the wall and "patch" for the others, and nothing else (the box's own patch, empty once the
// box's cells outside the vessel are gone, is dropped). Throws std::runtime_error with one line
// when a tool fails (naming its log) or a region did not become a patch with faces. The tools get
// WM_PROJECT_DIR (Debian's OpenFOAM needs it while its libraries load): this process's, else
// /usr/share/openfoam.
PolyMesh mesh_surface(const Surface& surface, const SurfaceMeshSpec& spec, const std::string& case_dir);

// A point to castellate from: the inlet's centroid moved into the vessel along its inward normal
// by a third of the inlet's equivalent radius (sqrt(A / pi)).
Vec3 point_inside_from_inlet(const Surface& surface);

// The fluid mesh of a scene's surface vessel (model/geometry.h, make_vessel_surface): meshed in
// `case_dir` with cells of mesh.surface_cell_size_um (0: the vessel's diameter / 12) from a point
// inside its inlet, a fed inlet's feeder appended (append_feeder, feeder_layout(scene)), or, when
// `mesh` is false (a resumed run), read back from the case as write_case wrote it.
PolyMesh surface_vessel_mesh(const Scene& scene, const std::string& case_dir, bool mesh);

// Reads an ASCII constant/polyMesh (points, faces, owner, neighbour, boundary, and cellZones when
// there is one) under `case_dir`: a mapped patch's uniform offset, and zones of consecutive cells.
// Throws std::runtime_error naming the file on anything it cannot read.
PolyMesh read_polymesh(const std::string& case_dir);

}  // namespace hemo
