// The fluid mesh of the vessel: an O-grid disk (square core and four ring blocks) extruded along
// z, each axial station's section scaled to the vessel shape's local radius R(z)
// (model/geometry.h; the wall polygon's sides tangent to, or corners on, that station's circle),
// generated in plain C++ in OpenFOAM's polyMesh order, written as constant/polyMesh and packed
// into the mesh message the particle node locates particles with. A periodic vessel's ends are a
// cyclic pair; an open vessel's are an inlet and an outlet, and a feeder inlet adds the feeder
// vessel as a second, disconnected region of the same mesh (model/vessel_ends.h).
// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once

#include <scene.h>
#include <vessel_ends.h>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace hemo {

class mesh_t;

using Vec3 = std::array<double, 3>;

// Shape of the O-grid cross-section (dimensionless, relative to the radius R).
struct OGridShape {
  double core_half_width = 0.55;  // half-width of the core square, in R
  double core_rounding = 0.4;     // 0: straight core edges, 1: core edges on a circle
};

struct PatchInfo {
  std::string name;
  std::string type;          // "wall", "cyclic", "patch" (open end) or "mappedPatch" (fed inlet)
  int start = 0;             // first face
  int size = 0;              // number of faces
  std::string neighbour;     // cyclic partner patch
  Vec3 separation{0, 0, 0};  // cyclic: neighbour face centre minus this face centre
  // mappedPatch. Without a sample patch (nearestCell): each face takes the value of the cell
  // holding its centre + sample_offset. With one (nearestPatchFaceAMI): each face takes the
  // area-weighted mean of that patch's face values over its overlap with them, once the sample
  // patch's points are moved by sample_offset onto this patch.
  Vec3 sample_offset{0, 0, 0};
  std::string sample_patch{};
};

// Cells [first, first + size) under a name (constant/polyMesh/cellZones).
struct CellZone {
  std::string name;
  int first = 0, size = 0;
};

// An unstructured polyhedral mesh in OpenFOAM order: internal faces first, upper-triangular
// (sorted by owner, then neighbour, owner < neighbour, normal from owner to neighbour), then
// boundary faces patch by patch with outward normals.
struct PolyMesh {
  std::vector<Vec3> points;
  std::vector<std::vector<int>> faces;
  std::vector<int> owner;
  std::vector<int> neighbour;  // size = number of internal faces
  std::vector<PatchInfo> patches;
  std::vector<CellZone> cell_zones;  // the feeder's cells; none in a periodic vessel
  int n_cells = 0;

  int n_internal_faces() const { return static_cast<int>(neighbour.size()); }
  int n_faces() const { return static_cast<int>(faces.size()); }
  const PatchInfo& patch(const std::string& name) const;  // throws if absent
};

// Geometry computed the way OpenFOAM does (face centres and area vectors from triangles about
// the point average; cell centres and volumes from pyramids about the face-centre average).
struct MeshGeometry {
  std::vector<Vec3> face_centres;
  std::vector<Vec3> face_areas;  // area-weighted normals
  std::vector<Vec3> cell_centres;
  std::vector<double> cell_volumes;
};

// Patch names of the vessel mesh.
namespace patch_name {
inline constexpr const char* wall = "wall";
inline constexpr const char* inlet = "inlet";    // z = 0: cyclic partner of outlet, or an open inlet
inline constexpr const char* outlet = "outlet";  // z = length
// The feeder of a fed open vessel: its wall and its own cyclic pair.
inline constexpr const char* feeder_wall = "feeder_wall";
inline constexpr const char* feeder_inlet = "feeder_inlet";
inline constexpr const char* feeder_outlet = "feeder_outlet";
// Whether a patch is an outlet holding p = 0: the O-grid's "outlet", a surface vessel's
// "outlet_1", "outlet_2", ... (model/surface.h).
inline bool is_outlet(const std::string& name) { return name == outlet || name.rfind("outlet_", 0) == 0; }
}  // namespace patch_name

// The cell zone of the feeder's cells, the only ones the body force G drives in an open vessel.
inline constexpr const char* feeder_zone = "feeder";

// Generates the O-grid vessel mesh: the vessel's cells first (the same mesh, to the bit, whatever
// its ends), then the feeder's when it has one. Throws std::invalid_argument on impossible input.
PolyMesh make_vessel_mesh(const Vessel& vessel, const MeshSpec& spec, const OGridShape& shape = {});

// How a fed inlet takes the feeder's section: the O-grid's inlet faces each lie at the same
// section position as one cell of the feeder's (the same O-grid), so each samples the feeder's
// last-layer cell above it; a surface vessel's snapped faces match none of the feeder's, so they
// take the feeder's end faces' values weighted by their overlaps (OpenFOAM's AMI), which moves
// the feeder's flux through the inlet's footprint onto the inlet whole, where sampling one cell
// per face would weigh each cell's velocity by the area of the faces whose centres it holds.
enum class FeederSampling { cell_above_face, overlap_of_faces };

// Appends the feeder of `layout` (model/vessel_ends.h) to a vessel's mesh whose inlet patch lies
// in the plane z = layout.inlet_z: the O-grid of `spec` and `shape` of the feeder's radius,
// layout.layers layers over its period, moved so that its axis runs parallel to z through
// (axis_x, inlet_y) from z = inlet_z, as a disconnected region after the vessel's (its cells the
// zone `feeder_zone`, its patches feeder_wall and the cyclic pair feeder_inlet / feeder_outlet).
// The inlet becomes a mapped patch taking the feeder's section at the same offset from its axis
// as from the inlet's centre: the feeder's flow is the same in every layer (periodic, uniform
// along z), so its end section is any one of them. cell_above_face: the last-layer cell holding
// each face centre moved there (nearestCell); overlap_of_faces: the faces of feeder_inlet moved
// onto the inlet, their values weighted by their overlaps with each inlet face
// (nearestPatchFaceAMI). Throws std::invalid_argument without an inlet patch.
void append_feeder(PolyMesh& mesh, const FeederLayout& layout, const MeshSpec& spec, const OGridShape& shape = {},
                   FeederSampling sampling = FeederSampling::cell_above_face);

MeshGeometry compute_geometry(const PolyMesh& mesh);

// Smallest edge length of any face: a lower bound of the cell size used for the
// unresolved-coupling check (particle diameter / cell size < 1).
double min_edge_length(const PolyMesh& mesh);

// Short hex fingerprint (FNV-1a 64) of points, faces, owner, neighbour and patches.
std::string mesh_hash(const PolyMesh& mesh);

// Writes constant/polyMesh/{points,faces,owner,neighbour,boundary} under `case_dir`
// (creating directories), ASCII, full precision.
void write_polymesh(const PolyMesh& mesh, const std::string& case_dir);

// Fills the mesh message (everything except the envelope).
void fill_mesh_message(const PolyMesh& mesh, const MeshGeometry& geometry, const Vessel& vessel, mesh_t& msg);

}  // namespace hemo
