/* h5_cause.h — why the HDF5 call just made failed, in words, for the
 * messages of the writers (the field snapshots, the coupler's output and its
 * checkpoints): a full disk should say "No space left on device", not only
 * "HDF5 error". */
#ifndef COMMON_H5_CAUSE_H
#define COMMON_H5_CAUSE_H

#include <stddef.h>

/* The cause of the error on HDF5's stack into text (n bytes; "" when the
 * stack says nothing): the system's message its file driver recorded (sec2:
 * "..., errno = 28, error message = 'No space left on device', ..."), else
 * err's (errno after a call that writes to the file, cleared before it; 0
 * for none: the MPI-IO driver records no system message, but its failed
 * write leaves errno set), else the innermost description. Call it at once
 * after the failed call: the next HDF5 call clears the stack. */
void h5_cause(int err, char *text, size_t n);

#endif
