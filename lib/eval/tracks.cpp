#include "eval/tracks.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <unordered_map>

#include "core/error.hpp"
#include "io/hdf5_handle.hpp"
#include "io/hdf5_util.hpp"
#include "io/trajectory_reader.hpp"

namespace swarmsim::eval {

std::ptrdiff_t Frame::find(std::int64_t key) const {
  if (dense) return key >= 0 && key < static_cast<std::int64_t>(id.size()) ? static_cast<std::ptrdiff_t>(key) : -1;
  const auto it = std::lower_bound(id.begin(), id.end(), key);
  return it != id.end() && *it == key ? it - id.begin() : -1;
}

FrameRange FrameRange::parse(const std::string& text) {
  const auto bad = [&]() {
    return InputError(
        "--frames: expected A:B (python-like half-open range of frames, either side optional, e.g. "
        "100:500, :200, -50:), got \"" +
        text + "\"");
  };
  const auto colon = text.find(':');
  if (colon == std::string::npos || text.find(':', colon + 1) != std::string::npos) throw bad();
  FrameRange r;
  const auto part = [&](const std::string& s) -> std::optional<long long> {
    if (s.empty()) return std::nullopt;
    char* stop = nullptr;
    errno = 0;
    const long long v = std::strtoll(s.c_str(), &stop, 10);
    if (*stop != '\0' || errno != 0) throw bad();
    return v;
  };
  r.begin = part(text.substr(0, colon));
  r.end = part(text.substr(colon + 1));
  return r;
}

void FrameRange::resolve(std::int64_t count, std::int64_t& first, std::int64_t& last) const {
  const auto fix = [count](long long v) -> std::int64_t {
    if (v < 0) v += count;
    return std::clamp<std::int64_t>(v, 0, count);
  };
  first = begin ? fix(*begin) : 0;
  last = end ? fix(*end) : count;
  if (last < first) last = first;
}

bool looksLikeHdf5(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char sig[8] = {};
  if (in && in.read(sig, 8) && std::memcmp(sig, "\x89HDF\r\n\x1a\n", 8) == 0) return true;
  const auto ends = [&](const char* ext) {
    const std::size_t n = std::strlen(ext);
    if (path.size() < n) return false;
    for (std::size_t i = 0; i < n; ++i) {
      if (std::tolower(static_cast<unsigned char>(path[path.size() - n + i])) != ext[i]) return false;
    }
    return true;
  };
  return ends(".h5") || ends(".hdf5");
}

namespace {

std::string lower(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::string trimCell(const std::string& s) {
  std::size_t a = 0, b = s.size();
  while (a < b && std::isspace(static_cast<unsigned char>(s[a]))) ++a;
  while (b > a && std::isspace(static_cast<unsigned char>(s[b - 1]))) --b;
  if (b - a >= 2 && s[a] == '"' && s[b - 1] == '"') {
    ++a;
    --b;
  }
  return s.substr(a, b - a);
}

std::vector<std::string> splitLine(const std::string& line, char delim) {
  std::vector<std::string> out;
  std::size_t start = 0;
  while (true) {
    const auto p = line.find(delim, start);
    out.push_back(trimCell(line.substr(start, p == std::string::npos ? std::string::npos : p - start)));
    if (p == std::string::npos) break;
    start = p + 1;
  }
  return out;
}

// ---------------------------------------------------------------- HDF5

class Hdf5Source : public TrackSource {
 public:
  Hdf5Source(const std::string& path, const SourceOptions& options) {
    const TrajectoryInfo ti = readTrajectoryInfo(path);
    const SwarmInfo* sw = nullptr;
    std::string names;
    for (const auto& s : ti.swarms) names += (names.empty() ? "" : ", ") + s.name;
    if (options.swarm.empty()) {
      if (ti.swarms.size() != 1) {
        throw InputError(path + ": " + std::to_string(ti.swarms.size()) +
                         " swarms; choose one with --swarm (swarms: " + names + ")");
      }
      sw = &ti.swarms[0];
    } else {
      for (const auto& s : ti.swarms) {
        if (s.name == options.swarm) sw = &s;
      }
      if (!sw) throw InputError(path + ": no swarm \"" + options.swarm + "\" (swarms: " + names + ")");
    }
    const auto has = [&](const char* q) {
      return std::find(sw->quantities.begin(), sw->quantities.end(), q) != sw->quantities.end();
    };
    if (!has("position")) throw InputError(path + ": swarm \"" + sw->name + "\" has no position dataset");
    info_.file = path;
    info_.kind = "hdf5";
    info_.swarm = sw->name;
    info_.individuals = sw->agents;
    info_.hasVelocity = has("velocity");
    double dt = ti.frameDt;
    if (!(dt > 0.0) || !std::isfinite(dt)) {
      const auto t = readDoubleDataset(path, "time");
      dt = t.size() >= 2 ? t[1] - t[0] : 0.0;
    }
    if (!(dt > 0.0) || !std::isfinite(dt))
      throw InputError(path + ": cannot determine the frame interval (frame_dt, /time)");
    info_.dt = dt;
    frames_ = sw->frames;
    options.frames.resolve(frames_, info_.first, info_.last);
    if (info_.last - info_.first < 2) {
      throw InputError(path + ": " + std::to_string(info_.last - info_.first) + " frame(s) of swarm \"" + sw->name +
                       "\" selected (of " + std::to_string(frames_) + "); need at least 2");
    }
    agents_ = static_cast<std::size_t>(sw->agents);
    h5::quietErrors();
    file_ = H5Handle(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
    if (!file_.valid()) throw InputError(path + ": cannot open as HDF5");
    const std::string g = "swarms/" + sw->name + "/";
    pos_ = H5Handle(H5Dopen2(file_, (g + "position").c_str(), H5P_DEFAULT), H5Dclose);
    if (info_.hasVelocity) vel_ = H5Handle(H5Dopen2(file_, (g + "velocity").c_str(), H5P_DEFAULT), H5Dclose);
    if (!pos_.valid() || (info_.hasVelocity && !vel_.valid()))
      throw InputError(path + ": cannot open " + g + "position/velocity");
    // a block of frames of at most ~64 MB (positions and velocities together)
    const std::size_t perFrame = std::max<std::size_t>(1, agents_ * 3 * sizeof(float) * (info_.hasVelocity ? 2 : 1));
    block_ = std::clamp<std::size_t>((64u << 20) / perFrame, 1, 512);
  }

  void read(std::int64_t k, Frame& out) override {
    if (k < blockFirst_ || k >= blockFirst_ + blockCount_) load(k);
    const std::size_t off = static_cast<std::size_t>(k - blockFirst_) * agents_ * 3;
    out.sample = k;
    out.dense = true;
    out.id.resize(agents_);
    for (std::size_t i = 0; i < agents_; ++i) out.id[i] = static_cast<std::int64_t>(i);
    out.pos.resize(agents_ * 3);
    for (std::size_t i = 0; i < agents_ * 3; ++i) out.pos[i] = static_cast<double>(posBuf_[off + i]);
    if (info_.hasVelocity) {
      out.vel.resize(agents_ * 3);
      for (std::size_t i = 0; i < agents_ * 3; ++i) out.vel[i] = static_cast<double>(velBuf_[off + i]);
    } else {
      out.vel.clear();
    }
    // an agent whose position is not finite is absent from this frame (a replayed track not yet started)
    bool absent = false;
    for (std::size_t i = 0; i < agents_ * 3 && !absent; ++i) absent = !std::isfinite(out.pos[i]);
    if (absent) {
      std::size_t w = 0;
      for (std::size_t i = 0; i < agents_; ++i) {
        const double* p = &out.pos[3 * i];
        if (!(std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]))) continue;
        out.id[w] = out.id[i];
        for (int c = 0; c < 3; ++c) {
          out.pos[3 * w + c] = p[c];
          if (info_.hasVelocity) out.vel[3 * w + c] = out.vel[3 * i + c];
        }
        ++w;
      }
      out.id.resize(w);
      out.pos.resize(3 * w);
      if (info_.hasVelocity) out.vel.resize(3 * w);
      out.dense = false;
    }
    if (k + 1 == info_.last) {  // end of a pass: free the block until the next pass
      std::vector<float>().swap(posBuf_);
      std::vector<float>().swap(velBuf_);
      blockCount_ = 0;
    }
  }

 private:
  void load(std::int64_t k) {
    blockFirst_ = k;
    blockCount_ = std::min<std::int64_t>(static_cast<std::int64_t>(block_), info_.last - k);
    const std::size_t n = static_cast<std::size_t>(blockCount_) * agents_ * 3;
    posBuf_.resize(n);
    readBlock(pos_, posBuf_, "position");
    if (info_.hasVelocity) {
      velBuf_.resize(n);
      readBlock(vel_, velBuf_, "velocity");
    }
  }
  void readBlock(hid_t ds, std::vector<float>& buf, const char* what) {
    if (agents_ == 0) return;
    const hsize_t start[3] = {static_cast<hsize_t>(blockFirst_), 0, 0};
    const hsize_t count[3] = {static_cast<hsize_t>(blockCount_), agents_, 3};
    H5Handle fspace(H5Dget_space(ds), H5Sclose);
    H5Handle mspace(H5Screate_simple(3, count, nullptr), H5Sclose);
    if (!fspace.valid() || !mspace.valid() ||
        H5Sselect_hyperslab(fspace, H5S_SELECT_SET, start, nullptr, count, nullptr) < 0 ||
        H5Dread(ds, H5T_NATIVE_FLOAT, mspace, fspace, H5P_DEFAULT, buf.data()) < 0) {
      throw InputError(info_.file + ": cannot read " + what + " of swarm \"" + info_.swarm + "\" frames " +
                       std::to_string(blockFirst_) + ".." + std::to_string(blockFirst_ + blockCount_ - 1));
    }
  }

  H5Handle file_, pos_, vel_;
  std::int64_t frames_ = 0;
  std::size_t agents_ = 0, block_ = 1;
  std::int64_t blockFirst_ = 0, blockCount_ = 0;
  std::vector<float> posBuf_, velBuf_;
};

// ---------------------------------------------------------------- CSV

struct Row {
  std::int64_t id = 0;
  std::int64_t sample = 0;
  double t = 0.0;
  double p[3] = {0, 0, 0};
  double v[3] = {0, 0, 0};
  std::int64_t line = 0;
};

class CsvSource : public TrackSource {
 public:
  CsvSource(const std::string& path, const SourceOptions& options) {
    info_.file = path;
    info_.kind = "csv";
    std::ifstream in(path, std::ios::binary);
    if (!in) throw InputError(path + ": cannot open");
    std::string line;
    std::int64_t lineNo = 0;
    // header: the first non-empty line
    std::string header;
    while (std::getline(in, line)) {
      ++lineNo;
      if (!line.empty() && line.back() == '\r') line.pop_back();
      if (!trimCell(line).empty()) {
        header = line;
        break;
      }
    }
    if (header.empty()) throw InputError(path + ": empty file (expected a header line)");
    const char delim = delimiterFor(header, options.csv.delimiter, path);
    const auto names = splitLine(header, delim);
    std::string headerList;
    for (const auto& n : names) headerList += (headerList.empty() ? "" : ", ") + n;
    const auto cols = chooseColumns(names, options.csv.columns, path, headerList);
    info_.hasVelocity = cols[5] >= 0;
    int needed = 0;
    for (int c : cols) needed = std::max(needed, c + 1);

    std::unordered_map<std::string, std::int64_t> ids;
    idNames_.clear();
    while (std::getline(in, line)) {
      ++lineNo;
      if (!line.empty() && line.back() == '\r') line.pop_back();
      if (trimCell(line).empty()) continue;
      const auto cells = splitLine(line, delim);
      const std::string where = path + ":" + std::to_string(lineNo);
      if (static_cast<int>(cells.size()) < needed) {
        throw InputError(where + ": expected " + std::to_string(names.size()) + " fields, got " +
                         std::to_string(cells.size()));
      }
      Row r;
      r.line = lineNo;
      const auto num = [&](int key) {
        const std::string& cell = cells[static_cast<std::size_t>(cols[static_cast<std::size_t>(key)])];
        const std::string& name = names[static_cast<std::size_t>(cols[static_cast<std::size_t>(key)])];
        char* end = nullptr;
        const double v = std::strtod(cell.c_str(), &end);
        if (cell.empty() || *end != '\0') {
          throw InputError(where + ": column " + name + ": expected a number, got \"" + cell + "\"");
        }
        if (!std::isfinite(v)) throw InputError(where + ": column " + name + ": not a finite number: \"" + cell + "\"");
        return v;
      };
      const std::string& idCell = cells[static_cast<std::size_t>(cols[0])];
      if (idCell.empty())
        throw InputError(where + ": column " + names[static_cast<std::size_t>(cols[0])] + ": empty id");
      const auto it = ids.emplace(idCell, static_cast<std::int64_t>(ids.size())).first;
      if (it->second == static_cast<std::int64_t>(idNames_.size())) idNames_.push_back(idCell);
      r.id = it->second;
      r.t = num(1);
      for (int a = 0; a < 3; ++a) r.p[a] = num(2 + a);
      if (info_.hasVelocity) {
        for (int a = 0; a < 3; ++a) r.v[a] = num(5 + a);
      }
      rows_.push_back(r);
    }
    if (rows_.size() < 2) {
      throw InputError(path + ": " + std::to_string(rows_.size()) + " sample(s); need at least 2");
    }
    // dt: median positive step within tracks
    std::sort(rows_.begin(), rows_.end(), [](const Row& a, const Row& b) {
      return a.id != b.id ? a.id < b.id : (a.t != b.t ? a.t < b.t : a.line < b.line);
    });
    std::vector<double> steps;
    double t0 = rows_[0].t;
    for (std::size_t i = 0; i < rows_.size(); ++i) {
      t0 = std::min(t0, rows_[i].t);
      if (i > 0 && rows_[i].id == rows_[i - 1].id && rows_[i].t > rows_[i - 1].t)
        steps.push_back(rows_[i].t - rows_[i - 1].t);
    }
    if (steps.empty()) {
      throw InputError(path + ": cannot determine the sampling interval: no track has two samples at different times");
    }
    const std::size_t mid = (steps.size() - 1) / 2;
    std::nth_element(steps.begin(), steps.begin() + static_cast<std::ptrdiff_t>(mid), steps.end());
    const double dt0 = steps[mid];
    // refined: the mean of the single steps (within 25 % of the median). Times rounded to a few decimals
    // (60 fps written as 0.0167, 0.0333, 0.05, ...) give steps that differ from the true interval by the
    // rounding, and the median is then off by up to half a unit of the last decimal, which piles up to a
    // whole sample over a long track; consecutive steps' rounding errors cancel in the mean.
    double sum = 0;
    std::size_t count = 0;
    for (double st : steps) {
      if (std::abs(st / dt0 - 1.0) < 0.25) {
        sum += st;
        ++count;
      }
    }
    const double mean = count > 0 ? sum / static_cast<double>(count) : dt0;
    info_.dt = std::abs(mean - dt0) > 1e-6 * dt0 ? mean : dt0;  // dt0 unless it is really off
    std::int64_t maxSample = 0;
    for (auto& r : rows_) {
      r.sample = std::llround((r.t - t0) / info_.dt);
      maxSample = std::max(maxSample, r.sample);
    }
    std::sort(rows_.begin(), rows_.end(), [](const Row& a, const Row& b) {
      return a.sample != b.sample ? a.sample < b.sample : (a.id != b.id ? a.id < b.id : a.line < b.line);
    });
    for (std::size_t i = 1; i < rows_.size(); ++i) {
      const Row &a = rows_[i - 1], &b = rows_[i];
      if (a.sample == b.sample && a.id == b.id) {
        std::ostringstream m;
        m << path << ":" << b.line << ": duplicate sample: id \"" << idNames_[static_cast<std::size_t>(b.id)]
          << "\" at time " << b.t << " falls on sample " << b.sample << " (dt " << info_.dt << " s), like line "
          << a.line;
        throw InputError(m.str());
      }
    }
    options.frames.resolve(maxSample + 1, info_.first, info_.last);
    // frame offsets over [first, last]
    start_.assign(static_cast<std::size_t>(info_.last - info_.first + 1), 0);
    std::size_t r = 0;
    std::vector<char> seen(idNames_.size(), 0);
    std::int64_t distinctSamples = 0;
    while (r < rows_.size() && rows_[r].sample < info_.first) ++r;
    for (std::int64_t k = info_.first; k < info_.last; ++k) {
      start_[static_cast<std::size_t>(k - info_.first)] = r;
      const std::size_t r0 = r;
      while (r < rows_.size() && rows_[r].sample == k) seen[static_cast<std::size_t>(rows_[r++].id)] = 1;
      if (r > r0) ++distinctSamples;
    }
    start_.back() = r;
    if (distinctSamples < 2) {
      throw InputError(path + ": " + std::to_string(distinctSamples) + " sample(s) of the time grid (dt " +
                       std::to_string(info_.dt) + " s) selected; need at least 2");
    }
    info_.individuals = static_cast<std::int64_t>(std::count(seen.begin(), seen.end(), 1));
  }

  void read(std::int64_t k, Frame& out) override {
    const std::size_t a = start_[static_cast<std::size_t>(k - info_.first)];
    const std::size_t b = start_[static_cast<std::size_t>(k - info_.first + 1)];
    out.sample = k;
    out.dense = false;
    out.id.clear();
    out.pos.clear();
    out.vel.clear();
    for (std::size_t i = a; i < b; ++i) {
      out.id.push_back(rows_[i].id);
      out.pos.insert(out.pos.end(), rows_[i].p, rows_[i].p + 3);
      if (info_.hasVelocity) out.vel.insert(out.vel.end(), rows_[i].v, rows_[i].v + 3);
    }
  }

 private:
  static char delimiterFor(const std::string& header, const std::string& option, const std::string& path) {
    if (!option.empty()) {
      if (option == "tab" || option == "\\t" || option == "\t") return '\t';
      if (option == "," || option == ";") return option[0];
      throw InputError("--delimiter: expected \",\", \";\" or \"tab\", got \"" + option + "\"");
    }
    const char cands[3] = {';', ',', '\t'};
    char best = 0;
    long bestCount = 0;
    for (char c : cands) {
      const long n = static_cast<long>(std::count(header.begin(), header.end(), c));
      if (n > bestCount) {
        best = c;
        bestCount = n;
      }
    }
    if (!best)
      throw InputError(path + ":1: cannot detect the delimiter (no ';', ',' or tab in the header); use --delimiter");
    return best;
  }

  // column indices for id, time, x, y, z, vx, vy, vz (-1: absent; velocities all or none)
  static std::vector<int> chooseColumns(const std::vector<std::string>& names, const std::string& option,
                                        const std::string& path, const std::string& headerList) {
    const std::vector<std::string> keys = {"id", "time", "x", "y", "z", "vx", "vy", "vz"};
    std::vector<std::string> low;
    for (const auto& n : names) low.push_back(lower(n));
    const auto exact = [&](const std::string& s) {
      for (std::size_t i = 0; i < low.size(); ++i) {
        if (low[i] == s) return static_cast<int>(i);
      }
      return -1;
    };
    const auto prefix = [&](const std::string& s) {
      for (std::size_t i = 0; i < low.size(); ++i) {
        if (low[i].compare(0, s.size(), s) == 0) return static_cast<int>(i);
      }
      return -1;
    };
    std::vector<int> cols(8, -1);
    std::map<std::string, std::string> given;
    if (!option.empty()) {
      std::stringstream ss(option);
      std::string item;
      while (std::getline(ss, item, ',')) {
        const auto eq = item.find('=');
        const std::string key = eq == std::string::npos ? "" : lower(trimCell(item.substr(0, eq)));
        if (eq == std::string::npos || std::find(keys.begin(), keys.end(), key) == keys.end() ||
            trimCell(item.substr(eq + 1)).empty()) {
          throw InputError("--columns: expected KEY=NAME items with KEY one of id, time, x, y, z, vx, vy, vz; got \"" +
                           item + "\"");
        }
        given[key] = trimCell(item.substr(eq + 1));
      }
    }
    for (std::size_t k = 0; k < keys.size(); ++k) {
      const auto g = given.find(keys[k]);
      if (g != given.end()) {
        cols[k] = exact(lower(g->second));
        if (cols[k] < 0) {
          throw InputError(path + ":1: no column \"" + g->second + "\" (given for " + keys[k] +
                           " by --columns); header: " + headerList);
        }
        continue;
      }
      if (k == 0) {
        for (const char* n : {"id", "object", "track", "track_id", "individual"}) {
          if (cols[0] < 0) cols[0] = exact(n);
        }
      } else if (k == 1) {
        cols[1] = exact("time");
        if (cols[1] < 0) cols[1] = exact("t");
      } else {
        cols[k] = exact(keys[k]);
        if (cols[k] < 0) cols[k] = prefix(keys[k]);
      }
    }
    const char* hints[5] = {"id (id, object, track, track_id or individual)", "time (time or t)",
                            "x (x or a name starting with x)", "y (y or a name starting with y)",
                            "z (z or a name starting with z)"};
    for (std::size_t k = 0; k < 5; ++k) {
      if (cols[k] < 0) throw InputError(path + ":1: missing column for " + hints[k] + "; header: " + headerList);
    }
    const int vcount = (cols[5] >= 0) + (cols[6] >= 0) + (cols[7] >= 0);
    const bool vgiven = given.count("vx") + given.count("vy") + given.count("vz") > 0;
    if (vcount != 3) {
      if (vgiven) {
        throw InputError(path +
                         ":1: --columns names only some of vx, vy, vz (give all three or none); header: " + headerList);
      }
      cols[5] = cols[6] = cols[7] = -1;
    }
    return cols;
  }

  std::vector<Row> rows_;
  std::vector<std::string> idNames_;
  std::vector<std::size_t> start_;
};

}  // namespace

std::unique_ptr<TrackSource> openTracks(const std::string& path, const SourceOptions& options) {
  {
    std::ifstream probe(path, std::ios::binary);
    if (!probe) throw InputError(path + ": cannot open (no such file or not readable)");
  }
  if (looksLikeHdf5(path)) return std::make_unique<Hdf5Source>(path, options);
  return std::make_unique<CsvSource>(path, options);
}

}  // namespace swarmsim::eval
