/* h5_cause.c — the cause of a failed HDF5 call (h5_cause.h). */
#include "h5_cause.h"

#include <hdf5.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>

typedef struct {
    char *text;
    size_t n;
    int system; /* text is the system's message */
} cause_t;

static herr_t find_cause(unsigned k, const H5E_error2_t *e, void *data)
{
    cause_t *c = data;
    static const char key[] = "error message = '";
    const char *p = e->desc != NULL ? strstr(e->desc, key) : NULL;
    if (p != NULL) {
        p += sizeof key - 1;
        const char *q = strchr(p, '\'');
        snprintf(c->text, c->n, "%.*s", (int)(q != NULL ? q - p : (ptrdiff_t)strlen(p)), p);
        c->system = 1;
        return 1; /* found: stop */
    }
    if (k == 0 && e->desc != NULL) {
        snprintf(c->text, c->n, "%s", e->desc); /* the innermost, in case nothing says more */
    }
    return 0;
}

void h5_cause(int err, char *text, size_t n)
{
    if (n == 0) {
        return;
    }
    text[0] = '\0';
    cause_t c = {text, n, 0};
    H5Ewalk2(H5E_DEFAULT, H5E_WALK_UPWARD, find_cause, &c);
    if (!c.system && err != 0) {
        snprintf(text, n, "%s", strerror(err));
    }
}
