// Builds, shares and gathers HDT volumes across ParaView's ranks
// (vtkHDTDistributedBuild.h).
#include "vtkHDTDistributedBuild.h"

#include "hdt/error.hpp"
#include "hdt/mesh.hpp"
#include "hdt/range_exchange.hpp"
#include "hdt/volume.hpp"
#include "hdt/winding_tree.hpp"

#include "vtkCommunicator.h"
#include "vtkDoubleArray.h"
#include "vtkFieldData.h"
#include "vtkIntArray.h"
#include "vtkMultiProcessController.h"
#include "vtkNew.h"
#include "vtkTypeUInt64Array.h"

#include <tbb/task_arena.h>

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <functional>
#include <memory>

namespace
{
using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0)
{
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

constexpr int kHaloTag = 914001;
constexpr int kGatherTag = 914002;
constexpr int kScatterTag = 914003;
// MPI counts are int: large buffers travel in pieces.
constexpr vtkIdType kPiece = vtkIdType(1) << 30;

void sendBytes(vtkMultiProcessController* c, const std::vector<uint8_t>& bytes, int to, int tag)
{
  unsigned long long n = bytes.size();
  c->Send(&n, 1, to, tag);
  for (vtkIdType at = 0; at < vtkIdType(n); at += kPiece)
  {
    c->Send(bytes.data() + at, std::min<vtkIdType>(kPiece, vtkIdType(n) - at), to, tag);
  }
}

std::vector<uint8_t> receiveBytes(vtkMultiProcessController* c, int from, int tag)
{
  unsigned long long n = 0;
  c->Receive(&n, 1, from, tag);
  std::vector<uint8_t> bytes(n);
  for (vtkIdType at = 0; at < vtkIdType(n); at += kPiece)
  {
    c->Receive(bytes.data() + at, std::min<vtkIdType>(kPiece, vtkIdType(n) - at), from, tag);
  }
  return bytes;
}

// Leaf words sent as they lie, in pieces (MPI counts are int); the receiver
// knows the count already.
constexpr vtkIdType kWordPiece = vtkIdType(1) << 28;

void sendWords(vtkMultiProcessController* c, const uint32_t* words, uint64_t count, int to, int tag)
{
  for (uint64_t at = 0; at < count; at += uint64_t(kWordPiece))
  {
    c->Send(words + at, vtkIdType(std::min<uint64_t>(uint64_t(kWordPiece), count - at)), to, tag);
  }
}

void receiveWords(vtkMultiProcessController* c, uint32_t* words, uint64_t count, int from, int tag)
{
  for (uint64_t at = 0; at < count; at += uint64_t(kWordPiece))
  {
    c->Receive(words + at, vtkIdType(std::min<uint64_t>(uint64_t(kWordPiece), count - at)), from, tag);
  }
}

// Every rank's buffer, in rank order (collective; small buffers only).
std::vector<std::vector<uint8_t>> allGatherBytes(vtkMultiProcessController* c, const std::vector<uint8_t>& mine)
{
  const int K = c->GetNumberOfProcesses();
  const vtkIdType n = vtkIdType(mine.size());
  std::vector<vtkIdType> lengths(static_cast<size_t>(K)), offsets(size_t(K) + 1, 0);
  c->AllGather(&n, lengths.data(), 1);
  for (int r = 0; r < K; ++r)
  {
    offsets[size_t(r) + 1] = offsets[size_t(r)] + lengths[size_t(r)];
  }
  std::vector<uint8_t> all(size_t(std::max<vtkIdType>(1, offsets.back())));
  c->AllGatherV(mine.data(), all.data(), n, lengths.data(), offsets.data());
  std::vector<std::vector<uint8_t>> out(static_cast<size_t>(K));
  for (int r = 0; r < K; ++r)
  {
    out[size_t(r)].assign(all.begin() + offsets[size_t(r)], all.begin() + offsets[size_t(r) + 1]);
  }
  return out;
}

// Runs `step` on every rank; when it fails anywhere, every rank throws (the
// failed one its own error). Keeps the ranks in step: no rank waits forever
// in a collective the others never reach.
void collectively(vtkMultiProcessController* c, const std::function<void()>& step)
{
  std::exception_ptr error;
  try
  {
    step();
  }
  catch (...)
  {
    error = std::current_exception();
  }
  int failed = error ? 1 : 0, anyFailed = 0;
  c->AllReduce(&failed, &anyFailed, 1, vtkCommunicator::MAX_OP);
  if (error)
  {
    std::rethrow_exception(error);
  }
  if (anyFailed)
  {
    throw hdt::Error(hdt::ErrorKind::OutOfResources,
      "the voxelization failed on another rank (see its error message)");
  }
}

// The root cells next to `own` on other ranks that the voxel surface of its
// cells looks at: R^2 cells (one layer along z) each side.
std::pair<hdt::RootRange, hdt::RootRange> haloOf(const hdt::RootRange& own, uint64_t R)
{
  if (own.size() == 0)
  {
    return { hdt::RootRange{ 0, 0 }, hdt::RootRange{ 0, 0 } };
  }
  const uint64_t cells = R * R * R, layer = R * R;
  return { hdt::RootRange{ own.first - std::min(own.first, layer), own.first },
    hdt::RootRange{ own.end, std::min(cells, own.end + layer) } };
}

hdt::RootRange intersect(const hdt::RootRange& a, const hdt::RootRange& b)
{
  const uint64_t first = std::max(a.first, b.first), end = std::min(a.end, b.end);
  return first < end ? hdt::RootRange{ first, end } : hdt::RootRange{ first, first };
}

// The halo's trees from the ranks that own them. Point to point, every rank
// walking the same global list of (sender, receiver) pairs in order: the
// earliest unfinished pair always has both ends waiting on it, so blocking
// sends cannot deadlock.
std::vector<hdt::RangeTree> exchangeHalo(vtkMultiProcessController* c, const hdt::GridSpec& g,
  const std::vector<hdt::RootRange>& ranges, const hdt::RangeTree& own)
{
  const int K = int(ranges.size()), me = c->GetLocalProcessId();
  const uint64_t R = uint64_t(g.rootGrid);
  std::vector<hdt::RangeTree> halo;
  for (int from = 0; from < K; ++from)
  {
    for (int to = 0; to < K; ++to)
    {
      if (from == to || (from != me && to != me))
      {
        continue;
      }
      const auto h = haloOf(ranges[size_t(to)], R);
      hdt::RootRange part = intersect(ranges[size_t(from)], h.first);
      if (part.size() == 0)
      {
        part = intersect(ranges[size_t(from)], h.second);
      }
      if (part.size() == 0)
      {
        continue;
      }
      if (from == me)
      {
        sendBytes(c, hdt::packRangeTree(hdt::sliceRangeTree(g, own, part)), to, kHaloTag);
      }
      else
      {
        const std::vector<uint8_t> bytes = receiveBytes(c, from, kHaloTag);
        halo.push_back(hdt::unpackRangeTree(bytes.data(), bytes.size(), g));
      }
    }
  }
  return halo;
}

// The piece volume: the halo's trees around the rank's own, in root-cell order.
std::shared_ptr<hdt::Volume> assemblePiece(
  const hdt::GridSpec& g, hdt::RangeTree&& own, std::vector<hdt::RangeTree>&& halo)
{
  std::vector<hdt::RangeTree> parts = std::move(halo);
  parts.push_back(std::move(own));
  std::sort(parts.begin(), parts.end(),
    [](const hdt::RangeTree& a, const hdt::RangeTree& b) { return a.cells.first < b.cells.first; });
  parts.erase(std::remove_if(parts.begin(), parts.end(),
                [](const hdt::RangeTree& t) { return t.cells.size() == 0; }),
    parts.end());
  return std::make_shared<hdt::Volume>(hdt::pieceVolume(g, std::move(parts)));
}

// The structure summed over ranks, the phase times per rank, and the
// statistics every rank reports: sums, the slowest rank's phase times.
void reduceStatistics(vtkMultiProcessController* c, const hdt::GridSpec& g, const hdt::RangeTree& own,
  const hdt::PhaseTimes& mine, vtkHDTDistributedPiece& piece, hdt::Statistics& s)
{
  uint64_t local[hdt::kStructureFields], sum[hdt::kStructureFields];
  hdt::structureToArray(hdt::rangeStructure(g, own), local);
  std::vector<unsigned long long> in(local, local + hdt::kStructureFields), out(in.size());
  c->AllReduce(in.data(), out.data(), vtkIdType(in.size()), vtkCommunicator::SUM_OP);
  std::copy(out.begin(), out.end(), sum);
  hdt::structureFromArray(sum, s);
  hdt::finishStructure(s);

  const int K = c->GetNumberOfProcesses();
  const double t[5] = { mine.mapping, mine.branching, mine.leaf, mine.classify, mine.total };
  std::vector<double> all(size_t(5 * K));
  c->AllGather(t, all.data(), 5);
  piece.RankTimes.resize(static_cast<size_t>(K));
  s.time = hdt::PhaseTimes();
  for (int r = 0; r < K; ++r)
  {
    hdt::PhaseTimes& p = piece.RankTimes[size_t(r)];
    const double* a = all.data() + 5 * r;
    p.mapping = a[0];
    p.branching = a[1];
    p.leaf = a[2];
    p.classify = a[3];
    p.total = a[4];
    s.time.mapping = std::max(s.time.mapping, p.mapping);
    s.time.branching = std::max(s.time.branching, p.branching);
    s.time.leaf = std::max(s.time.leaf, p.leaf);
    s.time.classify = std::max(s.time.classify, p.classify);
    s.time.total = std::max(s.time.total, p.total);
  }
}

// Every rank's range tree joined into one volume on rank `root` (collective;
// other ranks get null). Each rank's leaf-word count first: the root places
// each rank's words where the joined volume keeps them, as they arrive (no
// pass over them afterwards).
std::unique_ptr<hdt::Volume> gatherTrees(
  vtkMultiProcessController* c, const hdt::GridSpec& g, hdt::RangeTree&& own, int root)
{
  const int K = c->GetNumberOfProcesses(), me = c->GetLocalProcessId();
  const unsigned long long mine = own.leafWords.size();
  std::vector<unsigned long long> counts(static_cast<size_t>(K));
  c->Gather(&mine, counts.data(), 1, root);
  std::unique_ptr<hdt::PlacedGather> gather;
  collectively(c, [&] {
    if (me == root)
    {
      gather = std::make_unique<hdt::PlacedGather>(g, std::vector<uint64_t>(counts.begin(), counts.end()));
      gather->addOwn(size_t(me), std::move(own));
    }
  });
  if (me != root)
  {
    sendBytes(c, hdt::packRangeLevels(own), root, kGatherTag);
    sendWords(c, own.leafWords.data(), own.leafWords.size(), root, kGatherTag);
    return nullptr;
  }
  for (int r = 0; r < K; ++r)
  {
    if (r == me)
    {
      continue;
    }
    const std::vector<uint8_t> levels = receiveBytes(c, r, kGatherTag);
    gather->addLevels(size_t(r), hdt::unpackRangeLevels(levels.data(), levels.size(), g));
    receiveWords(c, gather->wordsOf(size_t(r)), gather->wordCountOf(size_t(r)), r, kGatherTag);
  }
  return std::make_unique<hdt::Volume>(gather->join());
}

// Under the winding number the ranks build the surface only (their drivers
// skip the parity passes): the trees go to rank 0, which classifies the
// joined volume as the serial build classifies its own (the same function of
// the mesh and the surface, so the same bytes), and each rank gets its own
// range's classified trees back. Returns them; `windingMs` the pass's time
// on rank 0 (0 elsewhere).
hdt::RangeTree classifiedByWindingOnRoot(vtkMultiProcessController* c, const hdt::PreparedMesh& mesh,
  const hdt::BuildOptions& options, tbb::task_arena& arena, const std::vector<hdt::RootRange>& ranges,
  hdt::RangeTree&& own, double& windingMs)
{
  const hdt::GridSpec& g = mesh.grid;
  const int K = c->GetNumberOfProcesses(), me = c->GetLocalProcessId();
  windingMs = 0;
  std::unique_ptr<hdt::Volume> whole = gatherTrees(c, g, std::move(own), 0);
  hdt::RangeTree mine;
  collectively(c, [&] {
    if (me != 0)
    {
      return;
    }
    arena.execute([&] { windingMs = hdt::applyInsideTestAfterPhases(mesh, *whole, options); });
    mine = hdt::sliceVolume(*whole, ranges[0]);
  });
  std::vector<uint8_t> bytes;
  if (me == 0)
  {
    for (int r = 1; r < K; ++r)
    {
      sendBytes(c, hdt::packRangeTree(hdt::sliceVolume(*whole, ranges[size_t(r)])), r, kScatterTag);
    }
  }
  else
  {
    bytes = receiveBytes(c, 0, kScatterTag);
  }
  collectively(c, [&] { // every rank: no rank may leave a collective the others are in
    if (me != 0)
    {
      mine = hdt::unpackRangeTree(bytes.data(), bytes.size(), g);
    }
  });
  return mine;
}

// What ran over the ranks, from every rank's device (-1: the CPU).
std::string backendOf(const std::vector<int>& rankDevices)
{
  const bool gpu = std::any_of(rankDevices.begin(), rankDevices.end(), [](int d) { return d >= 0; });
  const bool cpu = std::any_of(rankDevices.begin(), rankDevices.end(), [](int d) { return d < 0; });
  return gpu && cpu ? "cuda+cpu" : gpu ? "cuda" : "cpu";
}
} // namespace

//------------------------------------------------------------------------------
vtkMultiProcessController* vtkHDTDistributed::Controller()
{
  vtkMultiProcessController* c = vtkMultiProcessController::GetGlobalController();
  return c && c->GetNumberOfProcesses() > 1 ? c : nullptr;
}

//------------------------------------------------------------------------------
bool vtkHDTDistributed::Any(vtkMultiProcessController* c, bool value)
{
  int mine = value ? 1 : 0, any = 0;
  c->AllReduce(&mine, &any, 1, vtkCommunicator::MAX_OP);
  return any != 0;
}

//------------------------------------------------------------------------------
int vtkHDTDistributed::LocalRank(vtkMultiProcessController* c)
{
  // The ranks on this node are those with this host's name: what
  // MPI_Comm_split_type(MPI_COMM_TYPE_SHARED) gives, through the controller,
  // so that the module needs no MPI library of its own (its VTK tests run on
  // machines without MPI).
  constexpr int kName = 256;
  char name[kName] = {};
  gethostname(name, kName - 1);
  const int K = c->GetNumberOfProcesses(), me = c->GetLocalProcessId();
  std::vector<char> all(static_cast<size_t>(K) * kName);
  c->AllGather(name, all.data(), kName);
  int local = 0;
  for (int r = 0; r < me; ++r)
  {
    local += std::strncmp(all.data() + size_t(r) * kName, name, kName) == 0 ? 1 : 0;
  }
  return local;
}

//------------------------------------------------------------------------------
void vtkHDTDistributed::GatherMesh(vtkMultiProcessController* c, hdt::TriangleMesh& mesh)
{
  const int K = c->GetNumberOfProcesses();
  const vtkIdType counts[2] = { vtkIdType(mesh.points.size()), vtkIdType(mesh.triangles.size()) };
  std::vector<vtkIdType> all(size_t(2 * K));
  c->AllGather(counts, all.data(), 2);
  std::vector<vtkIdType> pLen(static_cast<size_t>(K)), pOff(size_t(K) + 1, 0), tLen(static_cast<size_t>(K)), tOff(size_t(K) + 1, 0);
  for (int r = 0; r < K; ++r)
  {
    pLen[size_t(r)] = all[size_t(2 * r)];
    tLen[size_t(r)] = all[size_t(2 * r + 1)];
    pOff[size_t(r) + 1] = pOff[size_t(r)] + pLen[size_t(r)];
    tOff[size_t(r) + 1] = tOff[size_t(r)] + tLen[size_t(r)];
  }
  if (uint64_t(pOff.back() / 3) > uint64_t(UINT32_MAX))
  {
    throw hdt::Error(hdt::ErrorKind::BadInput, "the gathered mesh has more than 2^32 points");
  }
  hdt::TriangleMesh gathered;
  gathered.points.resize(size_t(std::max<vtkIdType>(1, pOff.back())));
  gathered.triangles.resize(size_t(std::max<vtkIdType>(1, tOff.back())));
  c->AllGatherV(mesh.points.data(), gathered.points.data(), counts[0], pLen.data(), pOff.data());
  c->AllGatherV(mesh.triangles.data(), gathered.triangles.data(), counts[1], tLen.data(), tOff.data());
  gathered.points.resize(size_t(pOff.back()));
  gathered.triangles.resize(size_t(tOff.back()));
  for (int r = 1; r < K; ++r) // each rank's indices count from its own first point
  {
    const uint32_t base = uint32_t(pOff[size_t(r)] / 3);
    for (vtkIdType i = tOff[size_t(r)]; i < tOff[size_t(r) + 1]; ++i)
    {
      gathered.triangles[size_t(i)] += base;
    }
  }
  mesh = std::move(gathered);
}

//------------------------------------------------------------------------------
vtkHDTDistributedPiece vtkHDTDistributed::Build(
  vtkMultiProcessController* c, const hdt::PreparedMesh& mesh, const hdt::BuildOptions& options)
{
  const auto t0 = Clock::now();
  const hdt::GridSpec& g = mesh.grid;
  const int K = c->GetNumberOfProcesses(), me = c->GetLocalProcessId();
  const uint64_t R = uint64_t(g.rootGrid);
  vtkHDTDistributedPiece piece;
  // The same loads and plan on every rank: they all prepared the same mesh.
  piece.Ranges = hdt::planRootRanges(hdt::cellLoads(mesh), R * R * R, K, R);
  piece.Cells = piece.Ranges[size_t(me)];

  // Each rank on its own driver (makeRangeBuild): with a GPU (Backend CUDA,
  // or Auto where a device is usable) the device of its local rank modulo the
  // node's devices, else (Auto) the CPU. Both drivers give the same boundary
  // parities and pieces, so the ranks need not agree.
  hdt::BuildOptions rankOptions = options;
  const int localRank = LocalRank(c); // collective: on every rank
  if (options.backend != hdt::Backend::Cpu)
  {
    rankOptions.device = localRank % std::max(1, hdt::cudaDeviceCount());
  }
  const int threads = options.threads > 0 ? options.threads : tbb::task_arena::automatic;
  tbb::task_arena arena(threads);
  std::unique_ptr<hdt::RootRangeBuild> build;
  hdt::RangeBoundary boundary;
  collectively(c, [&] {
    try
    {
      arena.execute([&] {
        build = hdt::makeRangeBuild(mesh, rankOptions, piece.Cells);
        boundary = build->buildTree();
      });
    }
    catch (const hdt::Error& e)
    {
      throw hdt::Error(e.kind(), "rank " + std::to_string(me) + ": " + e.what());
    }
  });
  const int rw = hdt::rowWordsFor(g.leafSize);
  const std::vector<std::vector<uint8_t>> sent = allGatherBytes(c, hdt::packBoundary(boundary, rw));
  hdt::RangeTree own;
  hdt::PhaseTimes times;
  collectively(c, [&] {
    std::vector<hdt::RangeBoundary> boundaries;
    for (const std::vector<uint8_t>& b : sent)
    {
      boundaries.push_back(hdt::unpackBoundary(b.data(), b.size(), rw));
    }
    const std::vector<hdt::RangeBoundary> beyond =
      hdt::parityBeyondRanges(boundaries, hdt::classifiedAxes(mesh.closed), rw);
    arena.execute([&] { own = build->finish(&beyond[size_t(me)]); });
    times = build->times();
    piece.Device = build->device(); // after finish: Auto may have fallen back in it
    build.reset();                  // the device's memory goes back now
  });
  if (hdt::windingPassFollows(mesh))
  {
    double windingMs = 0;
    // On rank 0's GPU where its range build ran on one, else on its host.
    own = classifiedByWindingOnRoot(c, mesh, hdt::insideTestOptionsAfterRangeBuild(rankOptions, piece.Device),
      arena, piece.Ranges, std::move(own), windingMs);
    times.classify += windingMs;
  }
  times.total = msSince(t0);
  piece.RankDevices.assign(static_cast<size_t>(K), -1);
  c->AllGather(&piece.Device, piece.RankDevices.data(), 1);
  piece.Backend = backendOf(piece.RankDevices);

  hdt::Statistics stats;
  reduceStatistics(c, g, own, times, piece, stats);
  stats.triangles = mesh.triangles.size();
  stats.degenerateTriangles = mesh.degenerateTriangles;
  stats.backend = piece.Backend;
  stats.threads = options.threads > 0 ? options.threads : tbb::this_task_arena::max_concurrency();

  std::shared_ptr<hdt::Volume> volume;
  collectively(c, [&] {
    std::vector<hdt::RangeTree> halo = exchangeHalo(c, g, piece.Ranges, own);
    volume = assemblePiece(g, std::move(own), std::move(halo));
  });
  volume->surfaceOnly = mesh.surfaceOnly;
  volume->closedMesh = mesh.closed;
  volume->insideTest = mesh.insideTest;
  volume->stats = stats;
  piece.Volume = volume;
  return piece;
}

//------------------------------------------------------------------------------
vtkHDTDistributedPiece vtkHDTDistributed::Share(
  vtkMultiProcessController* c, std::shared_ptr<const hdt::Volume> whole)
{
  const hdt::GridSpec& g = whole->grid;
  const uint64_t R = uint64_t(g.rootGrid), cells = R * R * R;
  const int K = c->GetNumberOfProcesses(), me = c->GetLocalProcessId();
  // Rows of root cells evenly: the file has no T1 loads.
  std::vector<hdt::CellLoad> loads;
  for (uint64_t cell = 0; cell < cells; ++cell)
  {
    loads.push_back(hdt::CellLoad{ cell, 1, 0 });
  }
  vtkHDTDistributedPiece piece;
  piece.Ranges = hdt::planRootRanges(loads, cells, K, R);
  piece.Cells = piece.Ranges[size_t(me)];
  piece.RankTimes.assign(size_t(K), whole->stats.time);
  piece.RankDevices.assign(size_t(K), -1); // nothing was built here
  piece.Backend = whole->stats.backend;
  const auto halo = haloOf(piece.Cells, R);
  std::vector<hdt::RangeTree> parts;
  for (const hdt::RootRange& r : { halo.first, piece.Cells, halo.second })
  {
    if (r.size())
    {
      parts.push_back(hdt::sliceVolume(*whole, r));
    }
  }
  auto volume = std::make_shared<hdt::Volume>(hdt::pieceVolume(g, std::move(parts)));
  volume->surfaceOnly = whole->surfaceOnly;
  volume->closedMesh = whole->closedMesh;
  volume->insideTest = whole->insideTest;
  volume->stats = whole->stats;
  piece.Volume = volume;
  return piece;
}

//------------------------------------------------------------------------------
void vtkHDTDistributed::AddFieldData(const vtkHDTDistributedPiece& piece, vtkFieldData* fd)
{
  vtkNew<vtkTypeUInt64Array> ranges;
  ranges->SetName("RankRootRanges");
  ranges->SetNumberOfComponents(2);
  ranges->SetNumberOfTuples(vtkIdType(piece.Ranges.size()));
  for (size_t r = 0; r < piece.Ranges.size(); ++r)
  {
    ranges->SetTypedComponent(vtkIdType(r), 0, piece.Ranges[r].first);
    ranges->SetTypedComponent(vtkIdType(r), 1, piece.Ranges[r].end);
  }
  fd->AddArray(ranges);
  vtkNew<vtkDoubleArray> times;
  times->SetName("RankTimes");
  times->SetNumberOfComponents(5);
  times->SetComponentName(0, "Mapping");
  times->SetComponentName(1, "Branching");
  times->SetComponentName(2, "Leaf");
  times->SetComponentName(3, "Classify");
  times->SetComponentName(4, "Total");
  times->SetNumberOfTuples(vtkIdType(piece.RankTimes.size()));
  for (size_t r = 0; r < piece.RankTimes.size(); ++r)
  {
    const hdt::PhaseTimes& t = piece.RankTimes[r];
    const double v[5] = { t.mapping, t.branching, t.leaf, t.classify, t.total };
    times->SetTypedTuple(vtkIdType(r), v);
  }
  fd->AddArray(times);
  vtkNew<vtkIntArray> devices;
  devices->SetName("RankDevices");
  for (int d : piece.RankDevices)
  {
    devices->InsertNextValue(d);
  }
  fd->AddArray(devices);
}

//------------------------------------------------------------------------------
std::vector<hdt::RootRange> vtkHDTDistributed::RangesOf(vtkFieldData* fd, int ranks)
{
  auto* a = fd ? vtkTypeUInt64Array::SafeDownCast(fd->GetArray("RankRootRanges")) : nullptr;
  std::vector<hdt::RootRange> out;
  if (!a || a->GetNumberOfComponents() != 2 || a->GetNumberOfTuples() != ranks)
  {
    return out;
  }
  for (vtkIdType r = 0; r < ranks; ++r)
  {
    out.push_back(hdt::RootRange{ a->GetTypedComponent(r, 0), a->GetTypedComponent(r, 1) });
  }
  return out;
}

//------------------------------------------------------------------------------
std::shared_ptr<hdt::Volume> vtkHDTDistributed::Gather(vtkMultiProcessController* c,
  const hdt::Volume& pieceVolume, const std::vector<hdt::RootRange>& ranges, int root)
{
  const int K = c->GetNumberOfProcesses(), me = c->GetLocalProcessId();
  const hdt::GridSpec& g = pieceVolume.grid;
  hdt::RangeTree own;
  collectively(c, [&] {
    if (int(ranges.size()) != K)
    {
      throw hdt::Error(hdt::ErrorKind::InvalidArgument, "the grid was not split over these ranks");
    }
    own = hdt::sliceVolume(pieceVolume, ranges[size_t(me)]);
  });
  std::unique_ptr<hdt::Volume> joined = gatherTrees(c, g, std::move(own), root);
  if (!joined)
  {
    return nullptr;
  }
  std::shared_ptr<hdt::Volume> whole = std::move(joined);
  whole->surfaceOnly = pieceVolume.surfaceOnly;
  whole->closedMesh = pieceVolume.closedMesh;
  whole->insideTest = pieceVolume.insideTest;
  whole->stats = pieceVolume.stats; // mesh counts, times and backend of the build
  hdt::computeStructureStatistics(*whole);
  return whole;
}
