#include "io/trajectory_writer.hpp"

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <system_error>

#include "core/error.hpp"
#include "io/hdf5_util.hpp"
#include "swarmsim/version.hpp"

namespace swarmsim {

namespace fs = std::filesystem;

namespace {

// ~1 MiB chunks of whole frames
constexpr hsize_t kChunkAgents = 87381;

H5Handle createExtendible(hid_t group, const char* name, hid_t type, int rank, const hsize_t* dims,
                          const hsize_t* chunk, int compression) {
  hsize_t maxdims[3] = {H5S_UNLIMITED, 0, 0};
  for (int a = 1; a < rank; ++a) maxdims[a] = dims[a];
  H5Handle space(H5Screate_simple(rank, dims, maxdims), H5Sclose);
  H5Handle props(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
  H5Pset_chunk(props, rank, chunk);
  if (compression > 0) {
    H5Pset_shuffle(props);
    H5Pset_deflate(props, static_cast<unsigned>(compression));
  }
  H5Handle ds(H5Dcreate2(group, name, type, space, H5P_DEFAULT, props, H5P_DEFAULT), H5Dclose);
  if (!ds.valid()) throw OutputError(std::string("cannot create dataset '") + name + "'");
  return ds;
}

}  // namespace

TrajectoryWriter::TrajectoryWriter(const std::string& path, const Scenario& scenario,
                                   const std::vector<SwarmState>& swarms,
                                   const std::vector<std::vector<std::string>>& statNames, bool force)
    : path_(path) {
  h5::quietErrors();
  const fs::path target(path);
  std::error_code ec;
  if (fs::is_directory(target, ec)) throw OutputError(path + ": is a directory (expected an output file path)");
  if (fs::exists(target, ec) && !force) {
    throw OutputError(path + ": output file exists (use --force to overwrite)");
  }
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  fs::create_directories(dir, ec);
  if (ec) throw OutputError(path + ": cannot create folder " + dir.string() + ": " + ec.message());
  tmpPath_ = (dir / ("." + target.filename().string() + ".tmp-" + std::to_string(getpid()))).string();
  file_ = H5Handle(H5Fcreate(tmpPath_.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose);
  if (!file_.valid()) throw OutputError(path + ": cannot create output file in " + dir.string());

  try {
    // root attributes: enough to reproduce the run from the file alone
    h5::writeAttr(file_, "format", std::string(kFormatName));
    h5::writeAttr(file_, "format_version", static_cast<std::int64_t>(kFormatVersion));
    h5::writeAttr(file_, "swarmsim_version", std::string(kVersion));
    h5::writeAttr(file_, "scenario_name", scenario.name);
    h5::writeAttr(file_, "scenario", scenario.resolved.dump());
    h5::writeAttr(file_, "seed", scenario.seed);
    h5::writeAttr(file_, "dt", scenario.dt);
    h5::writeAttr(file_, "steps_per_frame", scenario.stepsPerFrame);
    h5::writeAttr(file_, "frame_dt", scenario.dt * static_cast<double>(scenario.stepsPerFrame));
    h5::writeAttr(file_, "frames", std::int64_t{0});
    h5::writeAttr(file_, "complete", std::int64_t{0});

    const hsize_t tdims[1] = {0}, tchunk[1] = {1024};
    time_ = createExtendible(file_, "time", H5T_IEEE_F64LE, 1, tdims, tchunk, 0);
    h5::writeAttr(time_, "units", std::string("s"));

    H5Handle group(H5Gcreate2(file_, "swarms", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
    const bool wantPos = std::count(scenario.output.quantities.begin(), scenario.output.quantities.end(), "position");
    const bool wantVel = std::count(scenario.output.quantities.begin(), scenario.output.quantities.end(), "velocity");
    for (std::size_t i = 0; i < swarms.size(); ++i) {
      const SwarmState& s = swarms[i];
      const SwarmSpec& spec = scenario.swarms[i];
      SwarmDatasets d;
      d.group = H5Handle(H5Gcreate2(group, s.name.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
      if (!d.group.valid()) throw OutputError("cannot create group for swarm '" + s.name + "'");
      h5::writeAttr(d.group, "model", spec.model);
      h5::writeAttr(d.group, "count", static_cast<std::int64_t>(s.size()));
      h5::writeAttr(d.group, "params", scenario.resolved["swarms"][i]["params"].dump());
      const hsize_t n = std::max<hsize_t>(1, s.size());
      const hsize_t dims[3] = {0, s.size(), 3};
      const hsize_t chunk[3] = {1, std::min(n, kChunkAgents), 3};
      if (wantPos) {
        d.position = createExtendible(d.group, "position", H5T_IEEE_F32LE, 3, dims, chunk, scenario.output.compression);
        h5::writeAttr(d.position, "units", std::string("m"));
      }
      if (wantVel) {
        d.velocity = createExtendible(d.group, "velocity", H5T_IEEE_F32LE, 3, dims, chunk, scenario.output.compression);
        h5::writeAttr(d.velocity, "units", std::string("m/s"));
      }
      // row r of position/velocity is agent id r
      std::vector<std::uint32_t> idRows(s.size());
      for (std::size_t r = 0; r < idRows.size(); ++r) idRows[r] = static_cast<std::uint32_t>(r);
      const hsize_t idims[1] = {s.size()};
      H5Handle ispace(H5Screate_simple(1, idims, nullptr), H5Sclose);
      H5Handle ids(H5Dcreate2(d.group, "id", H5T_STD_U32LE, ispace, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Dclose);
      if (!ids.valid() || H5Dwrite(ids, H5T_NATIVE_UINT32, H5S_ALL, H5S_ALL, H5P_DEFAULT, idRows.data()) < 0) {
        throw OutputError("cannot write ids of swarm '" + s.name + "'");
      }
      if (i < statNames.size() && !statNames[i].empty()) {
        H5Handle sg(H5Gcreate2(d.group, "stats", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
        for (const auto& name : statNames[i]) {
          d.stats.push_back(createExtendible(sg, name.c_str(), H5T_IEEE_F64LE, 1, tdims, tchunk, 0));
        }
      }
      swarms_.push_back(std::move(d));
    }
  } catch (const std::exception& e) {
    file_.reset();
    fs::remove(tmpPath_, ec);
    throw OutputError(path + ": " + e.what());
  }
}

TrajectoryWriter::~TrajectoryWriter() {
  if (finished_) return;
  swarms_.clear();
  time_.reset();
  file_.reset();
  std::error_code ec;
  fs::remove(tmpPath_, ec);
}

void TrajectoryWriter::appendVec3(hid_t dataset, const SwarmState& s, bool velocity) {
  const std::size_t n = s.size();
  frameBuffer_.resize(3 * n);
  const auto& x = velocity ? s.vx : s.px;
  const auto& y = velocity ? s.vy : s.py;
  const auto& z = velocity ? s.vz : s.pz;
  // rows are ordered by agent id, whatever order the model keeps agents in
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t r = s.id[i];
    frameBuffer_[3 * r] = x[i];
    frameBuffer_[3 * r + 1] = y[i];
    frameBuffer_[3 * r + 2] = z[i];
  }
  const hsize_t f = static_cast<hsize_t>(frames_);
  const hsize_t newDims[3] = {f + 1, n, 3};
  const hsize_t start[3] = {f, 0, 0}, count[3] = {1, n, 3};
  if (H5Dset_extent(dataset, newDims) < 0) throw OutputError(path_ + ": cannot extend dataset");
  H5Handle fspace(H5Dget_space(dataset), H5Sclose);
  H5Sselect_hyperslab(fspace, H5S_SELECT_SET, start, nullptr, count, nullptr);
  H5Handle mspace(H5Screate_simple(3, count, nullptr), H5Sclose);
  if (H5Dwrite(dataset, H5T_NATIVE_FLOAT, mspace, fspace, H5P_DEFAULT, frameBuffer_.data()) < 0) {
    throw OutputError(path_ + ": cannot write frame " + std::to_string(frames_) + " (disk full?)");
  }
}

void TrajectoryWriter::appendScalar(hid_t dataset, double value, const char* what) {
  const hsize_t f = static_cast<hsize_t>(frames_);
  const hsize_t newDims[1] = {f + 1}, start[1] = {f}, count[1] = {1};
  if (H5Dset_extent(dataset, newDims) < 0) throw OutputError(path_ + ": cannot extend dataset '" + what + "'");
  H5Handle fspace(H5Dget_space(dataset), H5Sclose);
  H5Sselect_hyperslab(fspace, H5S_SELECT_SET, start, nullptr, count, nullptr);
  H5Handle mspace(H5Screate_simple(1, count, nullptr), H5Sclose);
  if (H5Dwrite(dataset, H5T_NATIVE_DOUBLE, mspace, fspace, H5P_DEFAULT, &value) < 0) {
    throw OutputError(path_ + ": cannot write '" + what + "' of frame " + std::to_string(frames_));
  }
}

void TrajectoryWriter::writeFrame(double time, const std::vector<SwarmState>& swarms,
                                  const std::vector<std::vector<double>>& stats) {
  for (std::size_t i = 0; i < swarms.size(); ++i) {
    if (swarms_[i].position.valid()) appendVec3(swarms_[i].position, swarms[i], false);
    if (swarms_[i].velocity.valid()) appendVec3(swarms_[i].velocity, swarms[i], true);
    for (std::size_t k = 0; k < swarms_[i].stats.size(); ++k) {
      appendScalar(swarms_[i].stats[k], i < stats.size() && k < stats[i].size() ? stats[i][k] : 0.0, "stats");
    }
  }
  appendScalar(time_, time, "time");
  ++frames_;
}

void TrajectoryWriter::finish(bool interrupted) {
  h5::writeAttr(file_, "frames", frames_);
  h5::writeAttr(file_, "complete", std::int64_t{interrupted ? 0 : 1});
  h5::writeAttr(file_, "interrupted", std::int64_t{interrupted ? 1 : 0});
  swarms_.clear();
  time_.reset();
  if (H5Fclose(file_.release()) < 0) throw OutputError(path_ + ": cannot close output file (disk full?)");
  std::error_code ec;
  fs::rename(tmpPath_, path_, ec);
  if (ec) throw OutputError(path_ + ": cannot rename " + tmpPath_ + " to the output path: " + ec.message());
  finished_ = true;
}

}  // namespace swarmsim
