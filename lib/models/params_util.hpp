#pragma once
// Parameter readers shared by the models' parsers.
#include <algorithm>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/json_reader.hpp"
#include "core/world.hpp"
#include "geometry/mesh.hpp"

namespace swarmsim {

// a mesh entry: "file" (relative to the folder of `scenarioFile`) placed by
// "translate", "rotate" (degrees) and "scale" (a number or three), as for obstacles;
// errors name the scenario file, the entry's JSON path and the OBJ line
TriangleMesh readPlacedMesh(JsonReader& o, const std::string& scenarioFile);

// three integers in [lo, hi] (grid cells per axis); absent: an error if required, else {0, 0, 0}
std::array<int, 3> readCells(JsonReader& r, const std::string& key, bool required, int lo, int hi);

// three integers >= 0 (Perlin seeds); absent: `seeds` unchanged
void readSeeds(JsonReader& r, const std::string& key, std::array<std::uint64_t, 3>& seeds);

// "keyframes": [{"time": t, "center": [x, y, z]}, ...] with increasing times >= 0
// appended to times/centers (absent: nothing)
void readKeyframes(JsonReader& r, std::vector<double>& times, std::vector<Vec3d>& centers);

// a point over time (a stimulus's centre, a moving goal): piecewise linear between keys, held outside
struct Keyed3 {
  std::vector<double> times;
  std::vector<Vec3d> values;
  Vec3d at(double t) const;
};
// "center": [x, y, z] (static) or "keyframes" (readKeyframes), one of the two; `what` names the object in errors
Keyed3 readPath(JsonReader& r, const char* what);

// piecewise linear in time between keys, held before the first and after the last
// (times increasing, values non-empty and of the same size)
template <typename T>
T interpolateKeys(const std::vector<double>& times, const std::vector<T>& values, double t) {
  if (times.size() <= 1 || t <= times.front()) return values.front();
  if (t >= times.back()) return values.back();
  const auto it = std::upper_bound(times.begin(), times.end(), t);
  const std::size_t b = static_cast<std::size_t>(it - times.begin()), a = b - 1;
  const double f = (t - times[a]) / (times[b] - times[a]);
  return values[a] + f * (values[b] - values[a]);
}

// Perlin noise is evaluated at frequency * x (in lattice cells) and turns the lattice cell into an
// integer. Refuses the value of `key` when frequency = value * perMetre (lattice cells per metre) takes
// some point of the domain beyond kMaxNoiseLattice cells from the origin, where a double no longer
// resolves the position inside a cell and the conversion could overflow.
constexpr double kMaxNoiseLattice = 1e15;
void checkNoiseFrequency(JsonReader& r, const std::string& key, const Aabb& domain, double value, double perMetre);

// cells per axis covering `domain` with edges of about `edge` (each axis in [4, 256]),
// the edge widened in steps of 5 % until there are at most maxCells
std::array<int, 3> cellsForEdge(const Aabb& domain, double edge, double maxCells);

}  // namespace swarmsim
