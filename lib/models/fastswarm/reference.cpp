#include "models/fastswarm/reference.hpp"

#include <openssl/evp.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <numeric>
#include <ostream>
#include <unordered_map>

#include <nlohmann/json.hpp>

#include "core/error.hpp"
#include "io/hdf5_handle.hpp"
#include "io/hdf5_util.hpp"
#include "io/output_target.hpp"
#include "swarmsim/version.hpp"

namespace swarmsim::fastswarm {

namespace {

std::string baseName(const std::string& path) {
  const auto slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

// the sorted values at floor(q (n - 1)), q in [0, 1]
double quantile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  const auto at = static_cast<std::size_t>(std::floor(q * static_cast<double>(values.size() - 1)));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(at), values.end());
  return values[at];
}

double tukeyLimit(const std::vector<double>& values, double fence) {
  if (fence <= 0.0) return std::numeric_limits<double>::infinity();
  const double q1 = quantile(values, 0.25), q3 = quantile(values, 0.75);
  return q3 + fence * (q3 - q1);
}

double norm3(const double* x) { return std::sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]); }

// --- HDF5 ------------------------------------------------------------------

H5Handle createGroup(hid_t parent, const char* name) {
  H5Handle props(H5Pcreate(H5P_GROUP_CREATE), H5Pclose);
  H5Pset_obj_track_times(props, 0);  // no time stamps: the same input gives the same bytes
  H5Handle g(H5Gcreate2(parent, name, H5P_DEFAULT, props, H5P_DEFAULT), H5Gclose);
  if (!g.valid()) throw OutputError(std::string("cannot create group '") + name + "'");
  return g;
}

void writeDataset(hid_t group, const char* name, hid_t fileType, hid_t memType, int rank, const hsize_t* dims,
                  const void* data, bool compress = false) {
  H5Handle space(H5Screate_simple(rank, dims, nullptr), H5Sclose);
  H5Handle props(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
  H5Pset_obj_track_times(props, 0);
  if (compress && dims[0] > 0) {  // the samples: shuffled and deflated (a third of their size)
    const hsize_t chunk[2] = {std::min<hsize_t>(dims[0], 16384), rank > 1 ? dims[1] : 1};
    H5Pset_chunk(props, rank, chunk);
    H5Pset_shuffle(props);
    H5Pset_deflate(props, 6);
  }
  H5Handle ds(H5Dcreate2(group, name, fileType, space, H5P_DEFAULT, props, H5P_DEFAULT), H5Dclose);
  if (!ds.valid()) throw OutputError(std::string("cannot create dataset '") + name + "' (disk full?)");
  if (dims[0] > 0 && H5Dwrite(ds, memType, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0) {
    throw OutputError(std::string("cannot write dataset '") + name + "' (disk full?)");
  }
}

void writeStrings(hid_t group, const char* name, const std::vector<std::string>& values) {
  H5Handle type(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(type, H5T_VARIABLE);
  H5Tset_cset(type, H5T_CSET_UTF8);
  std::vector<const char*> ptrs;
  for (const auto& v : values) ptrs.push_back(v.c_str());
  const hsize_t dims[1] = {values.size()};
  writeDataset(group, name, type, type, 1, dims, ptrs.data());
}

// a dataset's extent along each axis; throws InputError naming the file and dataset
std::vector<hsize_t> extentOf(hid_t ds, const std::string& file, const char* name) {
  H5Handle space(H5Dget_space(ds), H5Sclose);
  const int rank = H5Sget_simple_extent_ndims(space);
  if (rank < 1 || rank > 2) throw InputError(file + ": dataset '" + name + "' has rank " + std::to_string(rank));
  std::vector<hsize_t> dims(static_cast<std::size_t>(rank));
  H5Sget_simple_extent_dims(space, dims.data(), nullptr);
  return dims;
}

template <typename T>
std::vector<T> readDataset(hid_t group, const char* name, hid_t memType, std::size_t columns, const std::string& file,
                           std::size_t rows) {
  H5Handle ds(H5Dopen2(group, name, H5P_DEFAULT), H5Dclose);
  if (!ds.valid()) throw InputError(file + ": no dataset '" + name + "' (not a swarmsim reference?)");
  const auto dims = extentOf(ds, file, name);
  const std::size_t cols = dims.size() > 1 ? dims[1] : 1;
  if (dims[0] != rows || cols != columns) {
    throw InputError(file + ": dataset '" + name + "' is " + std::to_string(dims[0]) + " x " + std::to_string(cols) +
                     ", expected " + std::to_string(rows) + " x " + std::to_string(columns));
  }
  std::vector<T> out(rows * columns);
  if (rows > 0 && H5Dread(ds, memType, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()) < 0) {
    throw InputError(file + ": cannot read dataset '" + name + "'");
  }
  return out;
}

std::size_t rowsOf(hid_t group, const char* name, const std::string& file) {
  H5Handle ds(H5Dopen2(group, name, H5P_DEFAULT), H5Dclose);
  if (!ds.valid()) throw InputError(file + ": no dataset '" + name + "' (not a swarmsim reference?)");
  return extentOf(ds, file, name)[0];
}

std::vector<std::string> readStrings(hid_t group, const char* name, const std::string& file, std::size_t rows) {
  H5Handle ds(H5Dopen2(group, name, H5P_DEFAULT), H5Dclose);
  if (!ds.valid()) throw InputError(file + ": no dataset '" + name + "'");
  if (extentOf(ds, file, name)[0] != rows) throw InputError(file + ": dataset '" + name + "' has the wrong length");
  H5Handle type(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(type, H5T_VARIABLE);
  H5Tset_cset(type, H5T_CSET_UTF8);
  std::vector<char*> ptrs(rows, nullptr);
  if (rows > 0 && H5Dread(ds, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, ptrs.data()) < 0) {
    throw InputError(file + ": cannot read dataset '" + name + "'");
  }
  std::vector<std::string> out;
  for (char* p : ptrs) {
    out.emplace_back(p ? p : "");
    H5free_memory(p);
  }
  return out;
}

}  // namespace

std::string sha256File(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open");
  EVP_MD_CTX* ctx = EVP_MD_CTX_new();
  if (!ctx || EVP_DigestInit_ex(ctx, EVP_sha256(), nullptr) != 1) {
    EVP_MD_CTX_free(ctx);
    throw Error(kExitOther, "sha256: cannot initialise OpenSSL's digest");
  }
  std::vector<char> buf(1 << 16);
  while (in) {
    in.read(buf.data(), static_cast<std::streamsize>(buf.size()));
    const std::streamsize got = in.gcount();
    if (got > 0) EVP_DigestUpdate(ctx, buf.data(), static_cast<std::size_t>(got));
  }
  const bool readFailed = in.bad();
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int len = 0;
  EVP_DigestFinal_ex(ctx, digest, &len);
  EVP_MD_CTX_free(ctx);
  if (readFailed) throw InputError(path + ": cannot read");
  std::string hex;
  char byte[3];
  for (unsigned int i = 0; i < len; ++i) {
    std::snprintf(byte, sizeof byte, "%02x", digest[i]);
    hex += byte;
  }
  return hex;
}

void Reference::indexGroups() {
  groupFloor.resize(groups());
  for (std::size_t g = 0; g < groupFloor.size(); ++g) groupFloor[g] = speed[static_cast<std::size_t>(groupStart[g])];
  // the bins' table: bin k holds the group of the speed at its lower edge (by the search below, before the table)
  groupBin.clear();
  if (groupFloor.size() < 2 || !(groupFloor.back() > groupFloor.front())) return;
  binScale = static_cast<double>(kGroupBins) / (groupFloor.back() - groupFloor.front());
  std::vector<std::uint32_t> table(kGroupBins);
  for (std::size_t k = 0; k < kGroupBins; ++k) {
    table[k] = static_cast<std::uint32_t>(groupOfSpeed(groupFloor.front() + static_cast<double>(k) / binScale));
  }
  groupBin = std::move(table);
}

std::size_t Reference::groupOfSpeed(double s) const {
  const std::size_t g = groups();
  if (g == 0) return 0;
  if (groupBin.size() == kGroupBins && groupFloor.size() == g) {
    // the bin's group, then the few steps to the exact answer (either way: the bin's edge is rounded)
    if (!(s >= groupFloor.front())) return 0;  // (NaN too, as the search gives)
    const double t = (s - groupFloor.front()) * binScale;
    std::size_t k = groupBin[t < static_cast<double>(kGroupBins - 1) ? static_cast<std::size_t>(t) : kGroupBins - 1];
    while (k + 1 < g && groupFloor[k + 1] <= s) ++k;
    while (k > 0 && groupFloor[k] > s) --k;
    return k;
  }
  // the last group whose first sample is not faster than s (0 if none): the answer lies in [lo, lo + len); each
  // halving is a conditional move, not a branch (which the agents' speeds would take at random)
  const bool indexed = groupFloor.size() == g;
  std::size_t lo = 0, len = g;
  while (len > 1) {
    const std::size_t half = len / 2, mid = lo + half;
    const double first = indexed ? groupFloor[mid] : speed[static_cast<std::size_t>(groupStart[mid])];
    lo = first <= s ? mid : lo;
    len -= half;
  }
  return lo;
}

Reference buildReference(const ReferenceBuildOptions& options) {
  if (options.tracks.empty()) throw InputError("reference build: no track files given");
  if (options.groupSize < 1) throw InputError("--group-size: expected at least 1");
  if (!(options.fence >= 0.0)) throw InputError("--fence: expected a factor >= 0 (0: no fence)");
  if (!(options.maxSpeed >= 0.0) || !(options.maxAccel >= 0.0)) {
    throw InputError("--max-speed / --max-accel: expected a bound >= 0 (0: none)");
  }
  Reference ref;
  std::vector<double> v, a;  // all differenced samples, in source order
  std::vector<std::size_t> sourceOf;
  std::vector<std::int64_t> rawNext;  // per sample: the raw index of the same individual's next sample, or -1
  for (const std::string& path : options.tracks) {
    ReferenceSource src;
    src.path = path;
    src.name = baseName(path);
    src.sha256 = sha256File(path);
    auto tracks = eval::openTracks(path, options.source);
    const eval::TrackInfo& info = tracks->info();
    src.kind = info.kind;
    src.dt = info.dt;
    src.individuals = info.individuals;
    if (!(info.dt > 0.0)) throw InputError(path + ": cannot determine the time step");
    if (ref.sources.empty()) {
      ref.dt = info.dt;
    } else if (std::fabs(info.dt - ref.dt) > 1e-9 * ref.dt) {
      char msg[160];
      std::snprintf(msg, sizeof msg, ": time step %.9g s differs from %.9g s of %s (one reference has one time step)",
                    info.dt, ref.dt, ref.sources.front().name.c_str());
      throw InputError(path + msg);
    }
    // recorded velocities (when the source has them and they are wanted): v[k] as recorded and
    // a = (v[k+1] - v[k]) / dt, from samples k, k+1; else from positions, samples k, k+1, k+2
    const bool recorded = info.hasVelocity && options.velocity != VelocitySource::Positions;
    if (options.velocity == VelocitySource::Recorded && !info.hasVelocity) {
      throw InputError(path + ": has no velocity columns (--velocity recorded needs vx, vy, vz)");
    }
    src.velocity = recorded ? "recorded" : "positions";
    const int span = recorded ? 2 : 3;  // consecutive samples per (v, a)
    eval::Frame f[3];
    std::vector<std::int64_t> withSample;  // individuals that gave at least one sample
    const double inv = 1.0 / info.dt, inv2 = inv * inv;
    const std::size_t before = v.size() / 3;
    std::unordered_map<std::int64_t, std::pair<std::int64_t, std::size_t>> last;  // id -> (k, raw index) of its latest sample
    for (std::int64_t k = info.first; k < info.last; ++k) {
      std::swap(f[0], f[1]);
      std::swap(f[1], f[2]);
      tracks->read(k, f[2]);
      if (k < info.first + span - 1) continue;
      const eval::Frame& f0 = f[3 - span];  // sample k - span + 1
      for (std::size_t r0 = 0; r0 < f0.size(); ++r0) {
        const std::int64_t id = f0.id[r0];
        const std::ptrdiff_t r1 = f[4 - span].find(id), r2 = f[2].find(id);
        if (r1 < 0 || r2 < 0) continue;
        if (recorded) {
          const double* v0 = &f0.vel[3 * r0];
          const double* v1 = &f[2].vel[3 * static_cast<std::size_t>(r2)];
          for (int c = 0; c < 3; ++c) {
            v.push_back(v0[c]);
            a.push_back((v1[c] - v0[c]) * inv);
          }
        } else {
          const double* p0 = &f0.pos[3 * r0];
          const double* p1 = &f[1].pos[3 * static_cast<std::size_t>(r1)];
          const double* p2 = &f[2].pos[3 * static_cast<std::size_t>(r2)];
          for (int c = 0; c < 3; ++c) {
            v.push_back((p1[c] - p0[c]) * inv);
            a.push_back(((p2[c] - p1[c]) - (p1[c] - p0[c])) * inv2);
          }
        }
        sourceOf.push_back(ref.sources.size());
        withSample.push_back(id);
        const std::size_t raw = v.size() / 3 - 1;
        rawNext.push_back(-1);
        auto [it, fresh] = last.try_emplace(id, k, raw);
        if (!fresh) {
          if (it->second.first == k - 1) rawNext[it->second.second] = static_cast<std::int64_t>(raw);
          it->second = {k, raw};
        }
      }
    }
    std::sort(withSample.begin(), withSample.end());
    const auto distinct = std::unique(withSample.begin(), withSample.end()) - withSample.begin();
    src.samples = static_cast<std::int64_t>(v.size() / 3 - before);
    src.shortTracks = info.individuals - distinct;
    if (src.samples == 0) {
      throw InputError(path + ": no individual has " + std::string(recorded ? "two" : "three") +
                       " consecutive samples (" + std::to_string(info.individuals) +
                       " individuals): too short to difference for velocity and acceleration");
    }
    ref.sources.push_back(src);
  }

  // the filter
  const std::size_t n = v.size() / 3;
  std::vector<double> speed(n), accel(n);
  for (std::size_t i = 0; i < n; ++i) {
    speed[i] = norm3(&v[3 * i]);
    accel[i] = norm3(&a[3 * i]);
  }
  const double inf = std::numeric_limits<double>::infinity();
  ref.fence = options.fence;
  ref.maxSpeed = options.maxSpeed;
  ref.maxAccel = options.maxAccel;
  ref.speedLimit = std::min(tukeyLimit(speed, options.fence), options.maxSpeed > 0.0 ? options.maxSpeed : inf);
  ref.accelLimit = std::min(tukeyLimit(accel, options.fence), options.maxAccel > 0.0 ? options.maxAccel : inf);
  std::vector<std::size_t> kept;
  for (std::size_t i = 0; i < n; ++i) {
    const bool finite = std::isfinite(speed[i]) && std::isfinite(accel[i]);
    if (finite && speed[i] <= ref.speedLimit && accel[i] <= ref.accelLimit) {
      kept.push_back(i);
    } else {
      ++ref.sources[sourceOf[i]].dropped;
    }
  }
  if (kept.empty()) {
    throw InputError("reference build: the filter left no sample (speed limit " + std::to_string(ref.speedLimit) +
                     " m/s, acceleration limit " + std::to_string(ref.accelLimit) + " m/s^2)");
  }
  std::stable_sort(kept.begin(), kept.end(), [&](std::size_t x, std::size_t y) { return speed[x] < speed[y]; });
  std::vector<std::int64_t> sortedOf(n, -1);  // raw index -> sorted index (-1: dropped)
  for (std::size_t j = 0; j < kept.size(); ++j) sortedOf[kept[j]] = static_cast<std::int64_t>(j);
  for (const std::size_t i : kept) {
    ref.next.push_back(rawNext[i] < 0 ? -1 : sortedOf[static_cast<std::size_t>(rawNext[i])]);
    ref.speed.push_back(speed[i]);
    for (int c = 0; c < 3; ++c) {
      ref.v.push_back(v[3 * i + static_cast<std::size_t>(c)]);
      ref.a.push_back(a[3 * i + static_cast<std::size_t>(c)]);
    }
  }
  // speed groups
  ref.groupSize = options.groupSize;
  const auto m = static_cast<std::int64_t>(kept.size());
  const std::int64_t groups = std::max<std::int64_t>(1, m / options.groupSize);
  for (std::int64_t g = 0; g < groups; ++g) ref.groupStart.push_back(g * options.groupSize);
  ref.groupStart.push_back(m);
  ref.indexGroups();
  ref.swarmsimVersion = kVersion;
  return ref;
}

void writeReference(const Reference& ref, const std::string& path, bool force) {
  h5::quietErrors();
  const OutputTarget target(path, force, false);
  target.removePart();
  {
    H5Handle f(H5Fcreate(target.partPath().c_str(), H5F_ACC_EXCL, H5P_DEFAULT, H5P_DEFAULT), H5Fclose);
    if (!f.valid()) throw OutputError(target.partPath() + ": cannot create");
    h5::writeAttr(f, "format", std::string(Reference::kFormatName));
    h5::writeAttr(f, "format_version", Reference::kFormatVersion);
    h5::writeAttr(f, "swarmsim_version", ref.swarmsimVersion);
    h5::writeAttr(f, "dt", ref.dt);
    h5::writeAttr(f, "samples", static_cast<std::int64_t>(ref.size()));
    h5::writeAttr(f, "group_size", ref.groupSize);
    h5::writeAttr(f, "differencing",
                  std::string("forward; velocity 'recorded': v = v[k], a = (v[k+1] - v[k]) / dt; 'positions': "
                              "v = (p[k+1] - p[k]) / dt, a = (p[k+2] - 2 p[k+1] + p[k]) / dt^2"));
    h5::writeAttr(f, "filter_fence", ref.fence);
    h5::writeAttr(f, "filter_max_speed", ref.maxSpeed);
    h5::writeAttr(f, "filter_max_accel", ref.maxAccel);
    h5::writeAttr(f, "speed_limit", ref.speedLimit);
    h5::writeAttr(f, "accel_limit", ref.accelLimit);
    const hsize_t n = ref.size();
    {
      const H5Handle g = createGroup(f, "samples");
      const hsize_t d3[2] = {n, 3}, d1[1] = {n};
      writeDataset(g, "v", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 2, d3, ref.v.data(), true);
      writeDataset(g, "a", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 2, d3, ref.a.data(), true);
      writeDataset(g, "speed", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 1, d1, ref.speed.data(), true);
      writeDataset(g, "next", H5T_STD_I64LE, H5T_NATIVE_INT64, 1, d1, ref.next.data(), true);
    }
    {
      const H5Handle g = createGroup(f, "groups");
      const hsize_t d[1] = {ref.groupStart.size()};
      writeDataset(g, "start", H5T_STD_I64LE, H5T_NATIVE_INT64, 1, d, ref.groupStart.data());
    }
    {
      const H5Handle g = createGroup(f, "sources");
      std::vector<std::string> name, given, sha, kind, vel;
      std::vector<double> dt;
      std::vector<std::int64_t> counts;  // individuals, short tracks, samples, dropped
      for (const auto& s : ref.sources) {
        name.push_back(s.name);
        given.push_back(s.path);
        sha.push_back(s.sha256);
        kind.push_back(s.kind);
        vel.push_back(s.velocity);
        dt.push_back(s.dt);
        counts.insert(counts.end(), {s.individuals, s.shortTracks, s.samples, s.dropped});
      }
      writeStrings(g, "name", name);
      writeStrings(g, "path", given);
      writeStrings(g, "sha256", sha);
      writeStrings(g, "kind", kind);
      writeStrings(g, "velocity", vel);
      const hsize_t d1[1] = {ref.sources.size()}, d4[2] = {ref.sources.size(), 4};
      writeDataset(g, "dt", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 1, d1, dt.data());
      writeDataset(g, "counts", H5T_STD_I64LE, H5T_NATIVE_INT64, 2, d4, counts.data());
      h5::writeAttr(g, "counts_columns", std::string("individuals, short_tracks, samples, dropped"));
    }
    if (H5Fflush(f, H5F_SCOPE_GLOBAL) < 0) throw OutputError(target.partPath() + ": cannot write (disk full?)");
  }
  target.place(force);
}

bool isReferenceFile(const std::string& path) { return h5::fileFormat(path) == Reference::kFormatName; }

Reference readReference(const std::string& path) {
  h5::quietErrors();
  if (H5Fis_hdf5(path.c_str()) <= 0) throw InputError(path + ": not an HDF5 file (expected a swarmsim reference)");
  H5Handle f(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!f.valid()) throw InputError(path + ": cannot open as HDF5");
  Reference ref;
  try {
    if (!h5::hasAttr(f, "format") || h5::readStringAttr(f, "format") != Reference::kFormatName) {
      throw InputError(path + ": not a swarmsim reference (no format attribute \"" +
                       std::string(Reference::kFormatName) + "\"; build one with swarmsim reference build)");
    }
    const std::int64_t version = h5::readIntAttr(f, "format_version");
    if (version != Reference::kFormatVersion && version != 1) {
      throw InputError(path + ": reference format version " + std::to_string(version) + ", this build reads 1 and " +
                       std::to_string(Reference::kFormatVersion));
    }
    ref.formatVersion = version;
    ref.swarmsimVersion = h5::readStringAttr(f, "swarmsim_version");
    ref.dt = h5::readDoubleAttr(f, "dt");
    ref.groupSize = h5::readIntAttr(f, "group_size");
    ref.fence = h5::readDoubleAttr(f, "filter_fence");
    ref.maxSpeed = h5::readDoubleAttr(f, "filter_max_speed");
    ref.maxAccel = h5::readDoubleAttr(f, "filter_max_accel");
    ref.speedLimit = h5::readDoubleAttr(f, "speed_limit");
    ref.accelLimit = h5::readDoubleAttr(f, "accel_limit");
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& e) {
    throw InputError(path + ": " + e.what());
  }
  H5Handle samples(H5Gopen2(f, "samples", H5P_DEFAULT), H5Gclose);
  H5Handle groups(H5Gopen2(f, "groups", H5P_DEFAULT), H5Gclose);
  H5Handle sources(H5Gopen2(f, "sources", H5P_DEFAULT), H5Gclose);
  if (!samples.valid() || !groups.valid() || !sources.valid()) {
    throw InputError(path + ": missing group /samples, /groups or /sources");
  }
  const std::size_t n = rowsOf(samples, "speed", path);
  ref.v = readDataset<double>(samples, "v", H5T_NATIVE_DOUBLE, 3, path, n);
  ref.a = readDataset<double>(samples, "a", H5T_NATIVE_DOUBLE, 3, path, n);
  ref.speed = readDataset<double>(samples, "speed", H5T_NATIVE_DOUBLE, 1, path, n);
  if (ref.formatVersion >= 2) {  // (readDataset names a missing one)
    ref.next = readDataset<std::int64_t>(samples, "next", H5T_NATIVE_INT64, 1, path, n);
    for (const std::int64_t j : ref.next) {
      if (j < -1 || j >= static_cast<std::int64_t>(n)) throw InputError(path + ": /samples/next: an index outside the samples");
    }
  }
  ref.groupStart = readDataset<std::int64_t>(groups, "start", H5T_NATIVE_INT64, 1, path, rowsOf(groups, "start", path));
  // the groups must tile the samples in order: the model indexes with them
  bool tiles = n > 0 && ref.groupStart.size() >= 2 && ref.groupStart.front() == 0 &&
               ref.groupStart.back() == static_cast<std::int64_t>(n);
  for (std::size_t g = 1; tiles && g < ref.groupStart.size(); ++g) tiles = ref.groupStart[g] > ref.groupStart[g - 1];
  for (std::size_t i = 1; tiles && i < n; ++i) tiles = ref.speed[i] >= ref.speed[i - 1];
  if (!tiles) throw InputError(path + ": its samples are empty, not sorted by speed, or its groups do not tile them");
  ref.indexGroups();
  const std::size_t s = rowsOf(sources, "name", path);
  const auto name = readStrings(sources, "name", path, s), given = readStrings(sources, "path", path, s);
  const auto sha = readStrings(sources, "sha256", path, s), kind = readStrings(sources, "kind", path, s);
  const auto vel = readStrings(sources, "velocity", path, s);
  const auto dt = readDataset<double>(sources, "dt", H5T_NATIVE_DOUBLE, 1, path, s);
  const auto counts = readDataset<std::int64_t>(sources, "counts", H5T_NATIVE_INT64, 4, path, s);
  for (std::size_t i = 0; i < s; ++i) {
    ReferenceSource src;
    src.name = name[i];
    src.path = given[i];
    src.sha256 = sha[i];
    src.kind = kind[i];
    src.velocity = vel[i];
    src.dt = dt[i];
    src.individuals = counts[4 * i];
    src.shortTracks = counts[4 * i + 1];
    src.samples = counts[4 * i + 2];
    src.dropped = counts[4 * i + 3];
    ref.sources.push_back(src);
  }
  return ref;
}

void printReferenceInfo(const Reference& ref, const std::string& path, bool json, std::ostream& out) {
  double amin = std::numeric_limits<double>::infinity(), amax = 0.0;
  for (std::size_t i = 0; i < ref.size(); ++i) {
    const double m = norm3(&ref.a[3 * i]);
    amin = std::min(amin, m);
    amax = std::max(amax, m);
  }
  const double smin = ref.speed.front(), smax = ref.speed.back(), smed = ref.speed[ref.size() / 2];
  const auto successors = std::count_if(ref.next.begin(), ref.next.end(), [](std::int64_t j) { return j >= 0; });
  const auto limit = [](double x) -> nlohmann::json { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(); };
  if (json) {
    nlohmann::json j = {{"file", path},
                        {"format", Reference::kFormatName},
                        {"format_version", ref.formatVersion},
                        {"successors", successors},
                        {"swarmsim_version", ref.swarmsimVersion},
                        {"dt", ref.dt},
                        {"samples", ref.size()},
                        {"groups", ref.groups()},
                        {"group_size", ref.groupSize},
                        {"speed", {{"min", smin}, {"median", smed}, {"max", smax}}},
                        {"accel", {{"min", amin}, {"max", amax}}},
                        {"filter",
                         {{"fence", ref.fence},
                          {"max_speed", ref.maxSpeed},
                          {"max_accel", ref.maxAccel},
                          {"speed_limit", limit(ref.speedLimit)},
                          {"accel_limit", limit(ref.accelLimit)}}}};
    nlohmann::json srcs = nlohmann::json::array();
    for (const auto& s : ref.sources) {
      srcs.push_back({{"name", s.name},
                      {"path", s.path},
                      {"sha256", s.sha256},
                      {"kind", s.kind},
                      {"velocity", s.velocity},
                      {"dt", s.dt},
                      {"individuals", s.individuals},
                      {"short_tracks", s.shortTracks},
                      {"samples", s.samples},
                      {"dropped", s.dropped}});
    }
    j["sources"] = srcs;
    out << j.dump(2) << "\n";
    return;
  }
  char line[512];
  std::snprintf(line, sizeof line,
                "file:      %s\nformat:    %s %lld (swarmsim %s)\ndt:        %g s\n"
                "samples:   %zu (v, a), in %zu speed groups of %lld\n"
                "speed:     %.4g .. %.4g m/s (median %.4g)\n|a|:       %.4g .. %.4g m/s^2\n",
                path.c_str(), Reference::kFormatName, static_cast<long long>(ref.formatVersion),
                ref.swarmsimVersion.c_str(), ref.dt, ref.size(), ref.groups(), static_cast<long long>(ref.groupSize),
                smin, smax, smed, amin, amax);
  out << line;
  std::snprintf(line, sizeof line, "successors: %lld of the samples have the next sample of their track\n",
                static_cast<long long>(successors));
  out << line;
  std::snprintf(line, sizeof line, "filter:    Tukey fence %g x IQR, max speed %g, max |a| %g (0: none): |v| <= %.4g m/s, |a| <= %.4g m/s^2\n",
                ref.fence, ref.maxSpeed, ref.maxAccel, ref.speedLimit, ref.accelLimit);
  out << line;
  for (const auto& s : ref.sources) {
    std::snprintf(line, sizeof line,
                  "source:    %s (%s, dt %g s, v %s): %lld individuals (%lld too short), %lld samples, %lld dropped\n"
                  "           sha256 %s\n",
                  s.name.c_str(), s.kind.c_str(), s.dt, s.velocity.c_str(), static_cast<long long>(s.individuals),
                  static_cast<long long>(s.shortTracks), static_cast<long long>(s.samples),
                  static_cast<long long>(s.dropped), s.sha256.c_str());
    out << line;
  }
}

}  // namespace swarmsim::fastswarm
