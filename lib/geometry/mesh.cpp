#include "geometry/mesh.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string_view>
#include <utility>

#include <tiny_obj_loader.h>

#include "core/error.hpp"

namespace swarmsim {

Eigen::AlignedBox3d TriangleMesh::bounds() const {
  Eigen::AlignedBox3d box;  // empty
  for (const Vec3d& v : vertices) box.extend(v);
  return box;
}

namespace {

// cosine and sine of an angle in degrees, exact for multiples of 90
void cosSinDeg(double deg, double& c, double& s) {
  // one turn at most first (fmod is exact, so multiples of 90 stay exact), so the
  // conversion of the quarter turns to an integer cannot overflow for any angle
  deg = std::fmod(deg, 360.0);
  const double quarter = deg / 90.0;
  if (quarter == std::round(quarter)) {
    const long long q = static_cast<long long>(std::round(quarter)) % 4;
    const int k = static_cast<int>(q < 0 ? q + 4 : q);
    const double cs[4] = {1.0, 0.0, -1.0, 0.0};
    c = cs[k];
    s = cs[(k + 3) % 4];
    return;
  }
  const double rad = deg * (3.14159265358979323846 / 180.0);
  c = std::cos(rad);
  s = std::sin(rad);
}

// right-handed rotation by deg degrees about the world axis `axis`
Eigen::Matrix3d axisRotation(int axis, double deg) {
  double c = 1.0, s = 0.0;
  cosSinDeg(deg, c, s);
  const int u = (axis + 1) % 3, v = (axis + 2) % 3;
  Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
  r(u, u) = c;
  r(u, v) = -s;
  r(v, u) = s;
  r(v, v) = c;
  return r;
}

}  // namespace

Eigen::Matrix3d MeshTransform::rotation() const {
  return axisRotation(2, rotateDeg.z()) * axisRotation(1, rotateDeg.y()) * axisRotation(0, rotateDeg.x());
}

Vec3d MeshTransform::apply(const Vec3d& p) const { return translate + rotation() * scale.cwiseProduct(p); }

namespace {

// OBJ line validation -------------------------------------------------------

bool isBlank(char c) { return c == ' ' || c == '\t'; }

// whitespace-separated tokens of a line (tinyobjloader splits on ' ' and '\t')
std::vector<std::string_view> tokens(std::string_view s) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && isBlank(s[i])) ++i;
    const std::size_t start = i;
    while (i < s.size() && !isBlank(s[i])) ++i;
    if (i > start) out.push_back(s.substr(start, i - start));
  }
  return out;
}

bool isDigit(char c) { return c >= '0' && c <= '9'; }

// [+-]? (digits ('.' digits*)? | '.' digits) ([eE] [+-]? digits)?  -- the
// numbers tinyobjloader reads in full
bool isObjNumber(std::string_view s) {
  std::size_t i = 0;
  if (i < s.size() && (s[i] == '+' || s[i] == '-')) ++i;
  std::size_t digits = 0;
  while (i < s.size() && isDigit(s[i])) ++i, ++digits;
  if (i < s.size() && s[i] == '.') {
    ++i;
    while (i < s.size() && isDigit(s[i])) ++i, ++digits;
  }
  if (digits == 0) return false;
  if (i < s.size() && (s[i] == 'e' || s[i] == 'E')) {
    ++i;
    if (i < s.size() && (s[i] == '+' || s[i] == '-')) ++i;
    std::size_t expDigits = 0;
    while (i < s.size() && isDigit(s[i])) ++i, ++expDigits;
    if (expDigits == 0) return false;
  }
  return i == s.size();
}

// "nan", "inf", "infinity" in any case, optionally signed
bool isNonFiniteWord(std::string_view s) {
  if (!s.empty() && (s[0] == '+' || s[0] == '-')) s.remove_prefix(1);
  std::string lower(s);
  for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return lower == "nan" || lower.rfind("nan(", 0) == 0 || lower == "inf" || lower == "infinity";
}

// [+-]? digits as a 64-bit integer; false if malformed (huge values saturate)
bool parseIndex(std::string_view s, long long& out) {
  bool negative = false;
  if (!s.empty() && (s[0] == '+' || s[0] == '-')) {
    negative = s[0] == '-';
    s.remove_prefix(1);
  }
  if (s.empty() || !std::all_of(s.begin(), s.end(), isDigit)) return false;
  long long v = 0;
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  if (r.ec == std::errc::result_out_of_range) v = std::numeric_limits<long long>::max();
  out = negative ? -v : v;
  return true;
}

// "v", "v/vt", "v//vn" or "v/vt/vn" with integer parts; the vertex index goes to v
bool parseFaceVertex(std::string_view s, long long& v) {
  std::string_view parts[3];
  std::size_t n = 0;
  std::size_t start = 0;
  for (std::size_t i = 0; i <= s.size(); ++i) {
    if (i == s.size() || s[i] == '/') {
      if (n == 3) return false;
      parts[n++] = s.substr(start, i - start);
      start = i + 1;
    }
  }
  long long unused = 0;
  if (!parseIndex(parts[0], v)) return false;
  if (n == 2 && !parseIndex(parts[1], unused)) return false;
  if (n == 3 && !parts[1].empty() && !parseIndex(parts[1], unused)) return false;
  if (n == 3 && !parseIndex(parts[2], unused)) return false;
  return true;
}

struct ObjLine {
  std::size_t number;     // 1-based
  std::string_view text;  // without the line break, leading blanks removed
};

// the lines of an OBJ text split as tinyobjloader splits them ("\n", "\r\n" or "\r")
std::vector<ObjLine> splitLines(const std::string& text) {
  std::vector<ObjLine> lines;
  std::size_t i = 0, number = 0;
  while (i < text.size()) {
    std::size_t end = i;
    while (end < text.size() && text[end] != '\n' && text[end] != '\r') ++end;
    std::string_view line(text.data() + i, end - i);
    line = line.substr(0, line.find('\0'));  // tinyobjloader reads C strings
    std::size_t lead = 0;
    while (lead < line.size() && isBlank(line[lead])) ++lead;
    lines.push_back({++number, line.substr(lead)});
    if (end < text.size() && text[end] == '\r' && end + 1 < text.size() && text[end + 1] == '\n') ++end;
    i = end + 1;
  }
  return lines;
}

// the keyword of an OBJ statement: tinyobjloader's "v" is 'v' followed by a blank
bool isStatement(std::string_view line, char key) {
  return !line.empty() && line[0] == key && (line.size() == 1 || isBlank(line[1]));
}

[[noreturn]] void fail(const std::string& path, std::size_t line, const std::string& what) {
  throw InputError(path + ":" + std::to_string(line) + ": " + what);
}

// Check the 'v' and 'f' lines; returns the line number of each vertex.
std::vector<std::size_t> validateObj(const std::string& path, const std::vector<ObjLine>& lines) {
  std::vector<std::size_t> vertexLines;
  for (const ObjLine& l : lines) {
    if (!isStatement(l.text, 'v')) continue;
    const auto tok = tokens(l.text.substr(1));
    if (tok.size() < 3) fail(path, l.number, "vertex needs 3 coordinates (x y z)");
    for (std::size_t a = 0; a < 3; ++a) {
      if (isNonFiniteWord(tok[a])) fail(path, l.number, "vertex is not finite");
      if (!isObjNumber(tok[a])) fail(path, l.number, "vertex coordinate '" + std::string(tok[a]) + "' is not a number");
    }
    vertexLines.push_back(l.number);
  }
  const long long total = static_cast<long long>(vertexLines.size());
  long long before = 0;  // vertices defined before the current line
  bool anyFace = false;
  for (const ObjLine& l : lines) {
    if (isStatement(l.text, 'v')) ++before;
    if (!isStatement(l.text, 'f')) continue;
    anyFace = true;
    const auto tok = tokens(l.text.substr(1));
    if (tok.size() < 3)
      fail(path, l.number, "face has " + std::to_string(tok.size()) + " vertices (expected at least 3)");
    for (std::string_view t : tok) {
      long long idx = 0;
      if (!parseFaceVertex(t, idx)) {
        fail(path, l.number,
             "bad face vertex '" + std::string(t) + "' (expected v, v/vt, v//vn or v/vt/vn with integer indices)");
      }
      const std::string s(t.substr(0, t.find('/')));
      if (idx == 0) fail(path, l.number, "face index 0 is invalid (OBJ indices start at 1)");
      if (idx > total) {
        fail(path, l.number, "face index " + s + " out of range (file has " + std::to_string(total) + " vertices)");
      }
      if (idx < 0 && before + idx < 0) {
        fail(path, l.number,
             "face index " + s + " out of range (" + std::to_string(before) + " vertices before this line)");
      }
    }
  }
  if (!anyFace) throw InputError(path + ": no faces (expected at least one 'f' line)");
  return vertexLines;
}

// The text without a UTF-8 byte-order mark and without comments ('#' to the
// end of the line, also after data, which tinyobjloader would misread); line
// breaks are kept, so line numbers stay the same.
std::string withoutComments(const std::string& raw) {
  std::string out;
  out.reserve(raw.size());
  std::size_t i = raw.compare(0, 3, "\xEF\xBB\xBF") == 0 ? 3 : 0;
  bool comment = false;
  for (; i < raw.size(); ++i) {
    const char c = raw[i];
    if (c == '\n' || c == '\r') comment = false;
    if (c == '#') comment = true;
    if (!comment) out += c;
  }
  return out;
}

std::string trimmed(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == '\r' || s.back() == ' ' || s.back() == '.')) s.pop_back();
  return s;
}

}  // namespace

std::string readObjFile(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw InputError(path + ": cannot open OBJ file (it is a directory)");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open OBJ file");
  std::ostringstream buffer;
  buffer << in.rdbuf();
  if (in.bad()) throw InputError(path + ": cannot open OBJ file (read error)");
  return buffer.str();
}

TriangleMesh loadObj(const std::string& path, const MeshTransform& t, double maxCoordinate) {
  return parseObj(readObjFile(path), path, t, maxCoordinate);
}

TriangleMesh parseObj(const std::string& bytes, const std::string& path, const MeshTransform& t,
                      double maxCoordinate) {
  // validation and tinyobjloader parse the same text
  const std::string text = withoutComments(bytes);

  // our own checks, with line numbers
  const std::vector<ObjLine> lines = splitLines(text);
  const std::vector<std::size_t> vertexLines = validateObj(path, lines);

  // tinyobjloader parses and triangulates (mtllib is not followed for strings)
  tinyobj::ObjReaderConfig config;
  config.triangulate = true;
  config.vertex_color = false;
  tinyobj::ObjReader reader;
  if (!reader.ParseFromString(text, std::string(), config)) {
    const std::string msg = trimmed(reader.Error());
    throw InputError(path + ": " + (msg.empty() ? std::string("cannot parse OBJ file") : msg));
  }
  const tinyobj::attrib_t& attrib = reader.GetAttrib();
  if (attrib.vertices.size() != 3 * vertexLines.size()) {
    throw InputError(path + ": vertex count differs from the 'v' lines (unsupported OBJ syntax)");
  }

  // vertices: finite in the loader's precision, then placed
  TriangleMesh mesh;
  mesh.source = path;
  mesh.vertices.reserve(vertexLines.size());
  const Eigen::Matrix3d rotation = t.rotation();
  for (std::size_t v = 0; v < vertexLines.size(); ++v) {
    const Vec3d p(static_cast<double>(attrib.vertices[3 * v]), static_cast<double>(attrib.vertices[3 * v + 1]),
                  static_cast<double>(attrib.vertices[3 * v + 2]));
    if (!p.allFinite()) fail(path, vertexLines[v], "vertex is not finite");
    const Vec3d q = t.translate + rotation * t.scale.cwiseProduct(p);
    if (!q.allFinite()) fail(path, vertexLines[v], "vertex is not finite after the transform");
    if (!(q.cwiseAbs().maxCoeff() <= maxCoordinate)) {
      std::ostringstream where;
      where << "vertex placed at (" << q.x() << ", " << q.y() << ", " << q.z()
            << ") by translate, rotate and scale (expected every coordinate within +-" << maxCoordinate << " m)";
      fail(path, vertexLines[v], where.str());
    }
    mesh.vertices.push_back(q);
  }

  // triangles of all shapes
  for (const tinyobj::shape_t& shape : reader.GetShapes()) {
    const auto& idx = shape.mesh.indices;
    std::size_t offset = 0;
    for (const unsigned int fv : shape.mesh.num_face_vertices) {
      if (fv == 3) {
        std::array<std::uint32_t, 3> tri{};
        for (std::size_t c = 0; c < 3; ++c) tri[c] = static_cast<std::uint32_t>(idx[offset + c].vertex_index);
        mesh.triangles.push_back(tri);
      }
      offset += fv;
    }
  }
  if (mesh.triangles.empty()) throw InputError(path + ": no faces left after triangulation (all degenerate)");
  return mesh;
}

bool isWatertight(const TriangleMesh& mesh) {
  if (mesh.triangles.empty()) return false;
  // directed edges as (from << 32 | to); each must be unique and have its reverse
  std::vector<std::uint64_t> edges;
  edges.reserve(3 * mesh.triangles.size());
  for (const auto& tri : mesh.triangles) {
    if (tri[0] == tri[1] || tri[1] == tri[2] || tri[2] == tri[0]) return false;
    for (int e = 0; e < 3; ++e) {
      edges.push_back(static_cast<std::uint64_t>(tri[e]) << 32 | tri[(e + 1) % 3]);
    }
  }
  std::sort(edges.begin(), edges.end());
  if (std::adjacent_find(edges.begin(), edges.end()) != edges.end()) return false;
  for (const std::uint64_t e : edges) {
    const std::uint64_t reverse = (e << 32) | (e >> 32);
    if (!std::binary_search(edges.begin(), edges.end(), reverse)) return false;
  }
  return true;
}

}  // namespace swarmsim
