// The process heap (glibc malloc) of the long-running programs: vilma-estimatord and
// vilma-mapstored (docs/reliability.md "Soak"). Outside glibc these do nothing / report zeros.
#pragma once

#include <cstddef>

namespace vilma {

// What malloc holds over every arena (mallinfo2) [MB].
struct HeapUsage {
  double in_use_mb = 0.0;   // live allocations, mmapped blocks included
  double free_mb = 0.0;     // free chunks malloc keeps in its arenas (not returned to the kernel)
  double mmapped_mb = 0.0;  // live blocks that have their own mapping
};

// mallinfo2 takes each arena's lock while it counts: a status report's cost (once a second),
// not something for a realtime loop.
HeapUsage ReadHeapUsage();

// The default mmap threshold of FixMallocMmapThreshold [bytes].
constexpr std::size_t kDaemonMmapThresholdBytes = 256 * 1024;

// Blocks of `threshold_bytes` and more get their own mapping and go back to the kernel when
// freed. Why: glibc raises its mmap threshold to the largest mmapped block freed so far (up to
// 32 MiB) and its trim threshold to twice that, so once a program has freed one large block (a
// map loaded at start), later large transient buffers come from the arenas, and an arena keeps
// the free pages at its top below the raised trim threshold: every arena's resident size then
// ratchets up to the largest burst it has served, over hours. Setting the threshold turns the
// dynamic adjustment off (mallopt(3)); the trim threshold stays at its 128 KiB default. Call
// once at the start of main, before other threads exist. Returns false if malloc refused.
bool FixMallocMmapThreshold(std::size_t threshold_bytes = kDaemonMmapThresholdBytes);

// Gives free pages back to the kernel: malloc_trim(0), which (glibc 2.36's source) madvises
// the whole free pages of the free chunks in every arena's bins and shrinks the main arena's
// top; a thread arena's top is shrunk only by free() once it exceeds the trim threshold (hence
// FixMallocMmapThreshold). Takes each arena's lock while it walks its bins, so call it from a
// thread off the realtime path, and not often (vilma's daemons: every 10 s).
void ReleaseFreeHeap();

}  // namespace vilma
