// SPDX-License-Identifier: GPL-3.0-or-later
#include "surface_mesh.h"

#include <child_process.h>
#include <geometry.h>
#include <vessel_ends.h>

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace hemo {

namespace fs = std::filesystem;

namespace {

std::string header(const char* object) {
  return fmt::format(
      "FoamFile\n{{\n    version     2.0;\n    format      ascii;\n    class       dictionary;\n"
      "    object      {};\n}}\n\n",
      object);
}

void write_text(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream out(path);
  out << text;
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

std::string num(double v) { return fmt::format("{:.17g}", v); }

// The box around the surface: its bounding box grown by 1.5 cells on every side (so that no cell
// the vessel keeps touches the box's faces), in whole cells.
struct Background {
  Vec3 lo, hi;
  std::array<int, 3> cells;
};
Background background(const Surface& s, double h) {
  Background b;
  const Surface::Point lo = s.lower(), hi = s.upper();
  for (int c = 0; c < 3; ++c) {
    const double centre = (lo[c] + hi[c]) / 2;
    const int n = static_cast<int>(std::ceil((hi[c] - lo[c]) / h + 3));
    b.cells[static_cast<std::size_t>(c)] = n;
    b.lo[static_cast<std::size_t>(c)] = centre - n * h / 2;
    b.hi[static_cast<std::size_t>(c)] = centre + n * h / 2;
  }
  return b;
}

std::string block_mesh_dict(const Background& b) {
  std::string v;
  for (int k = 0; k < 2; ++k)
    for (int j = 0; j < 4; ++j) {
      const double x = (j == 1 || j == 2) ? b.hi[0] : b.lo[0], y = j >= 2 ? b.hi[1] : b.lo[1];
      v += fmt::format("    ({} {} {})\n", num(x), num(y), num(k ? b.hi[2] : b.lo[2]));
    }
  return header("blockMeshDict") + "convertToMeters 1;\n\nvertices\n(\n" + v + ");\n\nblocks\n(\n" +
         fmt::format("    hex (0 1 2 3 4 5 6 7) ({} {} {}) simpleGrading (1 1 1)\n", b.cells[0], b.cells[1],
                     b.cells[2]) +
         ");\n\nedges ();\n\nboundary\n(\n    background\n    {\n        type patch;\n        faces\n        (\n"
         "            (3 7 6 2) (0 4 7 3) (2 6 5 1) (1 5 4 0) (0 3 2 1) (4 5 6 7)\n        );\n    }\n);\n";
}

std::string snappy_dict(const Surface& s, const SurfaceMeshSpec& spec) {
  std::string renames, regions;
  for (const auto& name : s.region_names) {
    renames += fmt::format("            {} {{ name {}; }}\n", name, name);
    if (name != surface_region::wall)
      regions += fmt::format("                {} {{ level (0 0); patchInfo {{ type patch; }} }}\n", name);
  }
  const auto& p = spec.location_in_mesh;
  // No refinement (level 0): the cells are the box's cubes, the wall snapped; no layers. The
  // quality controls are snappyHexMesh's usual ones, with the absolute minimum cell volume and
  // tetrahedron quality off: ours are micrometre cells, 1e-18 m^3, below the usual 1e-13.
  return header("snappyHexMeshDict") +
         "castellatedMesh true;\nsnap            true;\naddLayers       false;\n\n"
         "geometry\n{\n    vessel.stl\n    {\n        type triSurfaceMesh;\n        name vessel;\n"
         "        regions\n        {\n" +
         renames +
         "        }\n    }\n}\n\n"
         "castellatedMeshControls\n{\n    maxLocalCells 10000000;\n    maxGlobalCells 20000000;\n"
         "    minRefinementCells 0;\n    maxLoadUnbalance 0.10;\n    nCellsBetweenLevels 2;\n    features ();\n"
         "    refinementSurfaces\n    {\n        vessel\n        {\n            level (0 0);\n"
         "            patchInfo { type wall; }\n            regions\n            {\n" +
         regions + "            }\n        }\n    }\n    resolveFeatureAngle 30;\n    refinementRegions {}\n" +
         fmt::format("    locationInMesh ({} {} {});\n", num(p[0]), num(p[1]), num(p[2])) +
         "    allowFreeStandingZoneFaces true;\n}\n\n"
         "snapControls\n{\n    nSmoothPatch 3;\n    tolerance 2.0;\n    nSolveIter 30;\n    nRelaxIter 5;\n"
         "    nFeatureSnapIter 10;\n    implicitFeatureSnap true;\n    explicitFeatureSnap false;\n"
         "    multiRegionFeatureSnap true;\n}\n\n"
         "addLayersControls\n{\n    relativeSizes true;\n    layers {}\n    expansionRatio 1.0;\n"
         "    finalLayerThickness 0.3;\n    minThickness 0.1;\n    nGrow 0;\n    featureAngle 60;\n"
         "    nRelaxIter 3;\n    nSmoothSurfaceNormals 1;\n    nSmoothNormals 3;\n    nSmoothThickness 10;\n"
         "    maxFaceThicknessRatio 0.5;\n    maxThicknessToMedialRatio 0.3;\n    minMedialAxisAngle 90;\n"
         "    nBufferCellsNoExtrude 0;\n    nLayerIter 50;\n}\n\n"
         "meshQualityControls\n{\n    maxNonOrtho 65;\n    maxBoundarySkewness 20;\n    maxInternalSkewness 4;\n"
         "    maxConcave 80;\n    minVol 1e-30;\n    minTetQuality 1e-30;\n    minArea -1;\n    minTwist 0.02;\n"
         "    minDeterminant 0.001;\n    minFaceWeight 0.05;\n    minVolRatio 0.01;\n    minTriangleTwist -1;\n"
         "    nSmoothScale 4;\n    errorReduction 0.75;\n}\n\nmergeTolerance 1e-6;\n";
}

void run_tool(const std::string& case_dir, const std::vector<std::string>& argv, const std::string& log_name) {
  const char* project = std::getenv("WM_PROJECT_DIR");
  ChildOptions opt;
  opt.env = {{"WM_PROJECT_DIR", project != nullptr && *project != '\0' ? project : "/usr/share/openfoam"}};
  std::vector<std::string> args = argv;
  args.insert(args.end(), {"-case", case_dir});
  const fs::path log = fs::path(case_dir) / log_name;
  std::ofstream out(log);
  std::string last_error;
  opt.on_line = [&](const std::string& line) {
    out << line << '\n';
    if (line.find("FOAM FATAL") != std::string::npos || line.find("Error") != std::string::npos) last_error = line;
  };
  opt.merge_stderr = true;
  const ChildResult r = run_child(args, opt);
  if (!r.ok())
    throw std::runtime_error(fmt::format("{} {} meshing the surface vessel (see {}){}", argv[0], r.describe(),
                                         log.string(), last_error.empty() ? "" : ": " + last_error));
}

// The tokens of an OpenFOAM ASCII file after its FoamFile header: words, and ( ) { } ; alone.
class Tokens {
 public:
  explicit Tokens(const fs::path& path) : path_(path) {
    std::ifstream in(path);
    if (!in) throw std::runtime_error("cannot read " + path.string());
    std::stringstream ss;
    ss << in.rdbuf();
    const std::string text = ss.str();
    for (std::size_t i = 0; i < text.size();) {
      const char c = text[i];
      if (std::isspace(static_cast<unsigned char>(c))) {
        ++i;
      } else if (text.compare(i, 2, "//") == 0) {
        i = text.find('\n', i);
        if (i == std::string::npos) i = text.size();
      } else if (text.compare(i, 2, "/*") == 0) {
        i = text.find("*/", i);
        i = i == std::string::npos ? text.size() : i + 2;
      } else if (std::string("(){};").find(c) != std::string::npos) {
        tokens_.emplace_back(1, c);
        ++i;
      } else {
        std::size_t j = i;
        while (j < text.size() && !std::isspace(static_cast<unsigned char>(text[j])) &&
               std::string("(){};").find(text[j]) == std::string::npos)
          ++j;
        tokens_.push_back(text.substr(i, j - i));
        i = j;
      }
    }
    if (!tokens_.empty() && tokens_[0] == "FoamFile") {  // skip the header's { ... }
      pos_ = 1;
      int depth = 0;
      do {
        const std::string& t = next();
        depth += t == "{" ? 1 : t == "}" ? -1 : 0;
      } while (depth > 0);
    }
  }
  const std::string& next() {
    if (pos_ >= tokens_.size()) fail("ends early");
    return tokens_[pos_++];
  }
  const std::string& peek() {
    if (pos_ >= tokens_.size()) fail("ends early");
    return tokens_[pos_];
  }
  void expect(const char* t) {
    if (next() != t) fail(std::string("expected '") + t + "'");
  }
  long integer() {
    const std::string& t = next();
    char* end = nullptr;
    const long v = std::strtol(t.c_str(), &end, 10);
    if (end == t.c_str() || *end != '\0') fail("expected an integer, found '" + t + "'");
    return v;
  }
  double real() {
    const std::string& t = next();
    char* end = nullptr;
    const double v = std::strtod(t.c_str(), &end);
    if (end == t.c_str() || *end != '\0') fail("expected a number, found '" + t + "'");
    return v;
  }
  [[noreturn]] void fail(const std::string& why) const {
    throw std::runtime_error(path_.string() + ": " + why + " (not an ASCII OpenFOAM list we read)");
  }

 private:
  fs::path path_;
  std::vector<std::string> tokens_;
  std::size_t pos_ = 0;
};

std::vector<int> read_labels(const fs::path& path) {
  Tokens t(path);
  const long n = t.integer();
  t.expect("(");
  std::vector<int> v(static_cast<std::size_t>(n));
  for (auto& x : v) x = static_cast<int>(t.integer());
  t.expect(")");
  return v;
}

// An OpenFOAM list of named dictionaries, `N ( name { ... } ... )` (polyMesh's boundary and
// cellZones): `entry(name)` reads each dictionary's keys, up to its closing brace.
template <class Entry>
void read_named_dictionaries(Tokens& t, Entry&& entry) {
  const long n = t.integer();
  t.expect("(");
  for (long i = 0; i < n; ++i) {
    const std::string name = t.next();
    t.expect("{");
    entry(name);
    t.expect("}");
  }
  t.expect(")");
}

}  // namespace

PolyMesh read_polymesh(const std::string& case_dir) {
  const fs::path dir = fs::path(case_dir) / "constant" / "polyMesh";
  PolyMesh m;
  {
    Tokens t(dir / "points");
    const long n = t.integer();
    t.expect("(");
    m.points.resize(static_cast<std::size_t>(n));
    for (auto& p : m.points) {
      t.expect("(");
      for (double& c : p) c = t.real();
      t.expect(")");
    }
    t.expect(")");
  }
  {
    Tokens t(dir / "faces");
    const long n = t.integer();
    t.expect("(");
    m.faces.resize(static_cast<std::size_t>(n));
    for (auto& f : m.faces) {
      f.resize(static_cast<std::size_t>(t.integer()));
      t.expect("(");
      for (int& p : f) p = static_cast<int>(t.integer());
      t.expect(")");
    }
    t.expect(")");
  }
  m.owner = read_labels(dir / "owner");
  m.neighbour = read_labels(dir / "neighbour");
  if (m.owner.size() != m.faces.size())
    throw std::runtime_error(
        fmt::format("{}: {} owners for {} faces", (dir / "owner").string(), m.owner.size(), m.faces.size()));
  int cells = 0;
  for (int c : m.owner) cells = std::max(cells, c + 1);
  for (int c : m.neighbour) cells = std::max(cells, c + 1);
  m.n_cells = cells;
  {
    Tokens t(dir / "boundary");
    read_named_dictionaries(t, [&](const std::string& name) {
      PatchInfo p;
      p.name = name;
      while (t.peek() != "}") {
        const std::string key = t.next();
        std::vector<std::string> value;
        while (t.peek() != ";") value.push_back(t.next());
        t.expect(";");
        if (key == "type" && value.size() == 1) p.type = value[0];
        if (key == "nFaces" && value.size() == 1) p.size = std::stoi(value[0]);
        if (key == "startFace" && value.size() == 1) p.start = std::stoi(value[0]);
        if (key == "samplePatch" && value.size() == 1) p.sample_patch = value[0];
        if (key == "offset" && value.size() == 5 && value[0] == "(" && value[4] == ")")
          for (std::size_t c = 0; c < 3; ++c) p.sample_offset[c] = std::stod(value[c + 1]);
      }
      m.patches.push_back(p);
    });
  }
  // Cell zones as write_polymesh writes them: each a run of consecutive cells (a fed vessel's
  // feeder), which is all a PolyMesh holds.
  if (fs::exists(dir / "cellZones")) {
    Tokens t(dir / "cellZones");
    read_named_dictionaries(t, [&](const std::string& name) {
      CellZone z;
      z.name = name;
      while (t.peek() != "}") {
        const std::string key = t.next();
        if (key != "cellLabels") {
          while (t.next() != ";") {
          }
          continue;
        }
        if (t.next() != "List<label>") t.fail("expected the cellLabels of zone " + z.name + " as a List<label>");
        z.size = static_cast<int>(t.integer());
        t.expect("(");
        for (int k = 0; k < z.size; ++k) {
          const long c = t.integer();
          if (k == 0) z.first = static_cast<int>(c);
          if (c != z.first + k) t.fail("zone " + z.name + " is not a run of consecutive cells");
        }
        t.expect(")");
        t.expect(";");
      }
      m.cell_zones.push_back(z);
    });
  }
  return m;
}

Vec3 point_inside_from_inlet(const Surface& surface) {
  const int inlet = surface.region_index(surface_region::inlet);
  if (inlet < 0) throw std::invalid_argument("the surface has no inlet region");
  const Surface::Point a = surface.area_vector(inlet);
  const double radius = std::sqrt(surface.area(inlet) / 3.14159265358979323846);
  const Surface::Point p = surface.centroid(inlet) - a.normalized() * radius / 3;
  return {p.x(), p.y(), p.z()};
}

PolyMesh mesh_surface(const Surface& surface, const SurfaceMeshSpec& spec, const std::string& case_dir) {
  if (!(spec.cell_size > 0)) throw std::invalid_argument("the surface mesh needs a positive cell size");
  check_surface(surface);
  const fs::path dir(case_dir);
  const Background box = background(surface, spec.cell_size);
  const long cells = 1L * box.cells[0] * box.cells[1] * box.cells[2];
  if (cells > 20'000'000)
    throw std::invalid_argument(
        fmt::format("the surface mesh's box would have {} cells of {:.3g} um (at most "
                    "20,000,000): use larger cells",
                    cells, spec.cell_size * 1e6));
  fs::create_directories(dir / "constant" / "triSurface");
  write_stl((dir / "constant" / "triSurface" / "vessel.stl").string(), surface);
  write_text(dir / "system" / "controlDict",
             header("controlDict") +
                 "application     snappyHexMesh;\nstartFrom       startTime;\nstartTime       0;\n"
                 "stopAt          endTime;\nendTime         1;\ndeltaT          1;\nwriteControl    timeStep;\n"
                 "writeInterval   1;\nwriteFormat     ascii;\nwritePrecision  17;\nwriteCompression off;\n"
                 "timeFormat      general;\ntimePrecision   6;\nrunTimeModifiable false;\n");
  write_text(dir / "system" / "fvSchemes",
             header("fvSchemes") +
                 "ddtSchemes { default Euler; }\ngradSchemes { default Gauss linear; }\n"
                 "divSchemes { default none; }\nlaplacianSchemes { default Gauss linear corrected; }\n"
                 "interpolationSchemes { default linear; }\nsnGradSchemes { default corrected; }\n");
  write_text(dir / "system" / "fvSolution", header("fvSolution"));
  write_text(dir / "system" / "blockMeshDict", block_mesh_dict(box));
  write_text(dir / "system" / "snappyHexMeshDict", snappy_dict(surface, spec));
  run_tool(case_dir, {"blockMesh"}, "log.blockMesh");
  run_tool(case_dir, {"snappyHexMesh", "-overwrite"}, "log.snappyHexMesh");

  PolyMesh mesh = read_polymesh(case_dir);
  // snappyHexMesh's own level and zone files: nothing of ours reads them.
  for (const char* extra :
       {"cellLevel", "pointLevel", "level0Edge", "surfaceIndex", "cellZones", "faceZones", "pointZones"})
    fs::remove(dir / "constant" / "polyMesh" / extra);
  std::vector<PatchInfo> kept;
  for (const PatchInfo& p : mesh.patches) {
    const bool region = surface.region_index(p.name) >= 0;
    if (!region && p.size == 0) continue;  // the box's patch, gone with the box's cells
    if (!region)
      throw std::runtime_error(
          fmt::format("the surface mesh has {} faces on patch '{}', not one of the surface's "
                      "regions: the vessel reaches its background box",
                      p.size, p.name));
    kept.push_back(p);
  }
  mesh.patches = kept;
  for (const auto& name : surface.region_names) {
    const auto it =
        std::find_if(mesh.patches.begin(), mesh.patches.end(), [&](const PatchInfo& p) { return p.name == name; });
    if (it == mesh.patches.end() || it->size == 0)
      throw std::runtime_error(
          fmt::format("snappyHexMesh made no faces of region '{}' (cells of {:.3g} um; see {}): "
                      "use smaller cells (mesh.surface_cell_size_um)",
                      name, spec.cell_size * 1e6, (dir / "log.snappyHexMesh").string()));
  }
  return mesh;
}

PolyMesh surface_vessel_mesh(const Scene& scene, const std::string& case_dir, bool mesh) {
  if (!mesh) return read_polymesh(case_dir);
  const Surface surface = make_vessel_surface(scene.vessel);
  SurfaceMeshSpec spec;
  spec.cell_size = surface_cell_size(scene);
  spec.location_in_mesh = point_inside_from_inlet(surface);
  PolyMesh vessel = mesh_surface(surface, spec, case_dir);
  if (fed_by_feeder(scene.vessel))
    append_feeder(vessel, feeder_layout(scene), scene.mesh, {}, FeederSampling::overlap_of_faces);
  return vessel;
}

}  // namespace hemo
