/* big_alloc.h — memory for arrays far larger than the caches (the fluid's
 * populations, the benchmark's copy arrays), backed by huge pages where the
 * kernel offers them. */
#ifndef COMMON_BIG_ALLOC_H
#define COMMON_BIG_ALLOC_H

#include <stddef.h>

/* bytes of memory aligned to 64 bytes, freed with free(); NULL when there is
 * none. From 8 MiB on it is aligned to 2 MiB and the kernel is asked for
 * transparent huge pages (madvise MADV_HUGEPAGE; ignored where they are
 * off, and when AGGLO_HUGE_PAGES=0 is set, for comparisons). */
void *big_alloc(size_t bytes);

#endif
