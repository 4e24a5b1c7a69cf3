/* big_alloc.c — big_alloc.h.
 *
 * Why huge pages can help: a stream of the fluid's kernel crosses a 4 KiB
 * page every 512 doubles, and it runs 19 to 38 of them at once, where the
 * hardware prefetcher stops at each page's end; the wall and sphere stages
 * touch 19 arrays, a page each, per cell. Why they are not the default: on
 * this project's VM the first touch of fresh 2 MiB pages was at times far
 * slower than that of recycled 4 KiB ones (perf: clear_page in the huge
 * page fault, 1.2 s of start-up for 262 MB), which cost more than 200 steps
 * of the dual star gained (README "Speed and memory"). The pages are backed at
 * first touch either way, so the fluid's parallel first touch still puts
 * them near the threads that stream them. */
#define _DEFAULT_SOURCE /* madvise, MADV_HUGEPAGE */
#include "big_alloc.h"

#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>

enum { BIG_PAGE = 2 << 20, BIG_FROM = 8 << 20 };

void *big_alloc(size_t bytes)
{
    const size_t align = bytes >= BIG_FROM ? BIG_PAGE : 64;
    if (bytes > (size_t)-1 - align) {
        return NULL;
    }
    const size_t size = bytes == 0 ? align : (bytes + align - 1) / align * align;
    void *m = aligned_alloc(align, size);
#if defined(MADV_HUGEPAGE)
    const char *env = getenv("AGGLO_HUGE_PAGES");
    if (m != NULL && align == BIG_PAGE && env != NULL && strcmp(env, "1") == 0) {
        (void)madvise(m, size, MADV_HUGEPAGE); /* advice: where it fails, 4 KiB pages */
    }
#endif
    return m;
}
