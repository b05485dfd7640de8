#include "models/params_util.hpp"

#include <cmath>
#include <filesystem>
#include <sstream>

#include "core/error.hpp"

namespace swarmsim {

TriangleMesh readPlacedMesh(JsonReader& o, const std::string& scenarioFile) {
  const std::string path = o.requireInputPath("file");
  MeshTransform t;
  t.translate = o.vec3("translate", Vec3d::Zero(), Range::coordinate());
  t.rotateDeg = o.vec3("rotate", Vec3d::Zero());
  const Json* scale = o.raw("scale");
  if (scale && scale->is_number()) {
    const double k = scale->get<double>();
    if (!(k > 0.0) || !std::isfinite(k)) o.failExpected("scale", "a number > 0 or an array of 3 numbers > 0", *scale);
    t.scale = Vec3d::Constant(k);
  } else if (scale) {
    t.scale = o.vec3("scale", Vec3d::Ones(), Range::positive());
  }
  try {
    const auto readFile = [&] { return readObjFile(path); };
    const std::string bytes = o.inputs() ? *o.inputs()->read(path, readFile) : readFile();
    return parseObj(bytes, path, t, kMaxCoordinate);
  } catch (const InputError& e) {  // say which scenario entry referenced it
    throw InputError(scenarioFile + ": " + o.pathOf("file") + ": " + e.what());
  }
}

std::array<int, 3> readCells(JsonReader& r, const std::string& key, bool required, int lo, int hi) {
  const std::string expected = "an array of 3 integers in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
  const Json* v = r.raw(key);
  if (!v) {
    if (required) r.failMissing(key, expected);
    return {0, 0, 0};
  }
  if (!v->is_array() || v->size() != 3) r.failExpected(key, expected, *v);
  std::array<int, 3> out{};
  for (std::size_t a = 0; a < 3; ++a) {
    const Json& c = (*v)[a];
    if (!c.is_number_integer() || c.get<long long>() < lo || c.get<long long>() > hi) r.failExpected(key, expected, *v);
    out[a] = static_cast<int>(c.get<long long>());
  }
  return out;
}

void readSeeds(JsonReader& r, const std::string& key, std::array<std::uint64_t, 3>& seeds) {
  const Json* v = r.raw(key);
  if (!v) return;
  if (!v->is_array() || v->size() != 3) r.failExpected(key, "an array of 3 integers >= 0", *v);
  for (std::size_t a = 0; a < 3; ++a) {
    if (!(*v)[a].is_number_unsigned()) r.failExpected(key, "an array of 3 integers >= 0", *v);
    seeds[a] = (*v)[a].get<std::uint64_t>();
  }
}

void readKeyframes(JsonReader& r, std::vector<double>& times, std::vector<Vec3d>& centers) {
  for (JsonReader& k : r.objectArray("keyframes", false, 0)) {
    const double t = k.requireNumber("time", Range::nonNegative());
    if (!times.empty() && !(t > times.back())) k.failExpected("time", "a time later than the previous keyframe's", t);
    times.push_back(t);
    centers.push_back(k.requireVec3("center", Range::coordinate()));
    k.finish();
  }
}

void checkNoiseFrequency(JsonReader& r, const std::string& key, const Aabb& domain, double value, double perMetre) {
  // the domain's farthest coordinate, and a margin of a domain for the samples just outside it
  const double reach = domain.min.cwiseAbs().cwiseMax(domain.max.cwiseAbs()).maxCoeff() + domain.extent().maxCoeff();
  if (!(reach * value * perMetre <= kMaxNoiseLattice)) {
    std::ostringstream m;
    m << "expected a number <= " << kMaxNoiseLattice / (reach * perMetre) << " (the noise lattice may reach at most "
      << kMaxNoiseLattice << " cells from the origin in this domain), got " << value;
    r.fail(key, m.str());
  }
}

std::array<int, 3> cellsForEdge(const Aabb& domain, double edge, double maxCells) {
  std::array<int, 3> n{};
  for (double factor = 1.0;; factor *= 1.05) {
    double total = 1.0;
    for (int a = 0; a < 3; ++a) {
      // clamped in floating point before the conversion (a tiny edge must not overflow the int)
      n[a] = static_cast<int>(std::clamp(std::ceil(domain.extent()[a] / (edge * factor)), 4.0, 256.0));
      total *= n[a];
    }
    if (total <= maxCells) return n;
  }
}

Vec3d Keyed3::at(double t) const { return interpolateKeys(times, values, t); }

Keyed3 readPath(JsonReader& r, const char* what) {
  Keyed3 path;
  readKeyframes(r, path.times, path.values);
  if (path.times.empty()) {
    path.times.push_back(0.0);
    path.values.push_back(r.requireVec3("center", Range::coordinate()));
  } else if (r.has("center")) {
    r.fail("center", std::string("give either center or keyframes for ") + what + ", not both");
  }
  return path;
}

}  // namespace swarmsim
