#pragma once
// `swarmsim export`: an output file in the formats other programs read
// (docs/tools.md#export):
//   xdmf  a sidecar .xmf that points into the .h5 (no data copied): ParaView opens it
//   ply   one binary PLY point cloud per swarm and frame (SWARM.FFFF.ply) and the obstacles (obstacles.ply)
//   csv   one row per present agent per frame, to a file or to standard output
// Frames are read and written one at a time: memory does not grow with the frames. Every file is written
// beside its path and renamed into place when complete (AtomicFile).
#include <cstdint>
#include <cstdio>
#include <string>

#include "eval/tracks.hpp"

namespace swarmsim {

struct ExportOptions {
  std::string input;         // a swarmsim output (.h5)
  std::string format;        // "xdmf", "ply", "csv"
  std::string output;        // xdmf/csv: the file ("-": standard output, csv only); ply: the folder. Empty: beside
                             // the input (IN.xmf, IN.csv, folder IN_ply)
  eval::FrameRange frames;   // frames A:B (half-open, python slice semantics)
  std::string swarm;         // only this swarm (empty: all)
  bool force = false;        // replace files an earlier export wrote
  bool relative = false;     // xdmf: name the .h5 relative to the .xmf's folder instead of by its absolute path
};

struct ExportResult {
  std::int64_t frames = 0;   // frames exported
  std::int64_t files = 0;    // files written
  std::int64_t rows = 0;     // agent rows (csv) or points (ply) written; xdmf: points referenced
  std::string where;         // the file or folder written ("-": standard output)
};

// throws InputError (exit 2) for a bad input or option, OutputError (exit 3) when a file cannot be written
// `standardOutput` receives the csv of output "-"
ExportResult runExport(const ExportOptions& options, std::FILE* standardOutput);

}  // namespace swarmsim
