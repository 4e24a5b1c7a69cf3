/* status.c — names of the status codes and the formatting log front end. */
#include "status.h"

#include <stdio.h>

const char *status_name(status_t s)
{
    switch (s) {
#define STATUS_CASE(name, text) \
    case name:                  \
        return text;
        STATUS_LIST(STATUS_CASE)
#undef STATUS_CASE
    }
    return "unknown";
}

status_t log_vmsg(const log_t *log, status_t level, const char *category, const char *fmt, va_list ap)
{
    if (log == NULL || log->fn == NULL) {
        return level;
    }
    char buf[2048];
    vsnprintf(buf, sizeof buf, fmt, ap);
    log->fn(log->ctx, level, category, buf);
    return level;
}

status_t log_msg(const log_t *log, status_t level, const char *category, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    log_vmsg(log, level, category, fmt, ap);
    va_end(ap);
    return level;
}

void log_stderr(void *ctx, status_t level, const char *category, const char *msg)
{
    (void)ctx;
    fprintf(stderr, "%s: [%s] %s\n", status_name(level), category ? category : "-", msg);
}

status_t log_state_corrupt(const log_t *log, const char *category, const char *fmt, ...)
{
    char msg[1500];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    return log_msg(log, STATUS_ERROR, category, "the state is corrupt and was not restored: %s", msg);
}
