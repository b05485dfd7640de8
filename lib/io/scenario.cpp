#include "io/scenario.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <optional>
#include <set>
#include <sstream>

#include "core/error.hpp"
#include "eval/tracks.hpp"
#include "geometry/mesh.hpp"
#include "geometry/obstacles.hpp"
#include "models/params_util.hpp"

namespace swarmsim {

namespace fs = std::filesystem;

namespace {

constexpr std::int64_t kMaxAgents = 200'000'000;

std::string formatLimit(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// a ball (spawn region, sphere obstacle) must lie within the coordinate limit
void checkBallInLimits(const JsonReader& r, const Vec3d& center, double radius) {
  const double reach = center.cwiseAbs().maxCoeff() + radius;
  if (!(reach <= kMaxCoordinate)) {
    r.fail("radius", "expected the ball within the coordinate limit (|x|, |y|, |z| <= " + formatLimit(kMaxCoordinate) +
                         " m), got centre coordinate " + formatLimit(center.cwiseAbs().maxCoeff()) + " + radius " +
                         formatLimit(radius));
  }
}

// the individuals present at sample `s.sample` of s.file, with their velocities (recorded, else forward
// differences to the next sample, else zero)
void readTrackSpawn(JsonReader& r, SpawnRegion& s) {
  eval::SourceOptions opt;
  std::unique_ptr<eval::TrackSource> src;
  try {
    src = eval::openTracks(s.file, opt);
  } catch (const InputError& e) {
    r.fail("file", e.what());
  }
  const eval::TrackInfo& info = src->info();
  const std::int64_t k = info.first + s.sample;
  if (k >= info.last) {
    r.fail("sample", "expected a sample of the file's " + std::to_string(info.last - info.first) + " (0 to " +
                         std::to_string(info.last - info.first - 1) + ")");
  }
  eval::Frame f, next;
  src->read(k, f);
  if (f.size() == 0) r.fail("sample", "no individual is present at sample " + std::to_string(s.sample) + " of " + s.file);
  const bool differences = !info.hasVelocity && k + 1 < info.last;
  if (differences) src->read(k + 1, next);
  auto pos = std::make_shared<std::vector<float>>(), vel = std::make_shared<std::vector<float>>();
  for (std::size_t i = 0; i < f.size(); ++i) {
    std::ptrdiff_t j = differences ? next.find(f.id[i]) : -1;
    for (int a = 0; a < 3; ++a) {
      const double p = f.pos[3 * i + static_cast<std::size_t>(a)];
      if (!(std::fabs(p) <= kMaxCoordinate)) r.fail("file", s.file + ": a position beyond the coordinate limit");
      pos->push_back(static_cast<float>(p));
      double v = 0.0;
      if (info.hasVelocity) {
        v = f.vel[3 * i + static_cast<std::size_t>(a)];
      } else if (j >= 0) {
        v = (next.pos[3 * static_cast<std::size_t>(j) + static_cast<std::size_t>(a)] - p) / info.dt;
      }
      vel->push_back(static_cast<float>(v));
    }
  }
  s.positions = pos;
  s.velocities = vel;
}

SpawnRegion readSpawn(JsonReader r) {
  SpawnRegion s;
  const std::string type = r.choice("type", "box", {"box", "sphere", "tracks"});
  if (type == "tracks") {
    s.kind = SpawnRegion::Kind::kTracks;
    s.file = r.requireInputPath("file");
    s.sample = r.integer("sample", 0, 0, std::int64_t{1} << 40);
    readTrackSpawn(r, s);
  } else if (type == "box") {
    s.kind = SpawnRegion::Kind::kBox;
    s.min = r.requireVec3("min", Range::coordinate());
    s.max = r.requireVec3("max", Range::coordinate());
    for (int a = 0; a < 3; ++a) {
      if (!(s.max[a] >= s.min[a])) r.fail("max", "expected max >= min on every axis, got " +
                                                    std::to_string(s.max[a]) + " < " + std::to_string(s.min[a]) +
                                                    " on axis " + "xyz"[a]);
    }
  } else {
    s.kind = SpawnRegion::Kind::kSphere;
    s.center = r.requireVec3("center", Range::coordinate());
    s.radius = r.requireNumber("radius", Range::nonNegative().limited(0.0, kMaxLength));
    checkBallInLimits(r, s.center, s.radius);
  }
  r.finish();
  return s;
}

// obstacles: OBJ meshes (placed by translate, rotate, scale), spheres and boxes
std::shared_ptr<const Obstacles> readObstacles(JsonReader& r, const std::string& file, std::vector<std::string>& warnings) {
  auto obs = std::make_shared<Obstacles>();
  for (JsonReader& o : r.objectArray("obstacles", false, 0)) {
    const std::string type = o.choice("type", "", {"mesh", "sphere", "box"});
    if (type.empty()) o.failMissing("type", "one of \"mesh\", \"sphere\", \"box\"");
    if (type == "mesh") {
      TriangleMesh mesh = readPlacedMesh(o, file);
      if (!isWatertight(mesh)) {
        warnings.push_back(mesh.source +
                           ": mesh is not watertight; inside and outside are decided by majority voting (docs/models/field.md)");
      }
      obs->meshes.push_back(std::move(mesh));
    } else if (type == "sphere") {
      SphereObstacle sp;
      sp.center = o.requireVec3("center", Range::coordinate());
      sp.radius = o.requireNumber("radius", Range::length());
      checkBallInLimits(o, sp.center, sp.radius);
      obs->spheres.push_back(sp);
    } else {
      BoxObstacle b;
      b.min = o.requireVec3("min", Range::coordinate());
      b.max = o.requireVec3("max", Range::coordinate());
      for (int a = 0; a < 3; ++a) {
        if (!(b.max[a] > b.min[a])) o.fail("max", std::string("expected max > min on every axis (axis ") + "xyz"[a] + ")");
      }
      obs->boxes.push_back(b);
    }
    o.finish();
  }
  return obs;
}

// the parts of a --set path: keys and indices
struct PathPart {
  std::string key;
  long index = -1;     // clamped to kMaxIndex
  std::string number;  // the index as written
};
constexpr long kMaxIndex = 1L << 40;

std::vector<PathPart> splitPath(const std::string& path) {
  std::vector<PathPart> parts;
  std::size_t i = 0;
  const auto bad = [&](const std::string& why) {
    throw InputError("--set " + path + ": " + why + " (expected a path like swarms[0].params.speed)");
  };
  while (i < path.size()) {
    if (path[i] == '[') {
      const auto close = path.find(']', i);
      if (close == std::string::npos) bad("missing ']'");
      const std::string num = path.substr(i + 1, close - i - 1);
      if (num.empty() || num.find_first_not_of("0123456789") != std::string::npos) bad("index is not a number");
      // no array holds more than kMaxIndex elements: a longer index is out of range whatever its value
      const std::string digits = num.substr(std::min(num.find_first_not_of('0'), num.size() - 1));
      const long index = digits.size() > 10 ? kMaxIndex : std::min<long>(std::stol(digits), kMaxIndex);
      parts.push_back({"", index, num});
      i = close + 1;
      if (i < path.size() && path[i] == '.') ++i;
    } else {
      const auto end = path.find_first_of(".[", i);
      const std::string key = path.substr(i, end == std::string::npos ? std::string::npos : end - i);
      if (key.empty()) bad("empty key");
      parts.push_back({key, -1, ""});
      i = end == std::string::npos ? path.size() : end;
      if (i < path.size() && path[i] == '.') ++i;
    }
  }
  if (parts.empty()) bad("empty path");
  if (parts.size() > kMaxJsonDepth) {
    throw InputError("--set " + path.substr(0, 60) + "...: path of " + std::to_string(parts.size()) +
                     " keys and indices (expected at most " + std::to_string(kMaxJsonDepth) +
                     ", the nesting limit of scenario JSON)");
  }
  return parts;
}

}  // namespace

std::int64_t Scenario::agentCount() const {
  std::int64_t n = 0;
  for (const auto& s : swarms) n += s.count;
  return n;
}

void applyOverride(Json& scenario, const std::string& assignment) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0) {
    throw InputError("--set " + assignment + ": expected PATH=VALUE, e.g. swarms[0].count=5000");
  }
  const std::string path = assignment.substr(0, eq);
  const std::string text = assignment.substr(eq + 1);
  const std::vector<PathPart> parts = splitPath(path);
  // checked like a file: no duplicate keys, the whole scenario nested at most kMaxJsonDepth deep
  std::optional<Json> parsed = parseJsonValue(text, "--set " + path, path, parts.size());
  Json value = parsed ? std::move(*parsed) : Json(text);  // not JSON: a plain string
  Json* node = &scenario;
  for (const auto& part : parts) {
    if (part.index >= 0) {
      if (!node->is_array() || static_cast<std::size_t>(part.index) >= node->size()) {
        throw InputError("--set " + path + ": index [" + part.number + "] is out of range (" +
                         (node->is_array() ? std::to_string(node->size()) + " elements" : std::string("not an array")) +
                         ")");
      }
      node = &(*node)[static_cast<std::size_t>(part.index)];
    } else {
      if (node->is_null()) *node = Json::object();
      if (!node->is_object()) throw InputError("--set " + path + ": '" + part.key + "' is inside a non-object value");
      node = &(*node)[part.key];
    }
  }
  *node = value;
}

void rescaleAgents(Json& scenario, std::int64_t agents, const std::string& file) {
  if (!scenario.contains("swarms") || !scenario["swarms"].is_array() || scenario["swarms"].empty()) {
    throw InputError(file + ": swarms: expected an array of at least 1 object");
  }
  // the checked scenario gives the current total and the shapes
  const Scenario before = parseScenario(scenario, file);
  const double total = static_cast<double>(before.agentCount());
  const double ratio = static_cast<double>(agents) / total;
  const double linear = std::cbrt(ratio);
  std::int64_t assigned = 0;
  for (std::size_t i = 0; i < before.swarms.size(); ++i) {
    Json& sw = scenario["swarms"][i];
    std::int64_t count = i + 1 == before.swarms.size()
                             ? agents - assigned
                             : std::max<std::int64_t>(1, std::llround(static_cast<double>(before.swarms[i].count) * ratio));
    count = std::max<std::int64_t>(1, count);
    assigned += count;
    sw["count"] = count;
    const SpawnRegion& sp = before.swarms[i].spawn;
    if (sp.kind == SpawnRegion::Kind::kTracks) {
      throw InputError(file + ": swarms[" + std::to_string(i) + "].spawn: a tracks spawn has the file's individuals; " +
                       "--agents cannot rescale it");
    }
    if (sp.kind == SpawnRegion::Kind::kModel) {
      throw InputError(file + ": swarms[" + std::to_string(i) + "]: model \"" + before.swarms[i].model +
                       "\" places its agents itself; --agents cannot rescale it");
    }
    if (sp.kind == SpawnRegion::Kind::kBox) {
      const Vec3d c = 0.5 * (sp.min + sp.max), h = 0.5 * (sp.max - sp.min) * linear;
      const Vec3d lo = c - h, hi = c + h;
      sw["spawn"]["min"] = {lo.x(), lo.y(), lo.z()};
      sw["spawn"]["max"] = {hi.x(), hi.y(), hi.z()};
    } else {
      sw["spawn"]["radius"] = sp.radius * linear;
    }
  }
  const Vec3d c = before.domain.center(), h = 0.5 * before.domain.extent() * linear;
  scenario["domain"]["min"] = {c.x() - h.x(), c.y() - h.y(), c.z() - h.z()};
  scenario["domain"]["max"] = {c.x() + h.x(), c.y() + h.y(), c.z() + h.z()};
}

Scenario parseScenario(const Json& json, const std::string& file, std::shared_ptr<InputFiles> inputs) {
  if (!json.is_object()) throw InputError(file + ": expected a JSON object at the top level, got " + describeValue(json));
  Scenario sc;
  sc.file = file;
  sc.inputs = inputs ? std::move(inputs) : std::make_shared<InputFiles>();
  JsonReader r(json, file, "", &sc.resolved, sc.inputs);
  r.string("description", "");
  const std::string stem = file == kStdinName ? "stdin" : fs::path(file).stem().string();
  sc.name = r.string("name", stem.empty() ? "scenario" : stem);
  if (sc.name.empty() || sc.name.find('/') != std::string::npos) {
    r.failExpected("name", "a non-empty name without '/'", sc.name);
  }
  sc.seed = r.unsignedInteger("seed", 1);
  sc.dt = r.requireNumber("dt", Range::positive().limited(kMinDt, kMaxDt));
  sc.frames = r.requireInteger("frames", 1, 100'000'000);
  sc.stepsPerFrame = r.integer("steps_per_frame", 1, 1, 1'000'000);
  {
    JsonReader d = r.object("domain", true);
    sc.domain.min = d.requireVec3("min", Range::coordinate());
    sc.domain.max = d.requireVec3("max", Range::coordinate());
    for (int a = 0; a < 3; ++a) {
      if (!(sc.domain.max[a] > sc.domain.min[a])) {
        d.fail("max", std::string("expected max > min on every axis, got ") + std::to_string(sc.domain.max[a]) +
                          " <= " + std::to_string(sc.domain.min[a]) + " on axis " + "xyz"[a]);
      }
      // a positive length (docs/scenario.md#limits): the models divide by the extent and its cells
      if (!(sc.domain.max[a] - sc.domain.min[a] >= kMinLength)) {
        d.fail("max", "expected max - min >= " + formatLimit(kMinLength) + " m on every axis, got " +
                          formatLimit(sc.domain.max[a] - sc.domain.min[a]) + " on axis " + "xyz"[a]);
      }
    }
    d.finish();
  }
  sc.obstacles = readObstacles(r, file, sc.warnings);
  const World world = sc.world();
  std::set<std::string> names;
  std::vector<JsonReader> swarms = r.objectArray("swarms", true, 1);
  std::int64_t total = 0;
  std::vector<std::vector<std::string>> seesNames;  // per swarm, resolved once every swarm is known
  for (std::size_t i = 0; i < swarms.size(); ++i) {
    JsonReader& s = swarms[i];
    SwarmSpec spec;
    spec.name = s.string("name", "swarm" + std::to_string(i));
    if (spec.name.empty() || spec.name.find_first_of("/.") != std::string::npos) {
      s.failExpected("name", "a non-empty name without '/' or '.'", spec.name);
    }
    if (!names.insert(spec.name).second) s.failExpected("name", "a name no other swarm has", spec.name);
    spec.model = s.requireString("model");
    const ModelEntry* entry = findModel(spec.model);
    if (!entry) {
      std::string known;
      for (const auto& e : modelRegistry()) known += (known.empty() ? "\"" : ", \"") + std::string(e.name) + "\"";
      s.failExpected("model", "one of " + known, spec.model);
    }
    const bool spawned = !entry->placesAgents || s.has("spawn");
    if (spawned) {
      if (entry->placesAgents) {
        s.fail("spawn", "model \"" + spec.model + "\" places its agents itself; remove \"spawn\"");
      }
      spec.spawn = readSpawn(s.object("spawn", true));
    }
    if (!spawned) {
      spec.spawn.kind = SpawnRegion::Kind::kModel;  // counted after the model's parameters
    } else if (spec.spawn.kind == SpawnRegion::Kind::kTracks) {
      // as many agents as the tracks give
      const auto n = static_cast<std::int64_t>(spec.spawn.positions->size() / 3);
      spec.count = s.integer("count", n, 1, kMaxAgents);
      if (spec.count != n) {
        s.fail("count", "the tracks spawn gives " + std::to_string(n) + " individuals at sample " +
                            std::to_string(spec.spawn.sample) + "; leave count out or set it to " + std::to_string(n));
      }
    } else {
      spec.count = s.requireInteger("count", 1, kMaxAgents);
    }
    spec.initialSpeed = s.number("initial_speed", 0.0, Range::speed());
    JsonReader params = s.object("params", false);
    const double seconds = sc.dt * static_cast<double>(sc.stepsPerFrame) * static_cast<double>(sc.frames - 1);
    spec.config = entry->parse(params, ModelContext{world, file, spec.count, seconds, sc.warnings});
    params.finish();
    if (!spawned) {
      const std::int64_t placed = spec.config->placedAgents();
      spec.count = s.integer("count", placed, 1, kMaxAgents);
      if (spec.count != placed) {
        s.fail("count", "model \"" + spec.model + "\" places " + std::to_string(placed) +
                            " agents; leave count out or set it to " + std::to_string(placed));
      }
    }
    if (const Json* see = s.raw("sees")) {
      bool ok = see->is_array();
      for (std::size_t k = 0; ok && k < see->size(); ++k) ok = (*see)[k].is_string();
      if (!ok) s.failExpected("sees", "an array of swarm names", *see);
      if (!see->empty() && !entry->looksAtOthers) {
        std::string which;
        for (const auto& e : modelRegistry()) {
          if (e.looksAtOthers) which += (which.empty() ? "" : ", ") + std::string(e.name);
        }
        s.fail("sees", "model \"" + spec.model + "\" does not look at other swarms (models that do: " + which + ")");
      }
      seesNames.emplace_back();
      for (const Json& x : *see) seesNames.back().push_back(x.get<std::string>());
    } else {
      seesNames.emplace_back();
    }
    total += spec.count;
    if (total > kMaxAgents) s.fail("count", "the scenario has more than " + std::to_string(kMaxAgents) + " agents");
    s.finish();
    sc.swarms.push_back(std::move(spec));
  }
  // "sees": names of other swarms of this scenario, each at most once
  std::string all;  // every swarm's name, for the messages
  for (const auto& o : sc.swarms) all += (all.empty() ? "" : ", ") + o.name;
  for (std::size_t i = 0; i < sc.swarms.size(); ++i) {
    std::set<std::string> listed;
    for (std::size_t k = 0; k < seesNames[i].size(); ++k) {
      const std::string& want = seesNames[i][k];
      const std::string at = "sees[" + std::to_string(k) + "]";
      std::size_t j = 0;
      while (j < sc.swarms.size() && sc.swarms[j].name != want) ++j;
      if (j == sc.swarms.size()) swarms[i].failExpected(at, "the name of a swarm of this scenario (" + all + ")", want);
      if (j == i) swarms[i].failExpected(at, "another swarm's name (a model always sees its own swarm)", want);
      if (!listed.insert(want).second) swarms[i].failExpected(at, "a swarm not listed before", want);
      sc.swarms[i].sees.push_back(static_cast<std::uint32_t>(j));
    }
  }
  {
    JsonReader o = r.object("output", false);
    const std::string path = o.string("path", sc.name + ".h5");
    if (path.empty()) o.failExpected("path", "a non-empty file path", path);
    // relative paths in the file resolve against the scenario's folder; the
    // default (no path given) is in the working directory
    if (json.contains("output") && json["output"].contains("path") && fs::path(path).is_relative()) {
      sc.output.path = resolveInputPath(file, path);
    } else {
      sc.output.path = path;
    }
    // absolute, so the resolved scenario (also stored in the output) means the same from anywhere
    sc.output.path = fs::absolute(sc.output.path).lexically_normal().string();
    sc.resolved["output"]["path"] = sc.output.path;
    sc.output.quantities = o.stringList("quantities", {"position", "velocity"}, {"position", "velocity"});
    if (sc.output.quantities.empty()) o.failExpected("quantities", "at least one quantity", Json::array());
    sc.output.compression = static_cast<int>(o.integer("compression", 0, 0, 9));
    o.finish();
  }
  r.finish();
  return sc;
}

Scenario loadScenario(const std::string& file, const std::vector<std::string>& overrides) {
  Json json = readJsonFile(file);
  for (const auto& o : overrides) applyOverride(json, o);
  return parseScenario(json, file == "-" ? kStdinName : file);
}

}  // namespace swarmsim
