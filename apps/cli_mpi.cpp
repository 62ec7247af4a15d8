// hdt-voxelize across MPI ranks (cli_mpi.hpp). MPI stays in this file.
#include "cli_mpi.hpp"

#include "hdt/error.hpp"

#include <cstdlib>

#if defined(HDT_WITH_MPI)
#include "hdt/host_memory.hpp"
#include "hdt/range_exchange.hpp"

#include <mpi.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <memory>
#include <vector>
#endif

namespace hdt::cli {

#if !defined(HDT_WITH_MPI)

MpiSession::MpiSession(int&, char**&) {}
MpiSession::~MpiSession() = default;
void MpiSession::abort(int code) const { std::exit(code); }
Volume buildAcrossRanks(const MpiSession&, const PreparedMesh& mesh, const BuildOptions& options) {
  return build(mesh, options);
}

#else

namespace {

using Clock = std::chrono::steady_clock;
constexpr int kGatherTag = 914101;
constexpr size_t kPiece = size_t(1) << 30; // MPI counts are int

// Every rank's bytes, in rank order (small buffers: boundaries).
std::vector<std::vector<uint8_t>> allGather(const std::vector<uint8_t>& mine, int size) {
  const long long n = (long long)mine.size();
  std::vector<long long> lengths(static_cast<size_t>(size));
  MPI_Allgather(&n, 1, MPI_LONG_LONG, lengths.data(), 1, MPI_LONG_LONG, MPI_COMM_WORLD);
  std::vector<int> counts(static_cast<size_t>(size)), offsets(static_cast<size_t>(size) + 1, 0);
  for (int r = 0; r < size; ++r) {
    if (lengths[size_t(r)] > (1ll << 30)) throw Error(ErrorKind::OutOfResources, "a rank's boundary parities exceed 1 GiB");
    counts[size_t(r)] = int(lengths[size_t(r)]);
    offsets[size_t(r) + 1] = offsets[size_t(r)] + counts[size_t(r)];
  }
  std::vector<uint8_t> all(size_t(std::max(1, offsets.back())));
  MPI_Allgatherv(mine.data(), int(n), MPI_BYTE, all.data(), counts.data(), offsets.data(), MPI_BYTE, MPI_COMM_WORLD);
  std::vector<std::vector<uint8_t>> out(static_cast<size_t>(size));
  for (int r = 0; r < size; ++r)
    out[size_t(r)].assign(all.begin() + offsets[size_t(r)], all.begin() + offsets[size_t(r) + 1]);
  return out;
}

void sendBytes(const std::vector<uint8_t>& bytes, int to) {
  unsigned long long n = bytes.size();
  MPI_Send(&n, 1, MPI_UNSIGNED_LONG_LONG, to, kGatherTag, MPI_COMM_WORLD);
  for (size_t at = 0; at < n; at += kPiece)
    MPI_Send(bytes.data() + at, int(std::min(kPiece, size_t(n) - at)), MPI_BYTE, to, kGatherTag, MPI_COMM_WORLD);
}

std::vector<uint8_t> receiveBytes(int from) {
  unsigned long long n = 0;
  MPI_Recv(&n, 1, MPI_UNSIGNED_LONG_LONG, from, kGatherTag, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
  std::vector<uint8_t> bytes(n);
  for (size_t at = 0; at < n; at += kPiece)
    MPI_Recv(bytes.data() + at, int(std::min(kPiece, size_t(n) - at)), MPI_BYTE, from, kGatherTag, MPI_COMM_WORLD,
             MPI_STATUS_IGNORE);
  return bytes;
}

int localRank() {
  MPI_Comm node;
  MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, 0, MPI_INFO_NULL, &node);
  int rank = 0;
  MPI_Comm_rank(node, &rank);
  MPI_Comm_free(&node);
  return rank;
}

double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

} // namespace

MpiSession::MpiSession(int& argc, char**& argv) {
  int provided = 0;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
  initialized_ = true;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
}

MpiSession::~MpiSession() {
  if (initialized_) MPI_Finalize();
}

void MpiSession::abort(int code) const {
  if (size_ > 1) MPI_Abort(MPI_COMM_WORLD, code);
  std::exit(code);
}

Volume buildAcrossRanks(const MpiSession& session, const PreparedMesh& mesh, const BuildOptions& options) {
  requireDistributable(mesh);
  // One rank: nothing to exchange, and the CUDA driver's one-piece path
  // (classification on the device) beats its range build.
  if (session.size() == 1) return build(mesh, options);
  const auto t0 = Clock::now();
  const GridSpec& g = mesh.grid;
  const int K = session.size(), me = session.rank();
  const uint64_t R = uint64_t(g.rootGrid);
  const std::vector<RootRange> ranges = planRootRanges(cellLoads(mesh), R * R * R, K, R);
  // Each rank on its own driver: the GPU of its local rank modulo the node's
  // devices, or (Auto, no usable device or the CUDA driver failed) the CPU.
  BuildOptions rankOptions = options;
  const int local = localRank(); // collective: on every rank
  if (options.backend != Backend::Cpu) rankOptions.device = local % std::max(1, cudaDeviceCount());
  tbb::task_arena arena(options.threads > 0 ? options.threads : tbb::task_arena::automatic);
  std::unique_ptr<RootRangeBuild> build;
  const int rw = rowWordsFor(g.leafSize);
  RangeBoundary boundary;
  arena.execute([&] {
    build = makeRangeBuild(mesh, rankOptions, ranges[size_t(me)]);
    boundary = build->buildTree();
  });
  std::vector<RangeBoundary> boundaries;
  for (const std::vector<uint8_t>& b : allGather(packBoundary(boundary, rw), K))
    boundaries.push_back(unpackBoundary(b.data(), b.size(), rw));
  const std::vector<RangeBoundary> beyond = parityBeyondRanges(boundaries, classifiedAxes(mesh.closed), rw);
  RangeTree own;
  arena.execute([&] { own = build->finish(&beyond[size_t(me)]); });
  const PhaseTimes times = build->times();
  const int device = build->device();
  build.reset(); // the device's memory goes back now
  // What ran on each rank: "cpu", "cuda" or both.
  int gpuRanks = 0;
  const int onGpu = device >= 0 ? 1 : 0;
  MPI_Allreduce(&onGpu, &gpuRanks, 1, MPI_INT, MPI_SUM, MPI_COMM_WORLD);
  const std::string backend = gpuRanks == 0 ? "cpu" : gpuRanks == K ? "cuda" : "cuda+cpu";
  // The slowest rank's phases.
  const double mine[4] = {times.mapping, times.branching, times.leaf, times.classify};
  double slowest[4] = {0, 0, 0, 0};
  MPI_Reduce(mine, slowest, 4, MPI_DOUBLE, MPI_MAX, 0, MPI_COMM_WORLD);
  const unsigned long long peak = peakResidentBytes();
  unsigned long long largestPeak = 0; // the largest rank's, before rank 0 joins
  MPI_Reduce(&peak, &largestPeak, 1, MPI_UNSIGNED_LONG_LONG, MPI_MAX, 0, MPI_COMM_WORLD);
  if (me != 0) {
    sendBytes(packRangeTree(own), 0);
    Volume grid;
    grid.grid = g;
    return grid;
  }
  std::vector<RangeTree> trees(static_cast<size_t>(K));
  trees[0] = std::move(own);
  for (int r = 1; r < K; ++r) {
    const std::vector<uint8_t> bytes = receiveBytes(r);
    trees[size_t(r)] = unpackRangeTree(bytes.data(), bytes.size(), g);
  }
  Volume v = joinRanges(g, std::move(trees));
  v.surfaceOnly = mesh.surfaceOnly;
  v.closedMesh = mesh.closed;
  computeStructureStatistics(v);
  v.stats.triangles = mesh.triangles.size();
  v.stats.degenerateTriangles = mesh.degenerateTriangles;
  v.stats.time = PhaseTimes{slowest[0], slowest[1], slowest[2], slowest[3], msSince(t0)};
  v.stats.backend = backend;
  v.stats.peakHostBytes = std::max<uint64_t>(largestPeak, peakResidentBytes());
  v.stats.threads = options.threads > 0 ? options.threads : tbb::this_task_arena::max_concurrency();
  return v;
}

#endif

} // namespace hdt::cli
