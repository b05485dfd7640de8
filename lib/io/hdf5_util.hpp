#pragma once
// Small helpers over the HDF5 C API shared by the trajectory writer and reader.
#include <cstdint>
#include <string>

#include "io/hdf5_handle.hpp"

namespace swarmsim::h5 {

// silence HDF5's own error printing (we report errors ourselves); idempotent
void quietErrors();

void writeAttr(hid_t obj, const char* name, const std::string& value);
void writeAttr(hid_t obj, const char* name, std::int64_t value);
void writeAttr(hid_t obj, const char* name, std::uint64_t value);
void writeAttr(hid_t obj, const char* name, double value);
// overwrite an existing 64-bit integer attribute in place (no new allocation in the file)
void updateAttr(hid_t obj, const char* name, std::int64_t value);

bool hasAttr(hid_t obj, const char* name);
// the root `format` attribute of the HDF5 file at `path` ("swarmsim-trajectory", "swarmsim-reference"),
// or "" when the file cannot be opened as HDF5 or has none; never throws
std::string fileFormat(const std::string& path);
std::string readStringAttr(hid_t obj, const char* name);
double readDoubleAttr(hid_t obj, const char* name);
std::int64_t readIntAttr(hid_t obj, const char* name);
std::uint64_t readUIntAttr(hid_t obj, const char* name);

}  // namespace swarmsim::h5
