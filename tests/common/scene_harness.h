/* scene_harness.h — loading scenes for the scene reader's tests
 * (test_scene.c valid input, test_scene_refused.c bad input): each scene is
 * written to a fresh mkdtemp directory, loaded with a log sink that captures
 * every message, and removed again; the loader must write nothing there. */
#ifndef TESTS_COMMON_SCENE_HARNESS_H
#define TESTS_COMMON_SCENE_HARNESS_H

#include "../../common/scene.h"

typedef struct {
    char text[32768];
    size_t len;
    int nerrors, nwarnings;
} capture_t;

/* The base scene (scene_tests.h) and one with only the required keys
 * (domain periodic, no bodies): every other value comes from a default. */
#define BASE scene_test_base
#define MINIMAL                                                            \
    "domain: {size: [1.0e-3, 1.0e-3, 1.0e-3]}\n"                          \
    "fluid: {density: 1000.0, viscosity: 1.0e-6, dx: 1.0e-4, tau: 1.0}\n" \
    "run: {end_time: 2.0}\n"

/* Writes yaml (when not NULL) to DIR/scene.yaml in a fresh temporary
 * directory, loads it with the overrides, checks that the loader wrote
 * nothing into the directory, and removes everything again. */
status_t scene_test_load(const char *yaml, const char *const *ov, int nov, capture_t *cap, scene_t **out);
/* A CUnit assertion at file:line that the captured log holds needle. */
void scene_test_contains(const capture_t *cap, const char *needle, const char *file, int line);
/* Loads yaml with the overrides and expects failure with every needle
 * (a NULL-terminated list) in the captured messages: STATUS_ERROR and exactly
 * nerrors error messages when nerrors > 0, at least one error when 0. */
void scene_test_expect_error(const char *file, int line, const char *yaml, const char *const *ov, int nov,
                             int nerrors, ...);
/* The base scene with one line replaced (1-based; malloc'ed), for errors
 * located by line. */
char *scene_test_base_with_line(int line, const char *replacement);
/* The same for the base scene with its line `line` (1-based) replaced. */
void scene_test_expect_line_error(const char *file, int test_line, int line, const char *replacement, const char *n1,
                                  const char *n2, const char *n3);

#define EXPECT_ERROR(yaml, ov, nov, ...) \
    scene_test_expect_error(__FILE__, __LINE__, yaml, ov, nov, 0, __VA_ARGS__, (const char *)NULL)
/* The same with exactly n error messages (every violation reported). */
#define EXPECT_N_ERRORS(n, yaml, ov, nov, ...) \
    scene_test_expect_error(__FILE__, __LINE__, yaml, ov, nov, n, __VA_ARGS__, (const char *)NULL)

/* One override on the base scene. */
#define EXPECT_SET_ERROR(set, ...)                             \
    do {                                                       \
        const char *const ov_[] = {set};                       \
        EXPECT_ERROR(BASE, ov_, 1, "scene.yaml", __VA_ARGS__); \
    } while (0)

#define EXPECT_LINE_ERROR(line, replacement, n1, n2, n3) \
    scene_test_expect_line_error(__FILE__, __LINE__, line, replacement, n1, n2, n3)

#endif
