/* status.h — status codes and the log sink shared by every component.
 *
 * Status codes are ordered by severity exactly as FMI 2.0 orders fmi2Status
 * (ok < warning < discard < error < fatal), so the FMI adapter maps them 1:1.
 * Library code never prints and never exits: it reports through a log_t given
 * at creation (the FMI logger inside an FMU, stderr in the CLI) and returns a
 * status. The enum and the names come from one list so they cannot drift. */
#ifndef COMMON_STATUS_H
#define COMMON_STATUS_H

#include <math.h>
#include <stdarg.h>
#include <stddef.h>

#define STATUS_LIST(X)            \
    X(STATUS_OK, "ok")            \
    X(STATUS_WARNING, "warning")  \
    X(STATUS_DISCARD, "discard")  \
    X(STATUS_ERROR, "error")      \
    X(STATUS_FATAL, "fatal")

typedef enum {
#define STATUS_ENUM(name, text) name,
    STATUS_LIST(STATUS_ENUM)
#undef STATUS_ENUM
} status_t;

const char *status_name(status_t s);

/* A log sink: fn(ctx, level, category, message). category is a short word
 * ("scene", "fluid", "rigid", "fmi", ...) so an FMI logger can filter. */
typedef void (*log_fn_t)(void *ctx, status_t level, const char *category, const char *msg);

typedef struct {
    log_fn_t fn;
    void *ctx;
} log_t;

/* Formats and sends one message; does nothing when log or log->fn is NULL.
 * Returns level so that `return log_msg(log, STATUS_ERROR, ...)` reads well. */
status_t log_msg(const log_t *log, status_t level, const char *category, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));
status_t log_vmsg(const log_t *log, status_t level, const char *category, const char *fmt, va_list ap);

/* What a component's state restore says of bytes it refuses, at
 * STATUS_ERROR: "the state is corrupt and was not restored: " and the
 * message (fluid/state.c, rigid/state.c). */
status_t log_state_corrupt(const log_t *log, const char *category, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

/* 1 when the n values from x on are all finite. */
static inline int all_finite(const double *x, size_t n)
{
    for (size_t k = 0; k < n; k++) {
        if (!isfinite(x[k])) {
            return 0;
        }
    }
    return 1;
}

/* The sink the CLI and tests use: "level: [category] message" on stderr. */
void log_stderr(void *ctx, status_t level, const char *category, const char *msg);

static inline status_t status_worst(status_t a, status_t b) { return a > b ? a : b; }

#endif
