// makeCudaRangeBuild (root_ranges.hpp): the CUDA driver on one range of root
// cells, in the two stages of a range build, so that a rank of a distributed
// build does its range's work only. The range is built as the chunked path
// builds the whole grid (chunked.hpp), with the parity beyond the range
// (from the other ranges) added to the parity beyond its chunks.
#include "chunked.hpp"
#include "session.hpp"

#include "hdt/error.hpp"
#include "hdt/progress.hpp"
#include "hdt/root_ranges.hpp"

#include <chrono>
#include <memory>
#include <string>

namespace hdt {
namespace {

using Clock = std::chrono::steady_clock;

double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

class CudaRangeBuild final : public RootRangeBuild {
public:
  CudaRangeBuild(const PreparedMesh& mesh, const BuildOptions& options, RootRange cells)
      : options_(options), session_(mesh, options_), range_(session_, cells) {
    // Under the winding number the joining process classifies the joined
    // volume afterwards and reports the rest of the progress.
    if (windingPassFollows(mesh)) session_.progressShare = kCpuPhasesShareBeforeWinding;
  }

  const RangeBoundary& buildTree() override {
    return translated([&]() -> const RangeBoundary& {
      if (!session_.mesh.triangles.empty()) uploadTriangles(session_);
      session_.progress(0.0, "mapping");
      return range_.buildTree();
    });
  }

  RangeTree finish(const RangeBoundary* beyond) override {
    return translated([&] {
      LeafWordVector leafWords;
      std::vector<RangeTree> chunks = range_.finish(beyond, leafWords);
      const auto t0 = Clock::now();
      RangeTree out = joinRangeTrees(std::move(chunks), std::move(leafWords));
      joinMs_ = msSince(t0);
      session_.progress(1.0, windingPassFollows(session_.mesh) ? "classification" : "done");
      return out;
    });
  }

  const PhaseTimes& times() const override {
    const double* ms = session_.ms;
    times_.mapping = ms[cuda::kMapping];
    times_.branching = ms[cuda::kBranching];
    times_.leaf = ms[cuda::kLeaf];
    // The host's part of classification and the chunks' join count there.
    times_.classify = ms[cuda::kClassify] + range_.hostMs() + joinMs_;
    times_.total = times_.mapping + times_.branching + times_.leaf + times_.classify;
    return times_;
  }
  const char* backend() const override { return "cuda"; }
  int device() const override { return session_.device; }
  uint64_t peakDeviceBytes() const override { return session_.memory.peak(); }
  double copyBackMs() const override { return session_.copyBackMs; }

private:
  // Device memory running out outside a chunk (the triangles, T1 of the
  // range) is an Error, as in buildCuda.
  template <class Fn>
  auto translated(Fn&& fn) -> decltype(fn()) {
    try {
      return fn();
    } catch (const cuda::DeviceMemoryExhausted& e) {
      const auto mib = [](uint64_t b) { return std::to_string((b + (uint64_t(1) << 20) - 1) >> 20); };
      throw Error(ErrorKind::OutOfResources, "out of device memory (needed at least " + mib(e.neededBytes()) +
                                                 " MiB, " + mib(e.availableBytes()) + " MiB available)");
    }
  }

  const BuildOptions options_; // the session keeps a reference
  cuda::Session session_;
  cuda::ChunkedRange range_;
  double joinMs_ = 0;
  mutable PhaseTimes times_;
};

} // namespace

std::unique_ptr<RootRangeBuild> makeCudaRangeBuild(const PreparedMesh& mesh, const BuildOptions& options,
                                                   RootRange cells) {
  std::string why;
  if (!cudaAvailable(&why)) throw Error(ErrorKind::InvalidArgument, "backend cuda: " + why);
  const uint64_t R = uint64_t(mesh.grid.rootGrid);
  if (cells.first > cells.end || cells.end > R * R * R)
    throw Error(ErrorKind::InvalidArgument, "range build: the cells are not a range of the root grid");
  return std::unique_ptr<RootRangeBuild>(new CudaRangeBuild(mesh, options, cells));
}

} // namespace hdt
