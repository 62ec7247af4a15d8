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

// All ranks on their GPU, or none (they must agree on the protocol).
bool useCuda(const BuildOptions& options) {
  if (options.backend == Backend::Cpu) return false;
  std::string why;
  const int here = cudaAvailable(&why) ? 1 : 0;
  if (options.backend == Backend::Cuda && !here)
    throw Error(ErrorKind::InvalidArgument, "backend cuda: " + why);
  int all = 0;
  MPI_Allreduce(&here, &all, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
  if (!all && options.log) options.log("backend auto: using the CPU driver on every rank (not every rank has a usable GPU)");
  return all != 0;
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
  const auto t0 = Clock::now();
  const GridSpec& g = mesh.grid;
  const int K = session.size(), me = session.rank();
  const uint64_t R = uint64_t(g.rootGrid);
  const std::vector<RootRange> ranges = planRootRanges(cellLoads(mesh), R * R * R, K, R);
  RangeTree own;
  PhaseTimes times;
  std::string backend = "cpu";
  if (useCuda(options)) {
    BuildOptions cuda = options;
    cuda.backend = Backend::Cuda;
    cuda.device = localRank() % std::max(1, cudaDeviceCount());
    const Volume whole = buildCuda(mesh, cuda);
    own = sliceVolume(whole, ranges[size_t(me)]);
    times = whole.stats.time;
    backend = "cuda";
  } else {
    tbb::task_arena arena(options.threads > 0 ? options.threads : tbb::task_arena::automatic);
    CpuRangeBuild build(mesh, options, ranges[size_t(me)]);
    const int rw = rowWordsFor(g.leafSize);
    RangeBoundary boundary;
    arena.execute([&] { boundary = build.buildTree(); });
    std::vector<RangeBoundary> boundaries;
    for (const std::vector<uint8_t>& b : allGather(packBoundary(boundary, rw), K))
      boundaries.push_back(unpackBoundary(b.data(), b.size(), rw));
    const std::vector<RangeBoundary> beyond = parityBeyondRanges(boundaries, classifiedAxes(mesh.closed), rw);
    arena.execute([&] { own = build.finish(&beyond[size_t(me)]); });
    times = build.times();
  }
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
