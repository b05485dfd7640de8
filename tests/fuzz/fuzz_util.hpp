#pragma once
// Shared by the libFuzzer targets: what counts as a finding.
//
// A swarmsim::Error (InputError, OutputError) is the expected answer to bad
// input. Anything else is a finding: a crash or sanitizer report (libFuzzer
// stops by itself), any other exception (std::bad_alloc, nlohmann::json's,
// std::filesystem's, ...) and a broken invariant of a successful parse
// (finding() prints it and aborts, so libFuzzer saves the input).
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <typeinfo>

#include "core/error.hpp"

namespace swarmsim_fuzz {

[[noreturn]] inline void finding(const std::string& what) {
  std::fprintf(stderr, "\n==swarmsim-fuzz== FINDING: %s\n", what.c_str());
  std::fflush(stderr);
  std::abort();
}

// Run body; swallow swarmsim::Error, turn any other exception into a finding.
template <class Body>
void expectOnlySwarmsimErrors(Body&& body) {
  try {
    body();
  } catch (const swarmsim::Error&) {
    // expected: bad input, reported with a message
  } catch (const std::exception& e) {
    finding(std::string("unexpected exception ") + typeid(e).name() + ": " + e.what());
  } catch (...) {
    finding("unexpected exception of a non-std type");
  }
}

}  // namespace swarmsim_fuzz
