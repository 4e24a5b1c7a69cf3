/* test_big_alloc.c — common/big_alloc.h: the alignment the kernels rely on
 * (non-temporal stores need 64 bytes), every byte usable, and with
 * AGGLO_HUGE_PAGES=1 huge pages where the system offers them (madvise or
 * always mode). */
#define _DEFAULT_SOURCE /* setenv, unsetenv */
#include "../../common/big_alloc.h"

#include <CUnit/CUnit.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* kB of AnonHugePages in this process (/proc/self/smaps_rollup), -1 without */
static long anon_huge_kb(void)
{
    FILE *f = fopen("/proc/self/smaps_rollup", "r");
    if (f == NULL) {
        return -1;
    }
    char line[256];
    long kb = -1;
    while (fgets(line, sizeof line, f) != NULL) {
        if (sscanf(line, "AnonHugePages: %ld kB", &kb) == 1) {
            break;
        }
    }
    fclose(f);
    return kb;
}

/* A counter of /proc/vmstat, -1 without */
static long vmstat(const char *name)
{
    FILE *f = fopen("/proc/vmstat", "r");
    if (f == NULL) {
        return -1;
    }
    char key[128];
    long v = -1, x;
    while (fscanf(f, "%127s %ld", key, &x) == 2) {
        if (strcmp(key, name) == 0) {
            v = x;
            break;
        }
    }
    fclose(f);
    return v;
}

/* 1 when transparent huge pages are on for an madvise'd region */
static int thp_offered(void)
{
    FILE *f = fopen("/sys/kernel/mm/transparent_hugepage/enabled", "r");
    if (f == NULL) {
        return 0;
    }
    char line[128] = "";
    const int ok = fgets(line, sizeof line, f) != NULL;
    fclose(f);
    return ok && (strstr(line, "[always]") != NULL || strstr(line, "[madvise]") != NULL);
}

static void test_alignment_and_size(void)
{
    const size_t sizes[] = {0, 1, 100, 4096, (8u << 20) - 8, 8u << 20, (8u << 20) + 24, 37u << 20};
    for (int on = 0; on < 2; on++) {
        if (on) {
            setenv("AGGLO_HUGE_PAGES", "1", 1);
        }
        for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++) {
            unsigned char *m = big_alloc(sizes[i]);
            CU_ASSERT_PTR_NOT_NULL_FATAL(m);
            CU_ASSERT((uintptr_t)m % 64 == 0);
            if (sizes[i] >= (8u << 20)) {
                CU_ASSERT((uintptr_t)m % (2u << 20) == 0);
            }
            if (sizes[i] > 0) {
                memset(m, 0xA5, sizes[i]); /* every byte asked for is there */
                CU_ASSERT(m[0] == 0xA5 && m[sizes[i] - 1] == 0xA5);
            }
            free(m);
        }
    }
    unsetenv("AGGLO_HUGE_PAGES");
    CU_ASSERT_PTR_NULL(big_alloc((size_t)-1 - 100)); /* no room in an address space */
}

static void test_huge_pages_where_offered(void)
{
    setenv("AGGLO_HUGE_PAGES", "1", 1);
    const long before = anon_huge_kb(), fallback = vmstat("thp_fault_fallback");
    if (!thp_offered() || before < 0) {
        printf("\n    (transparent huge pages off or not reported here: alignment only)\n");
        return;
    }
    const size_t bytes = 64u << 20;
    unsigned char *m = big_alloc(bytes);
    CU_ASSERT_PTR_NOT_NULL_FATAL(m);
    memset(m, 1, bytes); /* backed at first touch */
    const long with = anon_huge_kb(), fell = vmstat("thp_fault_fallback") - fallback;
    free(m);
    unsetenv("AGGLO_HUGE_PAGES");
    if (with - before < 16 * 1024 && fallback >= 0 && fell > 0) {
        /* the kernel tried and had no huge page to give (fragmented memory):
         * the advice was given, the machine could not follow it */
        printf("\n    (%ld huge page faults fell back to small pages here)\n", fell);
        return;
    }
    /* most of 64 MiB in 2 MiB pages; none at all, and no fallback, means
     * the advice was never given */
    CU_ASSERT(with - before >= 16 * 1024);
}

void big_alloc_register_tests(void)
{
    CU_pSuite s = CU_add_suite("big_alloc", NULL, NULL);
    CU_add_test(s, "64-byte aligned, 2 MiB from 8 MiB on, every byte usable, with and without AGGLO_HUGE_PAGES=1",
                test_alignment_and_size);
    CU_add_test(s, "with AGGLO_HUGE_PAGES=1, large arrays on transparent huge pages where the system offers them", test_huge_pages_where_offered);
}
