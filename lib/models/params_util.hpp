#pragma once
// Parameter readers shared by the models' parsers.
#include <array>
#include <cstdint>
#include <string>

#include "core/json_reader.hpp"

namespace swarmsim {

// three integers in [lo, hi] (grid cells per axis); absent: an error if required, else {0, 0, 0}
std::array<int, 3> readCells(JsonReader& r, const std::string& key, bool required, int lo, int hi);

// three integers >= 0 (Perlin seeds); absent: `seeds` unchanged
void readSeeds(JsonReader& r, const std::string& key, std::array<std::uint64_t, 3>& seeds);

}  // namespace swarmsim
