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
std::string readStringAttr(hid_t obj, const char* name);
double readDoubleAttr(hid_t obj, const char* name);
std::int64_t readIntAttr(hid_t obj, const char* name);
std::uint64_t readUIntAttr(hid_t obj, const char* name);

}  // namespace swarmsim::h5
