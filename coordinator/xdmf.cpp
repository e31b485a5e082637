// SPDX-License-Identifier: GPL-3.0-or-later
#include "xdmf.h"

#include "quiet_hdf5.h"

#include <fmt/format.h>
#include <hdf5.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <vector>

namespace hemo {

namespace {

struct SnapshotInfo {
  std::string name;
  double time_s = 0;
  hsize_t particles = 0;
  bool has_orientation = false;
};

std::vector<SnapshotInfo> scan(const std::string& h5_path) {
  const QuietHdf5 quiet;
  std::vector<SnapshotInfo> out;
  const hid_t file = H5Fopen(h5_path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (file < 0) throw std::runtime_error("cannot read " + h5_path);
  const hid_t group = H5Gopen2(file, "/snapshots", H5P_DEFAULT);
  hsize_t n = 0;
  if (group >= 0) H5Gget_num_objs(group, &n);
  for (hsize_t i = 0; i < n; ++i) {
    char name[64] = {0};
    H5Gget_objname_by_idx(group, i, name, sizeof name - 1);
    SnapshotInfo info{name};
    const hid_t snap = H5Gopen2(group, name, H5P_DEFAULT);
    const hid_t attr = H5Aopen(snap, "time_s", H5P_DEFAULT);
    const hid_t ids = H5Dopen2(snap, "id", H5P_DEFAULT);
    if (snap < 0 || attr < 0 || ids < 0) continue;  // a snapshot cut short by a crash: leave it out
    H5Aread(attr, H5T_NATIVE_DOUBLE, &info.time_s);
    const hid_t space = H5Dget_space(ids);
    H5Sget_simple_extent_dims(space, &info.particles, nullptr);
    info.has_orientation = H5Lexists(snap, "orientation", H5P_DEFAULT) > 0;
    H5Sclose(space);
    H5Dclose(ids);
    H5Aclose(attr);
    H5Gclose(snap);
    out.push_back(info);
  }
  if (group >= 0) H5Gclose(group);
  H5Fclose(file);
  return out;
}

std::string item(const std::string& path, hsize_t rows, int cols, const char* type, int precision) {
  const std::string dims = cols == 1 ? fmt::format("{}", rows) : fmt::format("{} {}", rows, cols);
  return fmt::format(
      R"(<DataItem Format="HDF" NumberType="{}" Precision="{}" Dimensions="{}">particles.h5:{}</DataItem>)", type,
      precision, dims, path);
}

}  // namespace

int write_paraview_sidecars(const std::string& run_dir) {
  namespace fs = std::filesystem;
  if (fs::is_directory(run_dir + "/fluid")) std::ofstream(run_dir + "/fluid/fluid.foam").flush();
  const std::string h5 = run_dir + "/particles.h5";
  if (!fs::exists(h5)) return 0;
  const auto snapshots = scan(h5);

  std::string xml = R"(<?xml version="1.0"?>
<Xdmf Version="3.0">
 <Domain>
  <Grid Name="particles" GridType="Collection" CollectionType="Temporal">
)";
  for (const auto& s : snapshots) {
    const std::string base = "/snapshots/" + s.name;
    xml += fmt::format(R"(   <Grid Name="step {}" GridType="Uniform">
    <Time Value="{:.17g}"/>
    <Topology TopologyType="Polyvertex" NumberOfElements="{}"/>
    <Geometry GeometryType="XYZ">{}</Geometry>
    <Attribute Name="id" AttributeType="Scalar" Center="Node">{}</Attribute>
    <Attribute Name="species" AttributeType="Scalar" Center="Node">{}</Attribute>
    <Attribute Name="velocity" AttributeType="Vector" Center="Node">{}</Attribute>
)",
                       s.name, s.time_s, s.particles, item(base + "/position", s.particles, 3, "Float", 8),
                       item(base + "/id", s.particles, 1, "Int", 8), item(base + "/species", s.particles, 1, "Char", 1),
                       item(base + "/velocity", s.particles, 3, "Float", 8));
    if (s.has_orientation)
      xml += fmt::format(R"(    <Attribute Name="orientation" AttributeType="Matrix" Center="Node">{}</Attribute>
)",
                         item(base + "/orientation", s.particles, 4, "Float", 8));
    xml += "   </Grid>\n";
  }
  xml += "  </Grid>\n </Domain>\n</Xdmf>\n";
  // Write beside, then rename: a reader never sees half a file.
  const std::string tmp = run_dir + "/.particles.xmf.tmp";
  std::ofstream(tmp) << xml;
  fs::rename(tmp, run_dir + "/particles.xmf");
  return static_cast<int>(snapshots.size());
}

}  // namespace hemo
