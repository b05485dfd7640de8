#pragma once
// Reading trajectory files written by TrajectoryWriter (for `swarmsim info`,
// tests and tools).
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace swarmsim {

struct SwarmInfo {
  std::string name;
  std::string model;
  std::int64_t agents = 0;
  std::int64_t frames = 0;  // frames stored for this swarm
  std::vector<std::string> quantities;
};

struct TrajectoryInfo {
  std::string path;
  std::string format;
  std::int64_t formatVersion = 0;
  std::string swarmsimVersion;
  std::string scenarioName;
  std::string scenarioJson;
  std::uint64_t seed = 0;
  double dt = 0.0;
  double frameDt = 0.0;
  std::int64_t stepsPerFrame = 0;
  std::int64_t frames = 0;
  bool complete = false;
  bool interrupted = false;
  std::vector<SwarmInfo> swarms;

  nlohmann::json toJson() const;
};

// throws InputError when the file cannot be opened or is not a swarmsim trajectory
TrajectoryInfo readTrajectoryInfo(const std::string& path);

// a whole float dataset (e.g. "swarms/midges/position"), row-major, with its shape
std::vector<float> readFloatDataset(const std::string& path, const std::string& dataset,
                                    std::vector<std::uint64_t>* shape = nullptr);
std::vector<double> readDoubleDataset(const std::string& path, const std::string& dataset);

}  // namespace swarmsim
