#pragma once
// Errors that carry a process exit code. Messages name the file and the place
// (JSON path, OBJ line) and say what was expected.
#include <stdexcept>
#include <string>

namespace swarmsim {

// documented exit codes of the swarmsim command
enum ExitCode : int {
  kExitOk = 0,
  kExitOther = 1,
  kExitInvalidInput = 2,   // arguments, scenario, referenced files
  kExitOutput = 3,         // output cannot be written
  kExitInterrupted = 4,    // SIGINT/SIGTERM: partial but valid output
};

class Error : public std::runtime_error {
 public:
  Error(ExitCode code, const std::string& message) : std::runtime_error(message), code_(code) {}
  ExitCode code() const { return code_; }

 private:
  ExitCode code_;
};

// bad input: a scenario, an argument, a referenced file
class InputError : public Error {
 public:
  explicit InputError(const std::string& message) : Error(kExitInvalidInput, message) {}
};

// the output cannot be created or written
class OutputError : public Error {
 public:
  explicit OutputError(const std::string& message) : Error(kExitOutput, message) {}
};

}  // namespace swarmsim
