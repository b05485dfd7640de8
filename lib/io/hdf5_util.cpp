#include "io/hdf5_util.hpp"

#include <stdexcept>
#include <vector>

namespace swarmsim::h5 {

namespace {
void check(herr_t status, const char* what, const char* name) {
  if (status < 0) throw std::runtime_error(std::string("HDF5: cannot ") + what + " attribute '" + name + "'");
}

void writeScalar(hid_t obj, const char* name, hid_t fileType, hid_t memType, const void* value) {
  if (H5Aexists(obj, name) > 0) H5Adelete(obj, name);
  H5Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  H5Handle attr(H5Acreate2(obj, name, fileType, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!attr.valid()) check(-1, "create", name);
  check(H5Awrite(attr, memType, value), "write", name);
}
}  // namespace

void quietErrors() { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); }

void writeAttr(hid_t obj, const char* name, const std::string& value) {
  H5Handle type(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(type, H5T_VARIABLE);
  H5Tset_cset(type, H5T_CSET_UTF8);
  const char* ptr = value.c_str();
  writeScalar(obj, name, type, type, &ptr);
}
void writeAttr(hid_t obj, const char* name, std::int64_t value) {
  writeScalar(obj, name, H5T_STD_I64LE, H5T_NATIVE_INT64, &value);
}
void writeAttr(hid_t obj, const char* name, std::uint64_t value) {
  writeScalar(obj, name, H5T_STD_U64LE, H5T_NATIVE_UINT64, &value);
}
void writeAttr(hid_t obj, const char* name, double value) {
  writeScalar(obj, name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, &value);
}

void updateAttr(hid_t obj, const char* name, std::int64_t value) {
  H5Handle attr(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose);
  if (!attr.valid()) check(-1, "open", name);
  check(H5Awrite(attr, H5T_NATIVE_INT64, &value), "write", name);
}

bool hasAttr(hid_t obj, const char* name) { return H5Aexists(obj, name) > 0; }

std::string readStringAttr(hid_t obj, const char* name) {
  H5Handle attr(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose);
  if (!attr.valid()) check(-1, "open", name);
  H5Handle ftype(H5Aget_type(attr), H5Tclose);
  if (H5Tget_class(ftype) != H5T_STRING) throw std::runtime_error(std::string("attribute '") + name + "' is not a string");
  if (H5Tis_variable_str(ftype) > 0) {
    H5Handle mtype(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_size(mtype, H5T_VARIABLE);
    H5Tset_cset(mtype, H5Tget_cset(ftype));
    char* ptr = nullptr;
    check(H5Aread(attr, mtype, &ptr), "read", name);
    std::string out = ptr ? ptr : "";
    H5free_memory(ptr);
    return out;
  }
  const std::size_t size = H5Tget_size(ftype);
  std::vector<char> buf(size + 1, '\0');
  H5Handle mtype(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(mtype, size + 1);
  check(H5Aread(attr, mtype, buf.data()), "read", name);
  return std::string(buf.data());
}

namespace {
template <typename T>
T readScalarAttr(hid_t obj, const char* name, hid_t memType) {
  T v{};
  H5Handle attr(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose);
  if (!attr.valid()) check(-1, "open", name);
  check(H5Aread(attr, memType, &v), "read", name);
  return v;
}
}  // namespace

double readDoubleAttr(hid_t obj, const char* name) { return readScalarAttr<double>(obj, name, H5T_NATIVE_DOUBLE); }
std::int64_t readIntAttr(hid_t obj, const char* name) {
  return readScalarAttr<std::int64_t>(obj, name, H5T_NATIVE_INT64);
}
std::uint64_t readUIntAttr(hid_t obj, const char* name) {
  return readScalarAttr<std::uint64_t>(obj, name, H5T_NATIVE_UINT64);
}

std::string fileFormat(const std::string& path) {
  quietErrors();
  if (H5Fis_hdf5(path.c_str()) <= 0) return "";
  H5Handle f(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!f.valid() || !hasAttr(f, "format")) return "";
  try {
    return readStringAttr(f, "format");
  } catch (const std::exception&) {
    return "";
  }
}

}  // namespace swarmsim::h5
