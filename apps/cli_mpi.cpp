// hdt-voxelize across MPI ranks (cli_mpi.hpp). MPI stays in this file.
#include "cli_mpi.hpp"

#include "hdt/error.hpp"

#include <cstdlib>

#if defined(HDT_WITH_MPI)
#include "hdt/host_memory.hpp"
#include "hdt/range_exchange.hpp"
#include "hdt/winding_tree.hpp"

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
Volume buildAcrossRanks(const MpiSession&, const PreparedMesh& mesh, const BuildOptions& options,
                        std::vector<RankReport>*) {
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

// Arrays of the gather, sent as they lie (no packing): the length, then
// pieces of at most kPiece bytes (MPI counts are int).
template <class T>
void sendArray(const T* data, uint64_t count, int to) {
  MPI_Send(&count, 1, MPI_UINT64_T, to, kGatherTag, MPI_COMM_WORLD);
  const auto* bytes = reinterpret_cast<const uint8_t*>(data);
  const uint64_t n = count * sizeof(T);
  for (uint64_t at = 0; at < n; at += kPiece)
    MPI_Send(bytes + at, int(std::min<uint64_t>(kPiece, n - at)), MPI_BYTE, to, kGatherTag, MPI_COMM_WORLD);
}

// The length sendArray sent first; refused past `limit` (a mismatched peer).
uint64_t receiveLength(uint64_t limit, int from) {
  uint64_t count = 0;
  MPI_Recv(&count, 1, MPI_UINT64_T, from, kGatherTag, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
  if (count > limit) throw Error(ErrorKind::BadInput, "rank " + std::to_string(from) + " sent more than its share");
  return count;
}

// The pieces of an array whose length was received.
template <class T>
void receiveInto(T* out, uint64_t count, int from) {
  auto* bytes = reinterpret_cast<uint8_t*>(out);
  const uint64_t n = count * sizeof(T);
  for (uint64_t at = 0; at < n; at += kPiece)
    MPI_Recv(bytes + at, int(std::min<uint64_t>(kPiece, n - at)), MPI_BYTE, from, kGatherTag, MPI_COMM_WORLD,
             MPI_STATUS_IGNORE);
}

// A rank's piece to rank 0: its tree's levels, then its leaf words.
void sendPiece(const RangeTree& piece) {
  const std::vector<uint8_t> levels = packRangeLevels(piece);
  sendArray(levels.data(), levels.size(), 0);
  sendArray(piece.leafWords.data(), piece.leafWords.size(), 0);
}

// Rank 0 receives a piece: the levels into the gather, the leaf words
// straight into their place in the joined volume's leaves.
void receivePiece(PlacedGather& gather, int from, const GridSpec& g) {
  // At most the tree's 2^30 elements (4 bytes each) and the buffer's headers.
  std::vector<uint8_t> levels(receiveLength((uint64_t(1) << 32) + 4096, from));
  receiveInto(levels.data(), levels.size(), from);
  gather.addLevels(size_t(from), unpackRangeLevels(levels.data(), levels.size(), g));
  const uint64_t words = gather.wordCountOf(size_t(from));
  if (receiveLength(words, from) != words)
    throw Error(ErrorKind::BadInput, "rank " + std::to_string(from) + " sent fewer leaf words than it announced");
  receiveInto(gather.wordsOf(size_t(from)), words, from);
}

// What a rank measured of its own part, gathered to rank 0 for the report.
struct RankFigures {
  PhaseTimes phases;
  double exchangeMs = 0, copyBackMs = 0, sendMs = 0;
  int device = -1;
  uint64_t leafGrids = 0, peakHostBytes = 0, peakDeviceBytes = 0;
};

// Collective: every rank's figures on rank 0 (in rank order), nothing elsewhere.
std::vector<RankReport> gatherFigures(const RankFigures& f, const std::vector<RootRange>* ranges, int size) {
  constexpr int kDoubles = 8, kWords = 4;
  const double d[kDoubles] = {f.phases.mapping, f.phases.branching, f.phases.leaf, f.phases.classify,
                              f.phases.total,   f.exchangeMs,       f.copyBackMs,  f.sendMs};
  const uint64_t w[kWords] = {uint64_t(int64_t(f.device)), f.leafGrids, f.peakHostBytes, f.peakDeviceBytes};
  std::vector<double> allD(ranges ? size_t(size) * kDoubles : 0);
  std::vector<uint64_t> allW(ranges ? size_t(size) * kWords : 0);
  MPI_Gather(d, kDoubles, MPI_DOUBLE, allD.data(), kDoubles, MPI_DOUBLE, 0, MPI_COMM_WORLD);
  MPI_Gather(w, kWords, MPI_UINT64_T, allW.data(), kWords, MPI_UINT64_T, 0, MPI_COMM_WORLD);
  std::vector<RankReport> out;
  if (!ranges) return out;
  for (int r = 0; r < size; ++r) {
    const double* x = allD.data() + size_t(r) * kDoubles;
    const uint64_t* y = allW.data() + size_t(r) * kWords;
    RankReport k;
    k.device = int(int64_t(y[0]));
    k.backend = k.device >= 0 ? "cuda" : "cpu";
    k.rootCells = (*ranges)[size_t(r)].end - (*ranges)[size_t(r)].first;
    k.leafGrids = y[1];
    k.phases = PhaseTimes{x[0], x[1], x[2], x[3], x[4]};
    k.exchangeMs = x[5];
    k.copyBackMs = x[6];
    k.sendMs = x[7];
    k.peakHostBytes = y[2];
    k.peakDeviceBytes = y[3];
    out.push_back(std::move(k));
  }
  return out;
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

Volume buildAcrossRanks(const MpiSession& session, const PreparedMesh& mesh, const BuildOptions& options,
                        std::vector<RankReport>* ranksOut) {
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
  const auto e0 = Clock::now();
  std::vector<RangeBoundary> boundaries;
  for (const std::vector<uint8_t>& b : allGather(packBoundary(boundary, rw), K))
    boundaries.push_back(unpackBoundary(b.data(), b.size(), rw));
  const std::vector<RangeBoundary> beyond = parityBeyondRanges(boundaries, classifiedAxes(mesh.closed), rw);
  const double exchangeMs = msSince(e0);
  RangeTree own;
  arena.execute([&] { own = build->finish(&beyond[size_t(me)]); });
  const PhaseTimes times = build->times();
  const int device = build->device();
  // What ran on each rank: "cpu", "cuda" or both.
  int gpuRanks = 0;
  const int onGpu = device >= 0 ? 1 : 0;
  MPI_Allreduce(&onGpu, &gpuRanks, 1, MPI_INT, MPI_SUM, MPI_COMM_WORLD);
  const std::string backend = gpuRanks == 0 ? "cpu" : gpuRanks == K ? "cuda" : "cuda+cpu";
  // Every rank's leaf words, so rank 0 can place each piece as it arrives.
  const uint64_t myWords = own.leafWords.size();
  std::vector<uint64_t> words(static_cast<size_t>(K));
  MPI_Gather(&myWords, 1, MPI_UINT64_T, words.data(), 1, MPI_UINT64_T, 0, MPI_COMM_WORLD);
  RankFigures figures;
  figures.phases = times;
  figures.exchangeMs = exchangeMs;
  figures.copyBackMs = build->copyBackMs();
  figures.device = device;
  figures.leafGrids = own.leafWords.size() / leafWordCount(g.leafSize);
  figures.peakHostBytes = peakResidentBytes();
  figures.peakDeviceBytes = build->peakDeviceBytes();
  build.reset(); // the device's memory goes back now
  if (me != 0) {
    const auto s0 = Clock::now();
    sendPiece(own);
    figures.sendMs = msSince(s0);
    gatherFigures(figures, nullptr, K);
    Volume grid;
    grid.grid = g;
    return grid;
  }
  const auto s0 = Clock::now();
  std::unique_ptr<PlacedGather> gather;
  arena.execute([&] {
    gather = std::make_unique<PlacedGather>(g, words);
    gather->addOwn(0, std::move(own));
  });
  for (int r = 1; r < K; ++r) receivePiece(*gather, r, g);
  Volume v = gather->join();
  gather.reset();
  figures.sendMs = msSince(s0);
  // Under the winding number the ranks built the surface only (their drivers
  // skip the parity passes) and the joined volume is classified here, the
  // serial build's last step on the same surface: the same bytes. On this
  // rank's GPU where its build ran on one, else on the host.
  const BuildOptions passOptions = insideTestOptionsAfterRangeBuild(rankOptions, device);
  double windingMs = 0;
  arena.execute([&] { windingMs = applyInsideTestAfterPhases(mesh, v, passOptions); });
  figures.phases.classify += windingMs;
  figures.phases.total += windingMs;
  figures.peakHostBytes = peakResidentBytes(); // rank 0 holds the joined volume now
  std::vector<RankReport> all = gatherFigures(figures, &ranges, K);
  v.surfaceOnly = mesh.surfaceOnly;
  v.closedMesh = mesh.closed;
  computeStructureStatistics(v);
  v.stats.triangles = mesh.triangles.size();
  v.stats.degenerateTriangles = mesh.degenerateTriangles;
  PhaseTimes slowest; // each phase's slowest rank
  uint64_t largestPeak = 0, largestDevice = 0;
  for (const RankReport& k : all) {
    slowest.mapping = std::max(slowest.mapping, k.phases.mapping);
    slowest.branching = std::max(slowest.branching, k.phases.branching);
    slowest.leaf = std::max(slowest.leaf, k.phases.leaf);
    slowest.classify = std::max(slowest.classify, k.phases.classify);
    largestPeak = std::max(largestPeak, k.peakHostBytes);
    largestDevice = std::max(largestDevice, k.peakDeviceBytes);
  }
  slowest.total = msSince(t0);
  v.stats.time = slowest;
  v.stats.backend = backend;
  v.stats.peakHostBytes = std::max<uint64_t>(largestPeak, peakResidentBytes());
  v.stats.peakDeviceBytes = largestDevice;
  v.stats.threads = options.threads > 0 ? options.threads : tbb::this_task_arena::max_concurrency();
  if (ranksOut) *ranksOut = std::move(all);
  return v;
}

#endif

} // namespace hdt::cli
