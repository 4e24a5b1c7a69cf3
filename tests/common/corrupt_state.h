/* corrupt_state.h — the corruption of a component's saved state, for the
 * tests of its restore (tests/fluid/test_spheres.c for the fluid's,
 * tests/rigid/test_input.c for the rigid component's). */
#ifndef TESTS_COMMON_CORRUPT_STATE_H
#define TESTS_COMMON_CORRUPT_STATE_H

#include "../../common/status.h"

#include <CUnit/CUnit.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* A component's restore: fluid_state_restore or rigid_state_restore. */
typedef status_t (*restore_fn_t)(void *component, const void *buf, size_t size);

/* buf (n bytes) with len bytes at off replaced by v, given to restore: it
 * must be refused with expect in the message. last: the log's buffer of its
 * last error message, read after the restore. */
static inline void expect_corrupt_refused(restore_fn_t restore, void *component, const char *last,
                                          const unsigned char *buf, size_t n, size_t off, const void *v, size_t len,
                                          const char *expect)
{
    unsigned char *c = malloc(n);
    CU_ASSERT_FATAL(c != NULL);
    memcpy(c, buf, n);
    memcpy(c + off, v, len);
    const status_t st = restore(component, c, n);
    const int named = strstr(last, expect) != NULL;
    if (st != STATUS_ERROR || !named) {
        printf("\n    corrupted at byte %zu: status %d, expected an error naming '%s'; last message: %s", off, (int)st,
               expect, last);
    }
    CU_ASSERT_EQUAL(st, STATUS_ERROR);
    CU_ASSERT(named);
    free(c);
}

#endif
