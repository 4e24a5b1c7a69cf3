/* fuzz_scene.c — libFuzzer target for the scene reader (common/scene*.c).
 *
 * Each input is a scene file: its bytes are written unchanged to one
 * temporary file per process and loaded with the real scene_load, so the
 * file path, the line numbers and every check run as they do for a user.
 * Lines at the very start of the input of the form "#set KEY=VALUE" (YAML
 * comments, so the file's line numbers stay those of the input) are also
 * passed as --set overrides, up to FUZZ_MAX_OVERRIDES of them; the dictionary
 * (scene.dict) and the seed corpus (corpus/) contain such lines.
 *
 * Besides what the sanitizers find (memory errors, undefined behaviour,
 * leaks: everything the loader allocates must be freed), the target checks
 * the loader's contract of scene.h and aborts when it is broken: a failed
 * load returns *out == NULL with at least one error logged, a successful one
 * returns a scene whose values lie in the documented ranges, and every
 * message starts with the file name. Messages are otherwise discarded.
 * Built with clang by `make fuzz` (README "Tests"); never part of run_tests. */
#include "../../common/scene.h"

#include <fcntl.h>
#include <float.h>
#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

enum { FUZZ_MAX_OVERRIDES = 8, FUZZ_OVERRIDE_MAX = 512 };

static char scene_path[64];

typedef struct {
    int nerrors;
} sink_t;

/* Discards the message after checking that it names the file first. */
static void sink(void *ctx, status_t level, const char *category, const char *msg)
{
    sink_t *k = ctx;
    if (strcmp(category, "scene") != 0 || strncmp(msg, scene_path, strlen(scene_path)) != 0) {
        abort();
    }
    if (level >= STATUS_ERROR) {
        k->nerrors++;
    }
}

static void remove_scene_file(void)
{
    unlink(scene_path);
}

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    const char *tmp = getenv("TMPDIR");
    snprintf(scene_path, sizeof scene_path, "%s/fuzz_scene_XXXXXX", tmp != NULL && strlen(tmp) < 40 ? tmp : "/tmp");
    int fd = mkstemp(scene_path);
    if (fd < 0) {
        perror("fuzz_scene: mkstemp");
        abort();
    }
    close(fd);
    atexit(remove_scene_file);
    return 0;
}

static void write_scene(const uint8_t *data, size_t size)
{
    int fd = open(scene_path, O_WRONLY | O_TRUNC);
    if (fd < 0) {
        abort();
    }
    while (size > 0) {
        ssize_t n = write(fd, data, size);
        if (n <= 0) {
            abort();
        }
        data += n;
        size -= (size_t)n;
    }
    close(fd);
}

/* The "#set KEY=VALUE" lines at the start of the input, copied NUL-terminated. */
static int take_overrides(const uint8_t *data, size_t size, char ov[][FUZZ_OVERRIDE_MAX])
{
    static const char tag[] = "#set ";
    const size_t taglen = sizeof tag - 1;
    int n = 0;
    size_t pos = 0;
    while (n < FUZZ_MAX_OVERRIDES && size - pos > taglen && memcmp(data + pos, tag, taglen) == 0) {
        pos += taglen;
        size_t len = 0;
        while (pos + len < size && data[pos + len] != '\n') {
            len++;
        }
        size_t keep = len < FUZZ_OVERRIDE_MAX - 1 ? len : FUZZ_OVERRIDE_MAX - 1;
        memcpy(ov[n], data + pos, keep);
        ov[n][keep] = '\0';
        n++;
        pos += len + (pos + len < size);
    }
    return n;
}

static bool in_range(double v, double lo, double hi)
{
    return isfinite(v) && v >= lo && v <= hi;
}

/* What scene.h and models/README.md promise about a scene that loaded. */
static void check_scene(const scene_t *s)
{
    bool ok = s->path != NULL && strcmp(s->path, scene_path) == 0 && s->text != NULL;
    for (int a = 0; a < 3; a++) {
        ok = ok && in_range(s->domain.size[a], 0x1p-1074, INFINITY);
    }
    const scene_fluid_t *f = &s->fluid;
    ok = ok && f->dx > 0 && isfinite(f->dx) && f->dt >= DBL_MIN && isfinite(10 * f->dt) && f->tau > 0.5 &&
         isfinite(f->tau) && f->density > 0 && f->viscosity > 0;
    ok = ok && s->nbodies >= 0 && (s->nbodies == 0) == (s->bodies == NULL);
    int ns = 0;
    for (int i = 0; ok && i < s->nbodies; i++) {
        const scene_body_t *b = &s->bodies[i];
        ok = b->nspheres >= 1 && b->spheres != NULL && b->density > 0;
        for (int k = 0; ok && k < b->nspheres; k++) {
            const scene_sphere_t *sp = &b->spheres[k];
            ok = sp->radius >= 1.5 * f->dx * (1 - 1e-12) && isfinite(sp->radius);
            for (int a = 0; ok && a < 3; a++) {
                ok = in_range(sp->center[a], 0, s->domain.size[a]);
            }
        }
        ns += b->nspheres;
    }
    ok = ok && ns == scene_total_spheres(s) && s->nconnections >= 0;
    for (int i = 0; ok && i < s->nconnections; i++) {
        const scene_connection_t *c = &s->connections[i];
        ok = c->a >= 0 && c->a < ns && c->b >= 0 && c->b < ns && c->a != c->b && c->max_normal >= 0 &&
             c->max_shear >= 0 && c->max_torque >= 0;
    }
    ok = ok && s->rigid.substeps >= 1 && s->run.end_time > 0 && s->run.output_interval > 0;
    ok = ok && ceil(s->run.end_time / f->dt - 1e-9) <= (double)SCENE_STEPS_MAX;
    for (int i = 0; ok && i < 6; i++) {
        ok = strcmp(face_type_name(s->domain.faces[i].type), "unknown") != 0;
    }
    if (!ok) {
        abort();
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static char ov[FUZZ_MAX_OVERRIDES][FUZZ_OVERRIDE_MAX];
    const char *ovp[FUZZ_MAX_OVERRIDES];
    int nov = take_overrides(data, size, ov);
    for (int i = 0; i < nov; i++) {
        ovp[i] = ov[i];
    }
    write_scene(data, size);

    sink_t k = {0};
    const log_t log = {sink, &k};
    scene_t *s = (scene_t *)&k; /* scene_load must overwrite it */
    status_t st = scene_load(scene_path, ovp, nov, &log, &s);
    if (st == STATUS_OK) {
        if (s == NULL || k.nerrors != 0) {
            abort();
        }
        check_scene(s);
    } else if (s != NULL || k.nerrors == 0 || (st != STATUS_ERROR && st != STATUS_FATAL)) {
        abort();
    }
    scene_free(s);
    return 0;
}
