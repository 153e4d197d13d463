// keep_freed_memory_for_reuse (gap.hpp): glibc's malloc tuned for one long batch analysis.
//
// Measured on the speed benchmark's 40-min recording, one step (`pof gap --max-steps 1`, 2 cores):
// 20.9 s and 590 MB peak RSS with glibc's defaults; 16.2 s and 547 MB with the three settings
// below (system time 10 s -> 0.4 s). Large blocks are otherwise mmapped and unmapped on every
// free, and each reuse faults in zeroed pages. One arena is needed, not only thrifty: a thread's
// own arena grows in heaps of at most 64 MB, so a design of 50-100 MB in a worker thread would be
// mmapped whatever M_MMAP_MAX says; from the main heap the workers' blocks are reused too, which
// is why the peak does not grow. glibc only (Debian's libc); elsewhere this does nothing.
#include "pof/gap/gap.hpp"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace pof::gap {

void keep_freed_memory_for_reuse() {
#if defined(__GLIBC__)
  mallopt(M_ARENA_MAX, 1);              // the candidates' threads share the main heap
  mallopt(M_MMAP_MAX, 0);               // large blocks come from the heap, not from fresh mappings
  mallopt(M_TRIM_THRESHOLD, 1 << 30);   // and freed ones are kept (up to 1 GiB at the top) for the next
#endif
}

}  // namespace pof::gap
