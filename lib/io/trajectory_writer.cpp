#include "io/trajectory_writer.hpp"

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>

#include "core/error.hpp"
#include "core/parallel.hpp"
#include "io/checkpoint.hpp"
#include "io/hdf5_util.hpp"
#include "io/scene_io.hpp"
#include "swarmsim/version.hpp"

namespace swarmsim {

namespace {

// ~1 MiB chunks of whole frames
constexpr hsize_t kChunkAgents = 87381;
// the rows of a position or velocity chunk of a swarm of n agents
hsize_t chunkRows(hsize_t n) { return std::min(std::max<hsize_t>(1, n), kChunkAgents); }
// blocks: at least 1,024 frames (or the frames so far, doubling), at most ~1 GiB of frames
constexpr std::int64_t kBlockFrames = 1024;
constexpr double kBlockBytes = 1024.0 * 1024.0 * 1024.0;

// a dataset with 0 frames (dims[0]) of rank 1 or 3, growing in frames
H5Handle createDataset(hid_t group, const char* name, hid_t type, int rank, const hsize_t* dims, const hsize_t* chunk,
                       int compression) {
  const hsize_t maxdims[3] = {H5S_UNLIMITED, rank > 1 ? dims[1] : 0, rank > 2 ? dims[2] : 0};
  H5Handle space(H5Screate_simple(rank, dims, maxdims), H5Sclose);
  H5Handle props(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
  H5Pset_chunk(props, rank, chunk);
  H5Pset_obj_track_times(props, 0);  // no time stamps: identical runs give identical bytes
  if (compression > 0) {
    H5Pset_shuffle(props);
    H5Pset_deflate(props, static_cast<unsigned>(compression));
  } else {
    // a block's chunks are placed when it is added: writing a frame then changes no metadata
    H5Pset_alloc_time(props, H5D_ALLOC_TIME_EARLY);
    H5Pset_fill_time(props, H5D_FILL_TIME_NEVER);
  }
  H5Handle ds(H5Dcreate2(group, name, type, space, H5P_DEFAULT, props, H5P_DEFAULT), H5Dclose);
  if (!ds.valid()) throw OutputError(std::string("cannot create dataset '") + name + "' (disk full?)");
  return ds;
}

H5Handle createGroup(hid_t parent, const char* name) {
  H5Handle props(H5Pcreate(H5P_GROUP_CREATE), H5Pclose);
  H5Pset_obj_track_times(props, 0);
  return H5Handle(H5Gcreate2(parent, name, H5P_DEFAULT, props, H5P_DEFAULT), H5Gclose);
}

std::string errnoText() { return std::strerror(errno); }

// rows [r0, r1) of a position or velocity dataset into `out` (3 floats a row):
// row r is agent id r, wherever the model keeps that agent
void fillRows(const SwarmState& s, bool velocity, std::size_t r0, std::size_t r1, float* out) {
  const float* x = velocity ? s.vx.data() : s.px.data();
  const float* y = velocity ? s.vy.data() : s.py.data();
  const float* z = velocity ? s.vz.data() : s.pz.data();
  const std::uint32_t* id = s.id.data();
  // the ids are a permutation of [0, n): slots [r0, r1) holding ids r0..r1-1
  // (a state never reordered, or that stretch of one) are the block as it is
  std::size_t a = r0;
  while (a < r1 && id[a] == a) ++a;
  if (a == r1) {
    for (a = r0; a < r1; ++a) {
      out[3 * (a - r0)] = x[a];
      out[3 * (a - r0) + 1] = y[a];
      out[3 * (a - r0) + 2] = z[a];
    }
    return;
  }
  const std::size_t rows = r1 - r0;
  parallelFor(s.size(), [&](std::size_t b) {  // each row written once (the ids are a permutation)
    const std::size_t r = id[b] - r0;  // wraps around below r0
    if (r >= rows) return;
    out[3 * r] = x[b];
    out[3 * r + 1] = y[b];
    out[3 * r + 2] = z[b];
  });
}

// File access: no raw-data chunk cache (a frame goes to disk when it is
// written, so compressed chunks get their space in writing order, whenever the
// file is flushed) and no metadata evictions (metadata reaches the disk only
// when the file is flushed or closed, so between two flushes the file on disk
// stays as the last flush left it, plus raw data in space no metadata uses).
H5Handle accessProps() {
  H5Handle fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  H5Pset_cache(fapl, 0, 0, 0, 0.75);
  H5AC_cache_config_t mdc;
  mdc.version = H5AC__CURR_CACHE_CONFIG_VERSION;
  if (H5Pget_mdc_config(fapl, &mdc) >= 0) {
    mdc.evictions_enabled = false;
    mdc.incr_mode = H5C_incr__off;
    mdc.flash_incr_mode = H5C_flash_incr__off;
    mdc.decr_mode = H5C_decr__off;
    H5Pset_mdc_config(fapl, &mdc);
  }
  return fapl;
}

}  // namespace

TrajectoryWriter::TrajectoryWriter(const std::string& file, const Scenario& scenario,
                                   const std::vector<SwarmState>& swarms,
                                   const std::vector<std::vector<std::string>>& statNames, Mode mode,
                                   std::int64_t framesKept, const std::vector<std::string>& facts)
    : file_(file), scenarioJson_(scenario.resolved.dump()), capacity_(scenario.frames) {
  h5::quietErrors();
  // the slots, in hashing order
  const bool wantPos = std::count(scenario.output.quantities.begin(), scenario.output.quantities.end(), "position");
  const bool wantVel = std::count(scenario.output.quantities.begin(), scenario.output.quantities.end(), "velocity");
  for (std::size_t i = 0; i < swarms.size(); ++i) {
    const std::string base = "swarms/" + swarms[i].name;
    swarmFirstSlot_.push_back(slots_.size());
    swarmHasPos_.push_back(wantPos);
    swarmHasVel_.push_back(wantVel);
    if (wantPos) {
      slots_.push_back({H5I_INVALID_HID, swarms[i].size(), true, i, false});
      slotNames_.push_back(base + "/position");
    }
    if (wantVel) {
      slots_.push_back({H5I_INVALID_HID, swarms[i].size(), true, i, true});
      slotNames_.push_back(base + "/velocity");
    }
    if (i < statNames.size()) {
      for (const auto& name : statNames[i]) {
        slots_.push_back({H5I_INVALID_HID, 0, false});
        slotNames_.push_back(base + "/stats/" + name);
      }
    }
  }
  swarmFirstSlot_.push_back(slots_.size());
  slots_.push_back({H5I_INVALID_HID, 0, false});
  slotNames_.push_back("time");
  values_.resize(slots_.size());
  setMaxBlockRows(kMaxBlockRows);

  try {
    if (mode == Mode::kCreate) create(scenario, swarms, statNames, facts);
    open(mode == Mode::kReopen);
  } catch (...) {
    closeFile();
    closed_ = true;
    throw;
  }
  if (mode == Mode::kReopen) {
    // the file has the blocks that frames [0, framesKept) needed, and no more
    std::int64_t expected = 0;
    while (expected < framesKept) expected = nextBoundary(expected);
    if (framesKept < 0 || framesKept > capacity_ || extent_ != expected) {
      closeFile();
      closed_ = true;
      throw InputError(file_ + ": has " + std::to_string(extent_) + " frames allocated, not what " +
                       std::to_string(framesKept) + " written frames need (damaged?)");
    }
    frames_ = framesKept;
  }
}

void TrajectoryWriter::create(const Scenario& scenario, const std::vector<SwarmState>& swarms,
                              const std::vector<std::vector<std::string>>& statNames,
                              const std::vector<std::string>& facts) {
  const H5Handle fapl = accessProps();
  H5Handle f(H5Fcreate(file_.c_str(), H5F_ACC_EXCL, H5P_DEFAULT, fapl), H5Fclose);
  if (!f.valid()) throw OutputError(file_ + ": cannot create output file: " + errnoText());
  // root attributes: enough to reproduce the run from the file alone
  h5::writeAttr(f, "format", std::string(kFormatName));
  h5::writeAttr(f, "format_version", static_cast<std::int64_t>(kFormatVersion));
  h5::writeAttr(f, "swarmsim_version", std::string(kVersion));
  h5::writeAttr(f, "scenario_name", scenario.name);
  h5::writeAttr(f, "scenario", scenarioJson_);
  h5::writeAttr(f, "seed", scenario.seed);
  h5::writeAttr(f, "dt", scenario.dt);
  h5::writeAttr(f, "steps_per_frame", scenario.stepsPerFrame);
  h5::writeAttr(f, "frame_dt", scenario.dt * static_cast<double>(scenario.stepsPerFrame));
  // the closing attributes exist from the start and are only overwritten in place
  h5::writeAttr(f, "frames", std::int64_t{0});
  h5::writeAttr(f, "complete", std::int64_t{0});
  h5::writeAttr(f, "interrupted", std::int64_t{0});

  const hsize_t tdims[1] = {0}, tchunk[1] = {1024};
  H5Handle group = createGroup(f, "swarms");
  if (!group.valid()) throw OutputError(file_ + ": cannot create group 'swarms'");
  for (std::size_t i = 0; i < swarms.size(); ++i) {
    const SwarmState& s = swarms[i];
    const SwarmSpec& spec = scenario.swarms[i];
    const hsize_t n = s.size();
    H5Handle g = createGroup(group, s.name.c_str());
    if (!g.valid()) throw OutputError("cannot create group for swarm '" + s.name + "'");
    h5::writeAttr(g, "model", spec.model);
    h5::writeAttr(g, "count", static_cast<std::int64_t>(n));
    h5::writeAttr(g, "params", scenario.resolved["swarms"][i]["params"].dump());
    if (i < facts.size() && !facts[i].empty()) h5::writeAttr(g, "model_facts", facts[i]);
    const hsize_t dims[3] = {0, n, 3};
    const hsize_t chunk[3] = {1, chunkRows(n), 3};
    if (swarmHasPos_[i]) {
      H5Handle d = createDataset(g, "position", H5T_IEEE_F32LE, 3, dims, chunk, scenario.output.compression);
      h5::writeAttr(d, "units", std::string("m"));
    }
    if (swarmHasVel_[i]) {
      H5Handle d = createDataset(g, "velocity", H5T_IEEE_F32LE, 3, dims, chunk, scenario.output.compression);
      h5::writeAttr(d, "units", std::string("m/s"));
    }
    // row r of position/velocity is agent id r
    std::vector<std::uint32_t> idRows(n);
    for (std::size_t r = 0; r < idRows.size(); ++r) idRows[r] = static_cast<std::uint32_t>(r);
    const hsize_t idims[1] = {n};
    H5Handle ispace(H5Screate_simple(1, idims, nullptr), H5Sclose);
    H5Handle dcpl(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
    H5Pset_obj_track_times(dcpl, 0);
    H5Handle ids(H5Dcreate2(g, "id", H5T_STD_U32LE, ispace, H5P_DEFAULT, dcpl, H5P_DEFAULT), H5Dclose);
    if (!ids.valid() || H5Dwrite(ids, H5T_NATIVE_UINT32, H5S_ALL, H5S_ALL, H5P_DEFAULT, idRows.data()) < 0) {
      throw OutputError("cannot write ids of swarm '" + s.name + "'");
    }
    {
      // every row the swarm's index in scenario order, for viewers that colour by swarm (the XDMF export):
      // a dataset of its fill value only, with no storage in the file
      H5Handle fill(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
      H5Pset_obj_track_times(fill, 0);
      const auto index = static_cast<std::uint32_t>(i);
      H5Pset_fill_value(fill, H5T_NATIVE_UINT32, &index);
      H5Pset_alloc_time(fill, H5D_ALLOC_TIME_LATE);
      H5Pset_fill_time(fill, H5D_FILL_TIME_IFSET);
      H5Handle d(H5Dcreate2(g, "swarm_index", H5T_STD_U32LE, ispace, H5P_DEFAULT, fill, H5P_DEFAULT), H5Dclose);
      if (!d.valid()) throw OutputError("cannot create swarm_index of swarm '" + s.name + "'");
    }
    if (i < statNames.size() && !statNames[i].empty()) {
      H5Handle sg = createGroup(g, "stats");
      for (const auto& name : statNames[i]) createDataset(sg, name.c_str(), H5T_IEEE_F64LE, 1, tdims, tchunk, 0);
    }
  }
  H5Handle t = createDataset(f, "time", H5T_IEEE_F64LE, 1, tdims, tchunk, 0);
  h5::writeAttr(t, "units", std::string("s"));
  t.reset();
  group.reset();
  writeScene(f, scenario);
  if (H5Fclose(f.release()) < 0) throw OutputError(file_ + ": cannot write the new output file (disk full?)");
}

void TrajectoryWriter::open(bool checkScenario) {
  const H5Handle fapl = accessProps();
  fileId_ = H5Handle(H5Fopen(file_.c_str(), H5F_ACC_RDWR, fapl), H5Fclose);
  if (!fileId_.valid()) throw InputError(file_ + ": cannot open the partial output (damaged?)");
  if (checkScenario) {
    bool same = false;
    try {
      same = h5::readStringAttr(fileId_, "format") == kFormatName && h5::readStringAttr(fileId_, "scenario") == scenarioJson_;
    } catch (const std::exception&) {
    }
    if (!same) throw InputError(file_ + ": not the partial output of this scenario");
  }
  datasets_.clear();
  extent_ = -1;
  for (std::size_t k = 0; k < slots_.size(); ++k) {
    H5Handle ds(H5Dopen2(fileId_, slotNames_[k].c_str(), H5P_DEFAULT), H5Dclose);
    if (!ds.valid()) throw InputError(file_ + ": no dataset '" + slotNames_[k] + "' (not the partial output of this scenario)");
    H5Handle space(H5Dget_space(ds), H5Sclose);
    hsize_t dims[3] = {0, 0, 0};
    const int rank = H5Sget_simple_extent_dims(space, dims, nullptr);
    const bool ok = slots_[k].vec ? rank == 3 && dims[1] == slots_[k].rows && dims[2] == 3 : rank == 1;
    const auto frames = static_cast<std::int64_t>(dims[0]);
    if (!ok || (extent_ >= 0 && frames != extent_)) {
      throw InputError(file_ + ": dataset '" + slotNames_[k] + "' has another shape than this scenario gives");
    }
    extent_ = frames;
    slots_[k].dataset = ds;
    datasets_.push_back(std::move(ds));
  }
}

void TrajectoryWriter::closeFile() {
  datasets_.clear();
  for (Slot& s : slots_) s.dataset = H5I_INVALID_HID;
  fileId_.reset();
}

std::int64_t TrajectoryWriter::nextBoundary(std::int64_t b) const {
  double frameBytes = 0.0;
  for (const Slot& s : slots_) frameBytes += static_cast<double>(s.bytes());
  const auto perGiB = static_cast<std::int64_t>(std::max(1.0, kBlockBytes / frameBytes));
  const std::int64_t block = std::max<std::int64_t>(1, std::min(std::max(b, kBlockFrames), perGiB));
  return b + std::min(block, capacity_ - b);
}

void TrajectoryWriter::grow() {
  const std::int64_t next = nextBoundary(extent_);
  for (const Slot& s : slots_) {
    const hsize_t dims[3] = {static_cast<hsize_t>(next), s.rows, 3};
    if (H5Dset_extent(s.dataset, dims) < 0) {
      throw OutputError(file_ + ": cannot add frames " + std::to_string(extent_) + "-" + std::to_string(next - 1) +
                        " (disk full?)");
    }
  }
  // close and open again: the block's metadata is on disk, and the library's
  // state is what a resumed run would read back
  closeFile();
  open(false);
  if (extent_ != next) throw OutputError(file_ + ": the new frames did not reach the file");
}

TrajectoryWriter::~TrajectoryWriter() {
  if (!closed_) closeFile();
}

void TrajectoryWriter::setMaxBlockRows(std::size_t rows) {
  rows = std::max<std::size_t>(1, rows);
  std::size_t most = 0;
  for (Slot& s : slots_) {
    if (!s.vec) continue;
    const std::size_t chunk = chunkRows(s.rows);
    s.blockRows = rows >= chunk ? rows / chunk * chunk : rows;
    most = std::max(most, std::min(s.blockRows, s.rows));
  }
  block_ = std::vector<float>(3 * most);
}

void TrajectoryWriter::transfer(std::size_t slot, hid_t dataset, std::int64_t frame, std::size_t r0, std::size_t r1,
                                void* data, bool write, const std::string& file) {
  const Slot& s = slots_[slot];
  const hsize_t f = static_cast<hsize_t>(frame);
  const int rank = s.vec ? 3 : 1;
  const hsize_t start[3] = {f, r0, 0}, count[3] = {1, r1 - r0, 3};
  const hid_t memType = s.vec ? H5T_NATIVE_FLOAT : H5T_NATIVE_DOUBLE;
  H5Handle fspace(H5Dget_space(dataset), H5Sclose);
  H5Sselect_hyperslab(fspace, H5S_SELECT_SET, start, nullptr, count, nullptr);
  H5Handle mspace(H5Screate_simple(rank, count, nullptr), H5Sclose);
  const herr_t st = write ? H5Dwrite(dataset, memType, mspace, fspace, H5P_DEFAULT, data)
                          : H5Dread(dataset, memType, mspace, fspace, H5P_DEFAULT, data);
  if (st < 0) {
    if (write) throw OutputError(file + ": cannot write frame " + std::to_string(frame) + " (disk full?)");
    throw InputError(file + ": cannot read frame " + std::to_string(frame) + " of '" + slotNames_[slot] + "' (damaged?)");
  }
}

template <typename Visit>
std::uint64_t TrajectoryWriter::forEachBlock(std::size_t k, std::uint64_t h, const Visit& visit) {
  const Slot& s = slots_[k];
  void* data = s.vec ? static_cast<void*>(block_.data()) : static_cast<void*>(&values_[k]);
  ByteHasher hasher(h, s.bytes());
  for (std::size_t r0 = 0; r0 < s.units(); r0 += s.blockRows) {
    const std::size_t r1 = std::min(s.units(), r0 + s.blockRows);
    visit(r0, r1, data);
    hasher.update(data, (r1 - r0) * s.unitBytes());
  }
  return hasher.finish();
}

template <typename Fill>
void TrajectoryWriter::appendFrame(const Fill& fill) {
  if (frames_ >= capacity_) throw OutputError(file_ + ": more frames than the scenario has");
  if (frames_ >= extent_) grow();
  for (std::size_t k = 0; k < slots_.size(); ++k) {
    hash_ = forEachBlock(k, hash_, [&](std::size_t r0, std::size_t r1, void* data) {
      fill(k, r0, r1, data);
      transfer(k, slots_[k].dataset, frames_, r0, r1, data, true, file_);
    });
  }
  ++frames_;
}

void TrajectoryWriter::writeFrame(double time, const std::vector<SwarmState>& swarms,
                                  const std::vector<std::vector<double>>& stats) {
  for (std::size_t i = 0; i < swarms.size(); ++i) {
    std::size_t k = swarmFirstSlot_[i];
    while (k < swarmFirstSlot_[i + 1] && slots_[k].vec) ++k;  // its stats follow its position and velocity
    for (std::size_t j = 0; k < swarmFirstSlot_[i + 1]; ++j, ++k) {
      values_[k] = i < stats.size() && j < stats[i].size() ? stats[i][j] : 0.0;
    }
  }
  values_.back() = time;
  appendFrame([&](std::size_t k, std::size_t r0, std::size_t r1, void* data) {
    const Slot& s = slots_[k];
    if (s.vec) fillRows(swarms[s.swarm], s.velocity, r0, r1, static_cast<float*>(data));
  });
}

void TrajectoryWriter::copyFramesFrom(const std::string& source, std::int64_t frames) {
  H5Handle src(H5Fopen(source.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!src.valid()) throw InputError(source + ": cannot open (expected a swarmsim output)");
  std::vector<H5Handle> ds;
  for (std::size_t k = 0; k < slots_.size(); ++k) {
    ds.emplace_back(H5Dopen2(src, slotNames_[k].c_str(), H5P_DEFAULT), H5Dclose);
    if (!ds.back().valid()) throw InputError(source + ": no dataset '" + slotNames_[k] + "'");
    H5Handle space(H5Dget_space(ds.back()), H5Sclose);
    hsize_t dims[3] = {0, 0, 0};
    const int rank = H5Sget_simple_extent_dims(space, dims, nullptr);
    if (rank != (slots_[k].vec ? 3 : 1) || (slots_[k].vec && dims[1] != slots_[k].rows) ||
        dims[0] < static_cast<hsize_t>(frames)) {
      throw InputError(source + ": dataset '" + slotNames_[k] + "' does not hold the frames its checkpoint says");
    }
  }
  for (std::int64_t f = 0; f < frames; ++f) {
    appendFrame([&](std::size_t k, std::size_t r0, std::size_t r1, void* data) {
      transfer(k, ds[k], f, r0, r1, data, false, source);
    });
  }
}

std::uint64_t TrajectoryWriter::hashStoredFrames(std::int64_t frames) {
  std::uint64_t h = 0;
  for (std::int64_t f = 0; f < frames; ++f) {
    for (std::size_t k = 0; k < slots_.size(); ++k) {
      h = forEachBlock(k, h, [&](std::size_t r0, std::size_t r1, void* data) {
        transfer(k, slots_[k].dataset, f, r0, r1, data, false, file_);
      });
    }
  }
  return h;
}

void TrajectoryWriter::flush() {
  if (H5Fflush(fileId_, H5F_SCOPE_LOCAL) < 0) throw OutputError(file_ + ": cannot write (disk full?)");
  void* handle = nullptr;
  if (H5Fget_vfd_handle(fileId_, H5P_DEFAULT, &handle) >= 0 && handle) {
    if (::fdatasync(*static_cast<int*>(handle)) != 0 && errno != EINVAL) {
      throw OutputError(file_ + ": cannot write to disk: " + errnoText());
    }
  }
}

void TrajectoryWriter::moveTo(const std::string& path) {
  if (std::rename(file_.c_str(), path.c_str()) != 0) {
    throw OutputError(file_ + ": cannot rename to " + path + ": " + errnoText());
  }
  file_ = path;
}

void TrajectoryWriter::close(bool complete) {
  if (!complete || extent_ != frames_) {  // cut every dataset to the frames written
    for (const Slot& s : slots_) {
      const hsize_t dims[3] = {static_cast<hsize_t>(frames_), s.rows, 3};
      if (H5Dset_extent(s.dataset, dims) < 0) throw OutputError(file_ + ": cannot cut dataset to the frames written");
    }
  }
  h5::updateAttr(fileId_, "frames", frames_);
  h5::updateAttr(fileId_, "complete", complete ? 1 : 0);
  h5::updateAttr(fileId_, "interrupted", complete ? 0 : 1);
  datasets_.clear();
  for (Slot& s : slots_) s.dataset = H5I_INVALID_HID;
  closed_ = true;
  if (H5Fclose(fileId_.release()) < 0) throw OutputError(file_ + ": cannot close output file (disk full?)");
}

}  // namespace swarmsim
