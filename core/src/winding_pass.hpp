// Steps of the winding-number pass shared by its files: winding.cpp (the
// elements and leaves of a volume) and winding_refine.cpp (the re-lay of the
// elements that the w = 1/2 surface splits). Internal to hdt_core.
#pragma once

#include "hdt/progress.hpp"
#include "hdt/volume.hpp"
#include "hdt/winding_tree.hpp"

#include <array>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <vector>

namespace hdt {
namespace winding_pass {

// The phase the inside test reports (BuildOptions::progress), and a report
// of `fraction` of it when the build has a poll: it throws Error(Aborted)
// when the caller asked to stop, also inside the loops since the last one
// (they poll with abortRequested and return early, leaving work undone that
// nothing reads after the throw).
constexpr const char* kWindingPhase = "inside test: winding number";
inline void reportWinding(ProgressPoll* progress, double fraction) {
  if (progress) progress->report(fraction, kWindingPhase);
}

// HDT_WINDING_TRACE set: the host's phases of the inside test on stderr (the
// device passes print theirs, cuda/src/winding_device.cu).
inline void traceWindingMs(const char* phase, double ms) {
  static const bool on = std::getenv("HDT_WINDING_TRACE") != nullptr;
  if (on) std::fprintf(stderr, "winding host: %s %.2f ms\n", phase, ms);
}
inline void traceWinding(const char* phase, std::chrono::steady_clock::time_point since) {
  traceWindingMs(phase, std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - since).count());
}

// A uniform element's verdict: inside, or split when its voxel centres lie
// on both sides of w = 1/2 (then it must be refined).
struct UniformVerdict {
  bool inside = false;
  bool split = false;
};

struct CoarseThresholds; // winding.cpp: the blocks' thresholds

// The verdicts of uniform elements: by the pass when there is one and it
// runs (verdict bit 0 inside, bit 1 split), here otherwise (by their block's
// threshold where `coarse` has one, else classifyUniform).
std::vector<UniformVerdict> decideUniformJobs(const WindingTree& tree, const std::vector<WindingUniformJob>& jobs,
                                              const WindingUniformPass& pass, ProgressPoll* progress,
                                              const CoarseThresholds* coarse = nullptr);

// A leaf decided voxel by voxel from certified sums (the fallback of every
// faster route), its surface plane kept.
void classifyLeaf(const WindingTreeView& t, uint32_t* words, int L, const std::array<int, 3>& origin);

// A leaf that refinement creates (no surface voxel) by the leaf decision;
// false when it cannot say (then classifyLeaf).
bool decideFreshLeaf(const WindingTreeView& t, uint32_t* words, int L, const std::array<int, 3>& origin);

// Re-lays the tree in canonical level order with every split uniform element
// refined (winding_refine.cpp). Returns the number of elements refined.
uint64_t refineSplitElements(const WindingTree& tree, Volume& v, const std::vector<uint8_t>& split,
                             const WindingUniformPass& uniformPass, const WindingFreshLeafPass& freshPass,
                             ProgressPoll* progress);

} // namespace winding_pass
} // namespace hdt
