// The writer's side of hdt::HdtLeafEncoder (hdt_file.hpp). Private to hdt_core.
#pragma once

#include "hdt/hdt_file.hpp"
#include "zstd_blocks.hpp"

#include <memory>

namespace hdt {

#if defined(HDT_HAVE_ZSTD)
// Waits for the blocks in flight, then hands over the encoded leaf data when
// the encoder was fed exactly `words` (all of them) at the options' level;
// null otherwise (the writer then compresses). Rethrows a compression error.
std::unique_ptr<zstd_blocks::Encoded> takeStreamedLeafBlocks(HdtLeafEncoder& encoder, const LeafWordVector& words,
                                                             const HdtWriteOptions& options);
#endif

} // namespace hdt
