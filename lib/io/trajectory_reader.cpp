#include "io/trajectory_reader.hpp"

#include "core/error.hpp"
#include "io/hdf5_handle.hpp"
#include "io/hdf5_util.hpp"

namespace swarmsim {

namespace {

H5Handle openFile(const std::string& path) {
  h5::quietErrors();
  H5Handle f(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!f.valid()) throw InputError(path + ": cannot open as HDF5 (expected a swarmsim output file)");
  return f;
}

std::vector<hsize_t> datasetShape(hid_t ds) {
  H5Handle space(H5Dget_space(ds), H5Sclose);
  const int rank = H5Sget_simple_extent_ndims(space);
  std::vector<hsize_t> dims(static_cast<std::size_t>(std::max(rank, 0)));
  if (rank > 0) H5Sget_simple_extent_dims(space, dims.data(), nullptr);
  return dims;
}

template <typename T>
std::vector<T> readAll(const std::string& path, const std::string& dataset, hid_t memType,
                       std::vector<std::uint64_t>* shape) {
  H5Handle f = openFile(path);
  H5Handle ds(H5Dopen2(f, dataset.c_str(), H5P_DEFAULT), H5Dclose);
  if (!ds.valid()) throw InputError(path + ": no dataset '" + dataset + "'");
  const auto dims = datasetShape(ds);
  std::size_t total = 1;
  for (auto d : dims) total *= d;
  if (shape) shape->assign(dims.begin(), dims.end());
  std::vector<T> out(total);
  if (total > 0 && H5Dread(ds, memType, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()) < 0) {
    throw InputError(path + ": cannot read dataset '" + dataset + "'");
  }
  return out;
}

}  // namespace

nlohmann::json TrajectoryInfo::toJson() const {
  nlohmann::json j;
  j["path"] = path;
  j["format"] = format;
  j["format_version"] = formatVersion;
  j["swarmsim_version"] = swarmsimVersion;
  j["scenario_name"] = scenarioName;
  j["seed"] = seed;
  j["dt"] = dt;
  j["frame_dt"] = frameDt;
  j["steps_per_frame"] = stepsPerFrame;
  j["frames"] = frames;
  j["complete"] = complete;
  j["interrupted"] = interrupted;
  j["swarms"] = nlohmann::json::array();
  for (const auto& s : swarms) {
    j["swarms"].push_back({{"name", s.name}, {"model", s.model}, {"agents", s.agents}, {"frames", s.frames},
                           {"quantities", s.quantities}});
  }
  return j;
}

TrajectoryInfo readTrajectoryInfo(const std::string& path) {
  H5Handle f = openFile(path);
  TrajectoryInfo info;
  info.path = path;
  try {
    if (!h5::hasAttr(f, "format") || h5::readStringAttr(f, "format") != "swarmsim-trajectory") {
      throw InputError(path + ": not a swarmsim trajectory (no format attribute 'swarmsim-trajectory')");
    }
    info.format = h5::readStringAttr(f, "format");
    info.formatVersion = h5::readIntAttr(f, "format_version");
    info.swarmsimVersion = h5::readStringAttr(f, "swarmsim_version");
    info.scenarioName = h5::readStringAttr(f, "scenario_name");
    info.scenarioJson = h5::readStringAttr(f, "scenario");
    info.seed = h5::readUIntAttr(f, "seed");
    info.dt = h5::readDoubleAttr(f, "dt");
    info.frameDt = h5::readDoubleAttr(f, "frame_dt");
    info.stepsPerFrame = h5::readIntAttr(f, "steps_per_frame");
    info.frames = h5::readIntAttr(f, "frames");
    info.complete = h5::readIntAttr(f, "complete") != 0;
    info.interrupted = h5::hasAttr(f, "interrupted") && h5::readIntAttr(f, "interrupted") != 0;
    // swarms in scenario order
    const auto scenario = nlohmann::json::parse(info.scenarioJson);
    for (const auto& sw : scenario.at("swarms")) {
      SwarmInfo s;
      s.name = sw.at("name").get<std::string>();
      const std::string gpath = "swarms/" + s.name;
      H5Handle g(H5Gopen2(f, gpath.c_str(), H5P_DEFAULT), H5Gclose);
      if (!g.valid()) throw InputError(path + ": missing group '" + gpath + "'");
      s.model = h5::readStringAttr(g, "model");
      s.agents = h5::readIntAttr(g, "count");
      for (const char* q : {"position", "velocity"}) {
        if (H5Lexists(g, q, H5P_DEFAULT) > 0) {
          s.quantities.emplace_back(q);
          H5Handle ds(H5Dopen2(g, q, H5P_DEFAULT), H5Dclose);
          s.frames = static_cast<std::int64_t>(datasetShape(ds).at(0));
        }
      }
      info.swarms.push_back(s);
    }
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& e) {
    throw InputError(path + ": damaged swarmsim trajectory: " + e.what());
  }
  return info;
}

std::vector<float> readFloatDataset(const std::string& path, const std::string& dataset,
                                    std::vector<std::uint64_t>* shape) {
  return readAll<float>(path, dataset, H5T_NATIVE_FLOAT, shape);
}

std::vector<double> readDoubleDataset(const std::string& path, const std::string& dataset) {
  return readAll<double>(path, dataset, H5T_NATIVE_DOUBLE, nullptr);
}

}  // namespace swarmsim
