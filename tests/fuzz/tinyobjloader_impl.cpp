// tinyobjloader's implementation, compiled from the installed header into the
// fuzz targets (see CMakeLists.txt beside this file): instrumented for coverage
// and ASan, and linked ahead of the shared library. Same configuration as the
// library's (float reals).
#define TINYOBJLOADER_IMPLEMENTATION
#include <tiny_obj_loader.h>
