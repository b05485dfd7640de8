#pragma once
// `swarmsim validate SCENARIO --set X` for each case: exit 2 with the expected text in the error (the JSON path
// and what was expected), and `swarmsim bench SCENARIO --agents 100` refused with `benchMessage`.
#include <catch2/catch.hpp>
#include <string>
#include <vector>

#include "test_util.hpp"

namespace swarmsim_test {

struct Refusal {
  std::string set, message;  // a --set argument (shell-quoted), text the error must contain
};

inline void checkRefusals(const std::string& scenario, const std::vector<Refusal>& cases, const std::string& benchMessage,
                          const fs::path& dir) {
  for (const auto& c : cases) {
    const auto v = runSwarmsim("validate " + shellQuote(scenario) + " --set " + c.set, dir);
    INFO(c.set << "\nstderr: " << v.err);
    CHECK(v.exitCode == 2);
    CHECK_THAT(v.err, Catch::Matchers::Contains(c.message));
  }
  const auto b = runSwarmsim("bench " + shellQuote(scenario) + " --agents 100 --frames 1 --repeat 1", dir);
  CHECK(b.exitCode == 2);
  CHECK_THAT(b.err, Catch::Matchers::Contains(benchMessage));
}

}  // namespace swarmsim_test
