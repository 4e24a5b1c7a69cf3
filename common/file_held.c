/* file_held.c — file_held.h. */
#define _DEFAULT_SOURCE /* flock */
#include "file_held.h"

#include <errno.h>
#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

int file_held(const char *path)
{
    const int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0) {
        return 0;
    }
    /* exclusive, as a writer's: refused while anyone holds a lock (HDF5's
     * readers hold a shared one) */
    const int held = flock(fd, LOCK_EX | LOCK_NB) != 0 && errno == EWOULDBLOCK;
    close(fd); /* and with it the lock, if it was taken */
    return held;
}
