#include "io/scene_io.hpp"

#include <cstdio>

#include "core/error.hpp"
#include "geometry/tessellate.hpp"
#include "io/hdf5_util.hpp"
#include "io/trajectory_reader.hpp"

namespace swarmsim {

namespace {

H5Handle group(hid_t parent, const char* name) {
  H5Handle props(H5Pcreate(H5P_GROUP_CREATE), H5Pclose);
  H5Pset_obj_track_times(props, 0);  // no time stamps: identical runs give identical bytes
  H5Handle g(H5Gcreate2(parent, name, H5P_DEFAULT, props, H5P_DEFAULT), H5Gclose);
  if (!g.valid()) throw OutputError(std::string("cannot create group '") + name + "' (disk full?)");
  return g;
}

// a contiguous dataset of `rows` x `cols` values (cols 0: 1-D)
void writeArray(hid_t parent, const char* name, hid_t fileType, hid_t memType, hsize_t rows, hsize_t cols,
                const void* data) {
  const hsize_t dims[2] = {rows, cols};
  H5Handle space(H5Screate_simple(cols ? 2 : 1, dims, nullptr), H5Sclose);
  H5Handle props(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
  H5Pset_obj_track_times(props, 0);
  H5Handle ds(H5Dcreate2(parent, name, fileType, space, H5P_DEFAULT, props, H5P_DEFAULT), H5Dclose);
  if (!ds.valid() || (rows > 0 && H5Dwrite(ds, memType, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0)) {
    throw OutputError(std::string("cannot write dataset '") + name + "' (disk full?)");
  }
}

std::string numbered(std::size_t k) {
  char name[24];
  std::snprintf(name, sizeof name, "%04zu", k);
  return name;
}

void writeMesh(hid_t parent, const std::string& name, const std::string& type, const nlohmann::json& entry,
               const TriangleMesh& mesh) {
  H5Handle g = group(parent, name.c_str());
  h5::writeAttr(g, "type", type);
  h5::writeAttr(g, "params", entry.dump());
  std::vector<double> v;
  v.reserve(3 * mesh.vertices.size());
  for (const Vec3d& p : mesh.vertices) v.insert(v.end(), {p.x(), p.y(), p.z()});
  std::vector<std::uint32_t> f;
  f.reserve(3 * mesh.triangles.size());
  for (const auto& t : mesh.triangles) f.insert(f.end(), t.begin(), t.end());
  writeArray(g, "vertices", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, mesh.vertices.size(), 3, v.data());
  writeArray(g, "faces", H5T_STD_U32LE, H5T_NATIVE_UINT32, mesh.triangles.size(), 3, f.data());
}

template <typename T>
std::vector<T> readArray(hid_t parent, const char* name, hid_t memType, const std::string& where) {
  H5Handle ds(H5Dopen2(parent, name, H5P_DEFAULT), H5Dclose);
  if (!ds.valid()) throw InputError(where + ": no dataset '" + name + "'");
  H5Handle space(H5Dget_space(ds), H5Sclose);
  const hssize_t n = H5Sget_simple_extent_npoints(space);
  std::vector<T> out(static_cast<std::size_t>(n > 0 ? n : 0));
  if (n > 0 && H5Dread(ds, memType, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()) < 0) {
    throw InputError(where + ": cannot read dataset '" + name + "'");
  }
  return out;
}

// names of a group's members, in name order
std::vector<std::string> members(hid_t g) {
  std::vector<std::string> names;
  H5Literate(
      g, H5_INDEX_NAME, H5_ITER_INC, nullptr,
      [](hid_t, const char* name, const H5L_info_t*, void* data) -> herr_t {
        static_cast<std::vector<std::string>*>(data)->emplace_back(name);
        return 0;
      },
      &names);
  return names;
}

H5Handle openOutput(const std::string& path) {
  h5::quietErrors();
  readTrajectoryInfo(path);  // throws unless a swarmsim trajectory
  H5Handle f(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!f.valid()) throw InputError(path + ": cannot open as HDF5 (expected a swarmsim output file)");
  return f;
}

}  // namespace

void writeScene(hid_t file, const Scenario& scenario) {
  H5Handle scene = group(file, "scene");
  h5::writeAttr(scene, "up_axis", std::string("z"));
  h5::writeAttr(scene, "units", std::string("m"));
  H5Handle obstacles = group(scene, "obstacles");
  const nlohmann::json& entries = scenario.resolved.value("obstacles", nlohmann::json::array());
  std::size_t meshes = 0, spheres = 0, boxes = 0;
  for (std::size_t k = 0; k < entries.size(); ++k) {
    const std::string type = entries[k].value("type", "");
    const std::string name = numbered(k);
    if (type == "mesh") {
      writeMesh(obstacles, name, type, entries[k], scenario.obstacles->meshes.at(meshes++));
    } else if (type == "sphere") {
      writeMesh(obstacles, name, type, entries[k], sphereMesh(scenario.obstacles->spheres.at(spheres++)));
    } else {
      writeMesh(obstacles, name, type, entries[k], boxMesh(scenario.obstacles->boxes.at(boxes++)));
    }
  }
  H5Handle inputs = group(file, "inputs");
  if (!scenario.inputs) return;
  std::size_t k = 0;
  for (const auto& [path, bytes] : scenario.inputs->used()) {
    const std::string name = numbered(k++);
    writeArray(inputs, name.c_str(), H5T_STD_U8LE, H5T_NATIVE_UINT8, bytes->size(), 0, bytes->data());
    H5Handle ds(H5Dopen2(inputs, name.c_str(), H5P_DEFAULT), H5Dclose);
    h5::writeAttr(ds, "path", path);
  }
}

std::vector<SceneObstacle> readScene(const std::string& path) {
  H5Handle f = openOutput(path);
  std::vector<SceneObstacle> out;
  if (H5Lexists(f, "scene", H5P_DEFAULT) <= 0 || H5Lexists(f, "scene/obstacles", H5P_DEFAULT) <= 0) return out;
  H5Handle g(H5Gopen2(f, "scene/obstacles", H5P_DEFAULT), H5Gclose);
  for (const std::string& name : members(g)) {
    H5Handle o(H5Gopen2(g, name.c_str(), H5P_DEFAULT), H5Gclose);
    const std::string where = path + ": /scene/obstacles/" + name;
    if (!o.valid()) throw InputError(where + ": not a group");
    SceneObstacle s;
    s.name = name;
    try {
      s.type = h5::readStringAttr(o, "type");
      s.params = h5::readStringAttr(o, "params");
    } catch (const std::exception& e) {
      throw InputError(where + ": " + e.what());
    }
    s.vertices = readArray<double>(o, "vertices", H5T_NATIVE_DOUBLE, where);
    s.faces = readArray<std::uint32_t>(o, "faces", H5T_NATIVE_UINT32, where);
    const std::size_t nv = s.vertices.size() / 3;
    for (const std::uint32_t i : s.faces) {
      if (i >= nv) throw InputError(where + ": face index " + std::to_string(i) + " out of range");
    }
    out.push_back(std::move(s));
  }
  return out;
}

StoredScenario readStoredScenario(const std::string& path) {
  const TrajectoryInfo info = readTrajectoryInfo(path);
  StoredScenario s;
  try {
    s.scenario = nlohmann::json::parse(info.scenarioJson);
  } catch (const std::exception& e) {
    throw InputError(path + ": the stored scenario is not valid JSON (" + e.what() + ")");
  }
  s.inputs = std::make_shared<InputFiles>();
  H5Handle f = openOutput(path);
  if (H5Lexists(f, "inputs", H5P_DEFAULT) <= 0) return s;
  H5Handle g(H5Gopen2(f, "inputs", H5P_DEFAULT), H5Gclose);
  for (const std::string& name : members(g)) {
    const std::string where = path + ": /inputs/" + name;
    const std::vector<unsigned char> bytes = readArray<unsigned char>(g, name.c_str(), H5T_NATIVE_UINT8, where);
    H5Handle ds(H5Dopen2(g, name.c_str(), H5P_DEFAULT), H5Dclose);
    std::string file;
    try {
      file = h5::readStringAttr(ds, "path");
    } catch (const std::exception& e) {
      throw InputError(where + ": " + e.what());
    }
    s.inputs->embed(file, std::string(bytes.begin(), bytes.end()));
  }
  return s;
}

}  // namespace swarmsim
