// What hdt-voxelize prints about a build: one JSON object, or an aligned table.
#pragma once

#include "hdt/labels.hpp"
#include "hdt/volume.hpp"

#include <ostream>
#include <string>
#include <vector>

namespace hdt::cli {

// Wall-clock time of the steps around the build, in milliseconds.
struct IoTimes {
  double read = 0;    // reading or generating the mesh
  double prepare = 0; // hdt::prepareMesh: validation, placement, snapping
  double write = 0;   // -o and --dense
  double transfer = 0; // --transfer: hdt::transferArrays
  // Where the rest of the process's time goes (--json only): the wait for the
  // device's set-up (hdt::prepareCuda, beside the read), the build call (copy
  // back included), the wait for the memory estimate (beside the build), and
  // all of it from the start of main() to the report.
  double deviceWait = 0, build = 0, estimateWait = 0, sinceStart = 0;
  // The wait for the leaf words' warm pages (reserved beside the device's
  // set-up) before the build, and for the device's release (beside the write)
  // after the write.
  double reserveWait = 0, releaseWait = 0;
  // Wall-clock times (ms since the Unix epoch) of main()'s start and of the
  // report: with a launcher's own clock, the time before main() and after it.
  double unixAtMain = 0, unixAtReport = 0;
};

// One rank of a distributed build (hdt-voxelize-mpi), as rank 0 gathers it.
struct RankReport {
  std::string backend;        // "cpu" or "cuda"
  int device = -1;            // the CUDA device, -1 for the CPU
  uint64_t rootCells = 0;     // the root cells of its range
  uint64_t leafGrids = 0;     // the leaf grids it built
  PhaseTimes phases;          // its own T1..classification (total: their sum)
  double exchangeMs = 0;      // waiting for and merging the boundary parities
  double copyBackMs = 0;      // the copies from its device to its host
  double sendMs = 0;          // its piece to rank 0 (rank 0: receiving and joining every piece)
  uint64_t peakHostBytes = 0; // its resident set's high-water mark
  uint64_t peakDeviceBytes = 0;
};

struct Report {
  std::string mesh;      // as given on the command line
  const Volume* volume = nullptr;
  IoTimes io;
  std::string hdtPath;   // empty when not written
  std::string densePath; // empty when not written
  uint64_t duplicateTriangles = 0;
  InsideTest requestedInsideTest = InsideTest::Auto; // --inside-test
  uint64_t hostBytesEstimate = 0;    // hdt::estimateHostBytes (CPU builds)
  std::vector<std::string> warnings; // hdt::buildWarnings
  bool labelled = false;             // --labels
  std::vector<LabelStatistics> labels; // hdt::labelStatistics
  uint64_t labelBytes = 0;           // hdt::labelFieldBytes
  std::string denseLabelsPath;       // empty when not written
  std::vector<RankReport> ranks;     // distributed builds: one a rank, in rank order
};

// Keys, in this order: mesh, triangles, resolution, root_grid, leaf_size,
// height, origin, voxel_size, tree_elements, leaf_grids, leaf_voxels,
// active_voxels, inside_voxels, paper_bits_per_active_voxel, topology_bytes,
// leaf_bytes, backend, threads, time_ms {mapping, branching, leaf, classify,
// total}, peak_host_bytes, then degenerate_triangles, closed_mesh,
// peak_device_bytes, surface_only, io_ms {read, prepare, write, transfer,
// device_wait, build, estimate_wait, since_start}, hdt_file,
// dense_file, duplicate_triangles, warnings [strings],
// host_bytes_estimate, inside_test ("parity" or "winding": the test that
// ran), inside_test_requested, inside_test_reason, winding_refined_elements,
// labels (null, or [{label, name, surface_voxels, inside_voxels, volume,
// surface_area}]), label_bytes, dense_labels_file, transferred_arrays
// ([{name, source ("point" or "cell"), components}]), transferred_array_bytes,
// ranks (null, or [{rank, backend, device, root_cells, leaf_grids, time_ms
// {mapping, branching, leaf, classify, total}, exchange_ms, copy_back_ms,
// send_ms, peak_host_bytes, peak_device_bytes}]), slowest_rank (null or the
// rank whose phases took longest).
// README.md says what
// each means.
void writeJson(std::ostream& out, const Report& report);

void writeTable(std::ostream& out, const Report& report);

} // namespace hdt::cli
