// The oneTBB arena of prepareMesh (private to core/src).
#pragma once

#include <tbb/task_arena.h>

namespace hdt {

// The arena that startHostThreads fills and prepareMesh runs in. oneTBB gives
// every thread that starts parallel work an implicit arena of its own, made at
// its first loop (its slots, then workers moved into it): started from a
// warm-up thread, the workers would wait in that thread's arena and the
// caller's first preparation would still pay for its own. One shared arena is
// made and filled once, by whichever thread comes first.
tbb::task_arena& hostArena();

// Ends keepHostThreadsAwake's tasks (warm_pages.hpp): prepareMesh's work is
// there for the workers.
void releaseHostThreads();

} // namespace hdt
