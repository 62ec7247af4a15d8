// The winding-number pass on the device (issue 16): the leaves of a
// copied-back solid volume decided by windingDecideLeaf (winding_leaf.hpp)
// from the signed +x crossing count N at each voxel centre, the same
// algorithm and bits as the host pass (core/src/winding.cpp,
// classifyLeavesByCrossings); the uniform elements and the leaves that
// refinement creates likewise. The host keeps the tree's build, the walk of
// the elements and the re-laying of refined ones.
#pragma once

#include "hdt/winding_tree.hpp"

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

namespace hdt {
namespace cuda {

class DeviceMemory;

// CUDA-event times of the device pass (milliseconds).
struct WindingDeviceTimes {
  double upload = 0, crossings = 0, lines = 0, counts = 0, decide = 0, download = 0;
  double blocks = 0; // block thresholds and the leaves they settle (decide: the rest)
  uint64_t boxes = 0;      // leaf boxes decided (breadth first)
  uint64_t hardVoxels = 0; // voxels decided on the host afterwards (windingInsideAt)
  double hardMs = 0;       // their host time
};

// The device passes of one build; the tree is uploaded once, on first use.
//
// Memory: every array the passes hold is reserved in `build` (the build's
// DeviceMemory: its budget caps them, its peak includes them); beyond the
// budget, or with no room on the device, a pass returns false (the host
// runs it). Null: counted only in peakBytes.
class WindingDevicePass {
public:
  explicit WindingDevicePass(DeviceMemory* build = nullptr);
  ~WindingDevicePass();
  WindingDevicePass(const WindingDevicePass&) = delete;
  WindingDevicePass& operator=(const WindingDevicePass&) = delete;

  // A WindingLeafPass: per leaf (one thread each) the signed crossings of its
  // rows with the candidate triangles, their suffix sums along each line of
  // leaves, N per voxel, then windingDecideLeaf's boxes breadth first; the
  // voxels that N and the strips leave unsure are decided on the host
  // (windingInsideAt; HDT_WINDING_HOST_VOXELS set: every single voxel, to
  // test that path). Leaves whose counts do not fit 16 bits go to
  // leftLeaves. False (nothing written) when the device has no room: the
  // caller runs the host pass. deviceWords: the volume's leaf words already
  // on the device (the build's own, kept), read and rewritten in place
  // instead of uploaded (volume.leafWords need not hold them then; on
  // return they hold the result either way; false leaves deviceWords' surface
  // planes intact, their inside planes undefined). beforeCopyBack: called
  // before the words come back into volume.leafWords (the caller readies them).
  bool leaves(const WindingTree& tree, Volume& volume, const std::vector<std::array<int, 3>>& origins,
              std::vector<uint32_t>& leftLeaves, WindingDeviceTimes* times = nullptr,
              uint32_t* deviceWords = nullptr, const std::function<void()>& beforeCopyBack = {});

  // A WindingUniformPass: classifyUniform's verdict per element, its boxes
  // breadth first (one thread per box and level, carried verdicts, halves);
  // elements whose boxes overflow the queue take the serial walk
  // (windingDecideBox, one thread each). ms: the kernels and their copies;
  // boxes: adds the number of boxes taken.
  bool uniform(const WindingTree& tree, const std::vector<WindingUniformJob>& jobs, std::vector<uint8_t>& verdicts,
               double* ms = nullptr, uint64_t* boxes = nullptr);

  // A WindingFreshLeafPass: the leaves that refinement creates hold no
  // surface voxel; N at each voxel centre by windingRayCrossings (one thread
  // per row: N is constant along a row there), then the same decision as leaves().
  bool fresh(const WindingTree& tree, int L, const std::vector<std::array<int, 3>>& origins, uint32_t* words,
             std::vector<uint32_t>& leftLeaves, double* ms = nullptr);

  // The most device bytes the passes held at once so far.
  uint64_t peakBytes() const;

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// N per voxel of every leaf (leaf-major, x fastest, L^3 each) as the pass
// computes it, and per leaf whether it fits 16 bits (tests: N must equal
// windingRayCrossings at every non-surface voxel centre).
void windingCountsOnDevice(const WindingTree& tree, int L, const std::vector<std::array<int, 3>>& origins,
                           std::vector<int16_t>& counts, std::vector<uint8_t>& fits);

} // namespace cuda
} // namespace hdt
