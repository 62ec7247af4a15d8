// The voxelizer, reader and writer across ParaView's MPI ranks (pvbatch,
// pvserver), through VTK's multi-process controller.
//
// ParaView's convention for a distributed vtkHyperTreeGrid: every rank holds
// the whole root grid and only its own trees. A build over K ranks:
//   1. every rank gathers all ranks' triangles (the mesh is small next to the
//      volume) and prepares them identically, so placement and the T1 loads
//      are the same everywhere;
//   2. the root grid is planned into K ranges of whole rows along x, balanced
//      by T1 pairs (hdt::planRootRanges, align R): +x rays never leave a rank;
//   3. each rank builds its range (hdt::makeRangeBuild: the CPU or the CUDA
//      driver), the ranks exchange the per-line boundary parities
//      (AllGatherV), each finishes its range;
//   4. neighbouring ranks send each other the trees of the root cells next to
//      their range (the halo: R^2 cells each side), so the voxel surface of a
//      rank's cells sees its true neighbours.
// Under the winding number (hdt::applyInsideTest) the ranks build their
// ranges' surfaces only; rank 0 gathers the trees, classifies the joined
// volume (the serial build's last step: the same bytes) and sends each rank
// its range's classified trees back before step 4.
// Each rank keeps a "piece volume": the whole root grid with its own trees and
// the halo's, other cells Empty. Only its own trees go to the hyper tree grid
// (vtkHDTConversionOptions::FirstTree/EndTree) and only its own cells' faces to
// the voxel surface. The statistics are summed over ranks (equal on all of
// them); field arrays RankRootRanges (K x 2: each rank's root cells),
// RankTimes (K x 5: mapping, branching, leaf, classify, total ms) and
// RankDevices (K: each rank's CUDA device, -1 for the CPU) describe the split. The writer gathers the ranks' trees into one volume on rank 0.
//
// With a GPU (Backend CUDA, or Auto with a usable device) a rank builds its
// range only on device (local rank mod device count); Auto falls back to the
// CPU per rank where there is no usable device or the CUDA driver fails, and
// RankDevices says what ran where (Backend: "cpu", "cuda" or "cuda+cpu").
//
// Internal to HDT::Filters and HDT::Readers (MPI stays out of the core).
#pragma once

#include "HDTFiltersModule.h" // export macro

#include "hdt/builder.hpp"
#include "hdt/root_ranges.hpp"

#include <memory>
#include <string>
#include <vector>

class vtkFieldData;
class vtkMultiProcessController;
namespace hdt
{
struct PreparedMesh;
struct TriangleMesh;
struct Volume;
}

struct vtkHDTDistributedPiece
{
  std::shared_ptr<const hdt::Volume> Volume; // piece volume (own trees + halo), reduced statistics
  std::vector<hdt::RootRange> Ranges;        // every rank's root cells
  hdt::RootRange Cells;                      // this rank's
  std::vector<hdt::PhaseTimes> RankTimes;    // every rank's build times
  std::string Backend;                       // what ran on the ranks ("cpu", "cuda", "cuda+cpu")
  int Device = -1;                           // this rank's CUDA device, -1 for the CPU
  std::vector<int> RankDevices;              // every rank's
};

class HDTFILTERS_EXPORT vtkHDTDistributed
{
public:
  // The global controller when the process runs with more than one rank,
  // else null (the serial path is taken).
  static vtkMultiProcessController* Controller();

  // All ranks' triangles, in rank order (collective).
  static void GatherMesh(vtkMultiProcessController* c, hdt::TriangleMesh& mesh);

  // True on every rank when `value` is true on any (collective).
  static bool Any(vtkMultiProcessController* c, bool value);

  // The build across the ranks (collective). Every rank throws when any
  // fails (the failed rank its own error, the others one that says so).
  static vtkHDTDistributedPiece Build(
    vtkMultiProcessController* c, const hdt::PreparedMesh& mesh, const hdt::BuildOptions& options);

  // A piece volume of a whole volume for this rank, without communication
  // (the reader: every rank holds the file's volume). Ranges of whole rows.
  static vtkHDTDistributedPiece Share(
    vtkMultiProcessController* c, std::shared_ptr<const hdt::Volume> whole);

  // Adds RankRootRanges and RankTimes to `fd`.
  static void AddFieldData(const vtkHDTDistributedPiece& piece, vtkFieldData* fd);

  // The ranks' root cells from a grid's field data; empty when it has none
  // (a serial grid) or they do not match `ranks`.
  static std::vector<hdt::RootRange> RangesOf(vtkFieldData* fd, int ranks);

  // The whole volume on rank `root` from every rank's piece (collective; other
  // ranks get null). `pieceVolume` holds the rank's range `cells`.
  static std::shared_ptr<hdt::Volume> Gather(vtkMultiProcessController* c,
    const hdt::Volume& pieceVolume, const std::vector<hdt::RootRange>& ranges, int root);

  // The rank's index among the ranks on its node (the ranks with its host
  // name, as MPI_Comm_split_type shared would group them; collective).
  static int LocalRank(vtkMultiProcessController* c);
};
