#include "core/input_files.hpp"

namespace swarmsim {

InputFiles::Bytes InputFiles::read(const std::string& path, const std::function<std::string()>& readFile) {
  const auto e = embedded_.find(path);
  Bytes bytes = e != embedded_.end() ? e->second : std::make_shared<const std::string>(readFile());
  used_[path] = bytes;
  return bytes;
}

void InputFiles::embed(const std::string& path, std::string bytes) {
  embedded_[path] = std::make_shared<const std::string>(std::move(bytes));
}

}  // namespace swarmsim
