/* big_alloc.h — memory for arrays far larger than the caches (the fluid's
 * populations, the benchmark's copy arrays), on transparent huge pages on
 * request (AGGLO_HUGE_PAGES=1). */
#ifndef COMMON_BIG_ALLOC_H
#define COMMON_BIG_ALLOC_H

#include <stddef.h>

/* bytes of memory aligned to 64 bytes, freed with free(); NULL when there is
 * none. From 8 MiB on it is aligned to 2 MiB, and with AGGLO_HUGE_PAGES=1 in
 * the environment the kernel is asked for transparent huge pages for it
 * (madvise MADV_HUGEPAGE; without effect where they are off). */
void *big_alloc(size_t bytes);

#endif
