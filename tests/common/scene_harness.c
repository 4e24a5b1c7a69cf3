/* scene_harness.c — loading scenes for the scene reader's tests
 * (scene_harness.h). */
#include "scene_harness.h"

#include "scene_tests.h"

#include <CUnit/CUnit.h>
#include <dirent.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static void capture_log(void *ctx, status_t level, const char *category, const char *msg)
{
    capture_t *c = ctx;
    int n = snprintf(c->text + c->len, sizeof c->text - c->len, "%s: [%s] %s\n", status_name(level),
                     category ? category : "-", msg);
    if (n > 0) {
        c->len = c->len + (size_t)n < sizeof c->text ? c->len + (size_t)n : sizeof c->text - 1;
    }
    if (level >= STATUS_ERROR) {
        c->nerrors++;
    } else if (level == STATUS_WARNING) {
        c->nwarnings++;
    }
}

static int dir_entries(const char *dir)
{
    DIR *d = opendir(dir);
    if (d == NULL) {
        return -1;
    }
    int n = 0;
    for (struct dirent *e = readdir(d); e != NULL; e = readdir(d)) {
        if (strcmp(e->d_name, ".") != 0 && strcmp(e->d_name, "..") != 0) {
            n++;
        }
    }
    closedir(d);
    return n;
}

status_t scene_test_load(const char *yaml, const char *const *ov, int nov, capture_t *cap, scene_t **out)
{
    char dir[] = "/tmp/scene_test_XXXXXX";
    char path[64];
    memset(cap, 0, sizeof *cap);
    *out = (scene_t *)cap; /* a sentinel: scene_load must overwrite it, with NULL on failure */
    CU_ASSERT_PTR_NOT_NULL_FATAL(mkdtemp(dir));
    snprintf(path, sizeof path, "%s/scene.yaml", dir);
    if (yaml != NULL) {
        FILE *f = fopen(path, "w");
        CU_ASSERT_PTR_NOT_NULL_FATAL(f);
        CU_ASSERT_EQUAL(fputs(yaml, f) >= 0, 1);
        CU_ASSERT_EQUAL(fclose(f), 0);
    }
    const log_t log = {capture_log, cap};
    status_t st = scene_load(path, ov, nov, &log, out);
    CU_ASSERT_EQUAL(dir_entries(dir), yaml != NULL ? 1 : 0);
    if (yaml != NULL) {
        CU_ASSERT_EQUAL(unlink(path), 0);
    }
    CU_ASSERT_EQUAL(rmdir(dir), 0);
    return st;
}

void scene_test_contains(const capture_t *cap, const char *needle, const char *file, int line)
{
    char msg[1024];
    bool ok = strstr(cap->text, needle) != NULL;
    snprintf(msg, sizeof msg, "log contains \"%s\"; log was: %.800s", needle, cap->text);
    CU_assertImplementation(ok ? CU_TRUE : CU_FALSE, (unsigned)line, msg, file, "", CU_FALSE);
}

void scene_test_expect_error(const char *file, int line, const char *yaml, const char *const *ov, int nov,
                             int nerrors, ...)
{
    capture_t *cap = malloc(sizeof *cap);
    CU_ASSERT_PTR_NOT_NULL_FATAL(cap);
    scene_t *s = NULL;
    status_t st = scene_test_load(yaml, ov, nov, cap, &s);
    char msg[1024];
    snprintf(msg, sizeof msg, "load fails with an error; log was: %.800s", cap->text);
    CU_assertImplementation(st >= STATUS_ERROR ? CU_TRUE : CU_FALSE, (unsigned)line, msg, file, "", CU_FALSE);
    CU_ASSERT_PTR_NULL(s);
    if (st < STATUS_ERROR) {
        scene_free(s);
    }
    if (nerrors > 0) {
        CU_assertImplementation(st == STATUS_ERROR && cap->nerrors == nerrors ? CU_TRUE : CU_FALSE, (unsigned)line,
                                "STATUS_ERROR with exactly the expected number of errors", file, "", CU_FALSE);
    } else {
        CU_ASSERT(cap->nerrors >= 1);
    }
    va_list ap;
    va_start(ap, nerrors);
    for (const char *needle = va_arg(ap, const char *); needle != NULL; needle = va_arg(ap, const char *)) {
        scene_test_contains(cap, needle, file, line);
    }
    va_end(ap);
    free(cap);
}

char *scene_test_base_with_line(int line, const char *replacement)
{
    size_t cap = strlen(BASE) + 1 + strlen(replacement) + 1;
    char *out = malloc(cap);
    CU_ASSERT_PTR_NOT_NULL_FATAL(out);
    const char *p = BASE;
    size_t pos = 0;
    for (int l = 1; *p != '\0'; l++) {
        const char *eol = strchr(p, '\n');
        size_t n = (size_t)(eol - p) + 1;
        if (l == line) {
            pos += (size_t)snprintf(out + pos, cap - pos, "%s\n", replacement);
        } else {
            memcpy(out + pos, p, n);
            pos += n;
        }
        p += n;
    }
    out[pos] = '\0';
    return out;
}

void scene_test_expect_line_error(const char *file, int test_line, int line, const char *replacement, const char *n1,
                                  const char *n2, const char *n3)
{
    char *yaml = scene_test_base_with_line(line, replacement);
    scene_test_expect_error(file, test_line, yaml, NULL, 0, 0, n1, n2, n3, (const char *)NULL);
    free(yaml);
}
