#include "io/export.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <vector>

#include "core/error.hpp"
#include "core/parallel.hpp"
#include "io/atomic_file.hpp"
#include "io/hdf5_handle.hpp"
#include "io/hdf5_util.hpp"
#include "io/scene_io.hpp"
#include "io/trajectory_reader.hpp"

namespace swarmsim {

namespace fs = std::filesystem;

namespace {

constexpr const char* kCsvHeader = "frame,time,swarm,id,x,y,z";
// agents per block of CSV rows formatted at once (bounds the text held in memory: ~6 MB)
constexpr std::size_t kCsvBlock = 65536;

// the first bytes of a file (to recognise our own exports)
std::string head(const std::string& path, std::size_t n) {
  std::ifstream in(path, std::ios::binary);
  std::string s(n, '\0');
  in.read(s.data(), static_cast<std::streamsize>(n));
  s.resize(static_cast<std::size_t>(in.gcount()));
  return s;
}
bool isOwnCsv(const std::string& path) { return head(path, std::strlen(kCsvHeader)) == kCsvHeader; }
bool isOwnPly(const std::string& path) {
  const std::string h = head(path, 512);
  return h.rfind("ply\n", 0) == 0 && h.find("\ncomment swarmsim export") != std::string::npos;
}
bool isOwnXmf(const std::string& path) { return head(path, 512).find("<!-- swarmsim export") != std::string::npos; }

// one swarm of the input, read frame by frame
struct SwarmReader {
  std::string name;
  std::size_t index = 0;  // in scenario order
  std::size_t agents = 0;
  bool swarmIndex = false;  // the file has swarm_index (files of swarmsim 0.1 before the scene was stored do not)
  H5Handle pos, vel;
  std::vector<std::uint32_t> ids;
  std::vector<float> p, v;  // one frame: 3 per agent

  void read(std::int64_t frame, const std::string& file) {
    readRows(pos, frame, p, file, "position");
    if (vel.valid()) readRows(vel, frame, v, file, "velocity");
  }

 private:
  void readRows(hid_t ds, std::int64_t frame, std::vector<float>& buf, const std::string& file, const char* what) {
    buf.resize(3 * agents);
    if (agents == 0) return;
    const hsize_t start[3] = {static_cast<hsize_t>(frame), 0, 0}, count[3] = {1, agents, 3};
    H5Handle fspace(H5Dget_space(ds), H5Sclose);
    H5Handle mspace(H5Screate_simple(3, count, nullptr), H5Sclose);
    if (!fspace.valid() || !mspace.valid() ||
        H5Sselect_hyperslab(fspace, H5S_SELECT_SET, start, nullptr, count, nullptr) < 0 ||
        H5Dread(ds, H5T_NATIVE_FLOAT, mspace, fspace, H5P_DEFAULT, buf.data()) < 0) {
      throw InputError(file + ": cannot read " + what + " of swarm \"" + name + "\" at frame " +
                       std::to_string(frame));
    }
  }
};

struct Input {
  TrajectoryInfo info;
  H5Handle file;
  std::vector<double> time;
  std::vector<SwarmReader> swarms;  // the selected ones, in scenario order
  std::int64_t first = 0, last = 0;
  bool anyVelocity = false;
};

Input openInput(const ExportOptions& o) {
  Input in;
  in.info = readTrajectoryInfo(o.input);
  in.file = H5Handle(H5Fopen(o.input.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!in.file.valid()) throw InputError(o.input + ": cannot open as HDF5 (expected a swarmsim output file)");
  in.time = readDoubleDataset(o.input, "time");
  std::string names;
  for (std::size_t i = 0; i < in.info.swarms.size(); ++i) {
    const SwarmInfo& s = in.info.swarms[i];
    names += (names.empty() ? "" : ", ") + s.name;
    if (!o.swarm.empty() && s.name != o.swarm) continue;
    SwarmReader r;
    r.name = s.name;
    r.index = i;
    r.agents = static_cast<std::size_t>(s.agents);
    const std::string base = "swarms/" + s.name + "/";
    r.pos = H5Handle(H5Dopen2(in.file, (base + "position").c_str(), H5P_DEFAULT), H5Dclose);
    if (!r.pos.valid()) {
      throw InputError(o.input + ": swarm \"" + s.name + "\" has no positions (output.quantities); nothing to export");
    }
    if (H5Lexists(in.file, (base + "velocity").c_str(), H5P_DEFAULT) > 0) {
      r.vel = H5Handle(H5Dopen2(in.file, (base + "velocity").c_str(), H5P_DEFAULT), H5Dclose);
      in.anyVelocity = true;
    }
    r.swarmIndex = H5Lexists(in.file, (base + "swarm_index").c_str(), H5P_DEFAULT) > 0;
    H5Handle ids(H5Dopen2(in.file, (base + "id").c_str(), H5P_DEFAULT), H5Dclose);
    r.ids.resize(r.agents);
    if (!ids.valid() ||
        (r.agents > 0 && H5Dread(ids, H5T_NATIVE_UINT32, H5S_ALL, H5S_ALL, H5P_DEFAULT, r.ids.data()) < 0)) {
      throw InputError(o.input + ": cannot read the ids of swarm \"" + s.name + "\"");
    }
    in.swarms.push_back(std::move(r));
  }
  if (in.swarms.empty()) throw InputError("--swarm: expected one of the file's swarms (" + names + "), got \"" + o.swarm + "\"");
  const auto frames = static_cast<std::int64_t>(in.time.size());
  o.frames.resolve(frames, in.first, in.last);
  if (in.first >= in.last) {
    throw InputError("--frames: selects no frame of the file's " + std::to_string(frames) + " (0 to " +
                     std::to_string(frames - 1) + ")");
  }
  return in;
}

std::string defaultBeside(const std::string& input, const std::string& suffix) {
  fs::path p(input);
  return (p.parent_path() / (p.stem().string() + suffix)).string();
}

// shortest text that reads back as the same value
template <typename T>
void appendNumber(std::string& out, T v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, r.ptr);
}

bool present(const float* p) { return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]); }

// ---- csv ----

ExportResult exportCsv(const ExportOptions& o, Input& in, std::FILE* standardOutput) {
  ExportResult r;
  const bool toStdout = o.output == "-";
  r.where = toStdout ? "-" : (o.output.empty() ? defaultBeside(o.input, ".csv") : o.output);
  std::unique_ptr<AtomicFile> file;
  if (!toStdout) file = std::make_unique<AtomicFile>(r.where, o.force, isOwnCsv);
  const auto emit = [&](const std::string& text) {
    if (file) {
      file->write(text.data(), text.size());
    } else if (std::fwrite(text.data(), 1, text.size(), standardOutput) != text.size()) {
      throw OutputError(std::string("standard output: cannot write: ") + std::strerror(errno));
    }
  };
  std::string buf = std::string(kCsvHeader) + (in.anyVelocity ? ",vx,vy,vz\n" : "\n");
  // per-thread text of one block of agents, reused for every block (no allocation once grown)
  std::vector<std::string> chunkText(static_cast<std::size_t>(chunkCount(kCsvBlock)));
  std::vector<std::size_t> chunkRows(chunkText.size());
  for (std::int64_t f = in.first; f < in.last; ++f) {
    std::string prefix;
    appendNumber(prefix, f);
    prefix += ',';
    appendNumber(prefix, in.time[static_cast<std::size_t>(f)]);
    prefix += ',';
    for (SwarmReader& s : in.swarms) {
      s.read(f, o.input);
      const std::string rowStart = prefix + s.name + ",";
      // the rows of a block of agents are formatted in parallel, one contiguous chunk of agents per
      // thread into its own buffer, and written in agent order: the text is the serial one
      for (std::size_t a0 = 0; a0 < s.agents; a0 += kCsvBlock) {
        const std::size_t n = std::min(kCsvBlock, s.agents - a0);
        parallelChunks(n, [&](std::size_t b, std::size_t e, int t) {
          std::string& out = chunkText[static_cast<std::size_t>(t)];
          out.clear();
          std::size_t rows = 0;
          for (std::size_t a = a0 + b; a < a0 + e; ++a) {
            const float* p = &s.p[3 * a];
            if (!present(p)) continue;  // absent from this frame: no row (docs/output.md#absent-agents)
            out += rowStart;
            appendNumber(out, s.ids[a]);
            for (int k = 0; k < 3; ++k) {
              out += ',';
              appendNumber(out, p[k]);
            }
            if (in.anyVelocity) {
              for (int k = 0; k < 3; ++k) {
                out += ',';
                if (s.vel.valid()) appendNumber(out, s.v[3 * a + static_cast<std::size_t>(k)]);
              }
            }
            out += '\n';
            ++rows;
          }
          chunkRows[static_cast<std::size_t>(t)] = rows;
        });
        for (int t = 0; t < chunkCount(n); ++t) {
          buf += chunkText[static_cast<std::size_t>(t)];
          r.rows += chunkRows[static_cast<std::size_t>(t)];
        }
        if (buf.size() >= (1u << 20)) {
          emit(buf);
          buf.clear();
        }
      }
    }
    ++r.frames;
  }
  emit(buf);
  if (file) {
    file->commit();
  } else if (std::fflush(standardOutput) != 0) {
    throw OutputError(std::string("standard output: cannot write: ") + std::strerror(errno));
  }
  r.files = 1;
  return r;
}

// ---- ply ----

void plyHeader(std::string& h, const std::string& comment, std::size_t vertices, bool velocity, std::size_t faces) {
  h = "ply\nformat binary_little_endian 1.0\ncomment swarmsim export: " + comment + "\n";
  h += "element vertex " + std::to_string(vertices) + "\nproperty float x\nproperty float y\nproperty float z\n";
  if (velocity) h += "property float vx\nproperty float vy\nproperty float vz\n";
  if (faces == 0 && vertices > 0 && comment.rfind("obstacles", 0) != 0) h += "property uint id\n";
  if (faces > 0) h += "element face " + std::to_string(faces) + "\nproperty list uchar uint vertex_indices\n";
  h += "end_header\n";
}

template <typename T>
void appendBytes(std::string& out, T v) {  // x86-64 and every platform we build on are little-endian
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  out.append(b, sizeof(T));
}

ExportResult exportPly(const ExportOptions& o, Input& in) {
  ExportResult r;
  if (o.output == "-") throw InputError("-o -: only --format csv can go to standard output (ply writes a folder)");
  r.where = o.output.empty() ? defaultBeside(o.input, "_ply") : o.output;
  std::error_code ec;
  if (fs::exists(r.where, ec) && !fs::is_directory(r.where, ec)) {
    throw OutputError(r.where + ": exists and is not a folder (--format ply writes a folder of files)");
  }
  std::string buf, header;
  // the scene: every obstacle in one mesh
  const std::vector<SceneObstacle> scene = readScene(o.input);
  if (!scene.empty()) {
    std::size_t nv = 0, nf = 0;
    for (const auto& s : scene) {
      nv += s.vertices.size() / 3;
      nf += s.faces.size() / 3;
    }
    plyHeader(header, "obstacles of " + in.info.scenarioName, nv, false, nf);
    buf = header;
    for (const auto& s : scene) {
      for (double c : s.vertices) appendBytes(buf, static_cast<float>(c));
    }
    std::uint32_t offset = 0;
    for (const auto& s : scene) {
      for (std::size_t t = 0; t + 2 < s.faces.size(); t += 3) {
        appendBytes(buf, static_cast<std::uint8_t>(3));
        for (int k = 0; k < 3; ++k) appendBytes(buf, s.faces[t + static_cast<std::size_t>(k)] + offset);
      }
      offset += static_cast<std::uint32_t>(s.vertices.size() / 3);
    }
    AtomicFile file((fs::path(r.where) / "obstacles.ply").string(), o.force, isOwnPly);
    file.write(buf.data(), buf.size());
    file.commit();
    ++r.files;
  }
  for (std::int64_t f = in.first; f < in.last; ++f) {
    for (SwarmReader& s : in.swarms) {
      s.read(f, o.input);
      std::size_t n = 0;
      for (std::size_t a = 0; a < s.agents; ++a) n += present(&s.p[3 * a]) ? 1 : 0;
      const bool velocity = s.vel.valid();
      char frameName[32];
      std::snprintf(frameName, sizeof frameName, ".%04lld.ply", static_cast<long long>(f));
      std::string comment = "swarm " + s.name + " frame " + std::to_string(f) + " time ";
      appendNumber(comment, in.time[static_cast<std::size_t>(f)]);
      plyHeader(header, comment, n, velocity, 0);
      buf = header;
      buf.reserve(header.size() + n * (velocity ? 28 : 16));
      for (std::size_t a = 0; a < s.agents; ++a) {
        const float* p = &s.p[3 * a];
        if (!present(p)) continue;
        for (int k = 0; k < 3; ++k) appendBytes(buf, p[k]);
        if (velocity) {
          for (int k = 0; k < 3; ++k) appendBytes(buf, s.v[3 * a + static_cast<std::size_t>(k)]);
        }
        appendBytes(buf, s.ids[a]);
      }
      AtomicFile file((fs::path(r.where) / (s.name + frameName)).string(), o.force, isOwnPly);
      file.write(buf.data(), buf.size());
      file.commit();
      ++r.files;
      r.rows += static_cast<std::int64_t>(n);
    }
    ++r.frames;
  }
  return r;
}

// ---- xdmf ----

std::string xmlEscape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

ExportResult exportXdmf(const ExportOptions& o, Input& in) {
  ExportResult r;
  if (o.output == "-") throw InputError("-o -: only --format csv can go to standard output");
  r.where = o.output.empty() ? defaultBeside(o.input, ".xmf2") : o.output;
  // Two dialects, by the file's extension, for ParaView 5.11's two XDMF readers: .xmf2 and .xdmf2 are
  // opened by its "XDMF Reader" alone (the GUI asks nothing), which reads a frame of a dataset as an XML
  // HyperSlab item; .xmf, .xdmf (and .xmf3, .xdmf3), which the GUI offers to three readers and
  // OpenDataFile gives to "Xdmf3ReaderS", get the Xdmf3 reader's "file:/path|start:stride:count:dims".
  const std::string ext = fs::path(r.where).extension().string();
  const bool xdmf2 = ext == ".xmf2" || ext == ".xdmf2";
  if (!xdmf2 && ext != ".xmf" && ext != ".xdmf" && ext != ".xmf3" && ext != ".xdmf3") {
    throw InputError("-o: expected a file name ending in .xmf2 or .xdmf2 (ParaView's XDMF Reader) or .xmf, "
                     ".xdmf, .xmf3, .xdmf3 (its Xdmf3 readers), got \"" + r.where + "\"");
  }
  // the .h5 as the file names it: absolute (ParaView 5.11's Xdmf3 reader resolves a relative name against
  // the file's folder only when it is opened with a folder in its path), or relative with --relative
  const fs::path xmfDir = fs::absolute(fs::path(r.where)).parent_path();
  const fs::path h5 = fs::weakly_canonical(fs::absolute(o.input));
  const std::string h5Name = xmlEscape(o.relative ? fs::relative(h5, fs::weakly_canonical(xmfDir)).string() : h5.string());
  const std::int64_t frames = static_cast<std::int64_t>(in.time.size());
  const std::vector<SceneObstacle> scene = readScene(o.input);

  std::string x;
  x += "<?xml version=\"1.0\" ?>\n";
  x += "<!-- swarmsim export of " + xmlEscape(h5.filename().string()) + " (scenario " +
       xmlEscape(in.info.scenarioName) + "): frames " + std::to_string(in.first) + " to " +
       std::to_string(in.last - 1) + "; docs/tools.md#paraview -->\n";
  x += std::string("<Xdmf Version=\"") + (xdmf2 ? "2.0" : "3.0") + "\">\n <Domain>\n";
  x += "  <Grid Name=\"swarms\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  for (std::int64_t f = in.first; f < in.last; ++f) {
    char t[32];
    const auto tr = std::to_chars(t, t + sizeof t, in.time[static_cast<std::size_t>(f)]);
    x += "   <Grid Name=\"frame " + std::to_string(f) + "\" GridType=\"Collection\" CollectionType=\"Spatial\">\n";
    x += "    <Time Value=\"" + std::string(t, tr.ptr) + "\"/>\n";
    for (const SwarmReader& s : in.swarms) {
      const std::string n = std::to_string(s.agents);
      const std::string base = h5Name + ":/swarms/" + xmlEscape(s.name) + "/";
      // frame f of a (frames, n, 3) float dataset
      const auto frameItem = [&](const char* dataset) {
        const std::string full = "<DataItem Dimensions=\"" + std::to_string(frames) + " " + n +
                                 " 3\" NumberType=\"Float\" Precision=\"4\" Format=\"HDF\">" + base + dataset;
        if (xdmf2) {
          return "<DataItem ItemType=\"HyperSlab\" Dimensions=\"" + n + " 3\" Type=\"HyperSlab\"><DataItem Dimensions=\"3 3\" "
                 "Format=\"XML\">" + std::to_string(f) + " 0 0 1 1 1 1 " + n + " 3</DataItem>" + full +
                 "</DataItem></DataItem>";
        }
        return "<DataItem Dimensions=\"" + n + " 3\" NumberType=\"Float\" Precision=\"4\" Format=\"HDF\">" + base +
               dataset + "|" + std::to_string(f) + " 0 0:1 1 1:1 " + n + " 3:" + std::to_string(frames) + " " + n +
               " 3</DataItem>";
      };
      x += "    <Grid Name=\"" + xmlEscape(s.name) + "\" GridType=\"Uniform\">\n";
      // one vertex cell per point: the XDMF Reader makes them itself; the Xdmf3 reader needs the
      // connectivity, which is the id dataset (ids are the row numbers, docs/output.md)
      x += "     <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"" + n + "\" NodesPerElement=\"1\"";
      x += xdmf2 ? std::string("/>\n")
                 : "><DataItem Dimensions=\"" + n + "\" NumberType=\"UInt\" Precision=\"4\" Format=\"HDF\">" + base +
                       "id</DataItem></Topology>\n";
      x += "     <Geometry GeometryType=\"XYZ\">" + frameItem("position") + "</Geometry>\n";
      if (s.vel.valid()) {
        x += "     <Attribute Name=\"velocity\" AttributeType=\"Vector\" Center=\"Node\">" + frameItem("velocity") +
             "</Attribute>\n";
      }
      x += "     <Attribute Name=\"id\" AttributeType=\"Scalar\" Center=\"Node\"><DataItem Dimensions=\"" + n +
           "\" NumberType=\"UInt\" Precision=\"4\" Format=\"HDF\">" + base + "id</DataItem></Attribute>\n";
      if (s.swarmIndex) {
        x += "     <Attribute Name=\"swarm\" AttributeType=\"Scalar\" Center=\"Node\"><DataItem Dimensions=\"" + n +
             "\" NumberType=\"UInt\" Precision=\"4\" Format=\"HDF\">" + base + "swarm_index</DataItem></Attribute>\n";
      }
      x += "    </Grid>\n";
      r.rows += static_cast<std::int64_t>(s.agents);
    }
    for (const SceneObstacle& ob : scene) {
      const std::string nv = std::to_string(ob.vertices.size() / 3), nf = std::to_string(ob.faces.size() / 3);
      const std::string base = h5Name + ":/scene/obstacles/" + ob.name + "/";
      x += "    <Grid Name=\"obstacle " + ob.name + " (" + ob.type + ")\" GridType=\"Uniform\">\n";
      x += "     <Topology TopologyType=\"Triangle\" NumberOfElements=\"" + nf + "\"><DataItem Dimensions=\"" + nf +
           " 3\" NumberType=\"UInt\" Precision=\"4\" Format=\"HDF\">" + base + "faces</DataItem></Topology>\n";
      x += "     <Geometry GeometryType=\"XYZ\"><DataItem Dimensions=\"" + nv +
           " 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" + base + "vertices</DataItem></Geometry>\n";
      x += "    </Grid>\n";
    }
    x += "   </Grid>\n";
    ++r.frames;
  }
  x += "  </Grid>\n </Domain>\n</Xdmf>\n";
  AtomicFile file(r.where, o.force, isOwnXmf);
  file.write(x.data(), x.size());
  file.commit();
  r.files = 1;
  return r;
}

}  // namespace

ExportResult runExport(const ExportOptions& options, std::FILE* standardOutput) {
  if (options.format != "xdmf" && options.format != "ply" && options.format != "csv") {
    throw InputError("--format: expected one of xdmf, ply, csv, got \"" + options.format + "\"");
  }
  h5::quietErrors();
  Input in = openInput(options);
  if (options.format == "csv") return exportCsv(options, in, standardOutput);
  if (options.format == "ply") return exportPly(options, in);
  return exportXdmf(options, in);
}

}  // namespace swarmsim
