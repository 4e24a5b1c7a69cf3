/* run.h — `coupler run`: drive a scene to its end time and write the output. */
#ifndef COUPLER_RUN_H
#define COUPLER_RUN_H

#include "../common/scene.h"

typedef struct {
    const char *output; /* .h5 path */
    long steps;         /* > 0: run this many steps instead of end_time */
    int quiet;          /* no progress line */
} run_options_t;

/* Returns 0 on success, non-zero on failure (messages already logged). */
int run_scene(const scene_t *scene, const run_options_t *opt, const log_t *log);

#endif
