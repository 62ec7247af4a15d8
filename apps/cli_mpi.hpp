// hdt-voxelize across MPI ranks (mpiexec -n K hdt-voxelize-mpi ...): the
// hdt-voxelize-mpi binary (HDT_WITH_MPI=ON); in hdt-voxelize a session has one rank.
//
// Every rank reads and prepares the mesh (identically), builds its range of
// root rows balanced by T1 pairs (hdt::planRootRanges, align R) with the CPU
// driver's range build, the ranks exchange their per-line boundary parities
// (MPI_Allgatherv), and rank 0 gathers the ranges' trees, joins them and
// writes the outputs: the same bytes as a serial run. With a GPU on every
// rank (backend cuda, or auto), each rank builds on device (local rank mod
// device count, MPI_Comm_split_type shared) with the CUDA driver's range
// build; Auto falls back to the CPU per rank.
// An error on any rank aborts the job (MPI_Abort) with that rank's message.
#pragma once

#include "cli_report.hpp"
#include "hdt/builder.hpp"

#include <vector>

namespace hdt::cli {

class MpiSession {
public:
  MpiSession(int& argc, char**& argv);
  ~MpiSession();
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;

  int rank() const { return rank_; }
  int size() const { return size_; }
  // Ends every rank with `code` after an error on this one (when several).
  [[noreturn]] void abort(int code) const;

private:
  int rank_ = 0, size_ = 1;
  bool initialized_ = false;
};

// The volume built across the session's ranks: whole on rank 0 (statistics:
// each phase's slowest rank, the largest peaks), only the grid on the others.
// Rank 0 receives each rank's leaf words straight into the joined volume.
// `ranks` (rank 0, when given): what each rank did and measured.
Volume buildAcrossRanks(const MpiSession& session, const PreparedMesh& mesh, const BuildOptions& options,
                        std::vector<RankReport>* ranks = nullptr);

} // namespace hdt::cli
