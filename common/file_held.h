/* file_held.h — whether another process holds a file open under a lock.
 *
 * HDF5 takes a lock (flock) on every file it opens, unless
 * HDF5_USE_FILE_LOCKING=FALSE; its create with H5F_ACC_TRUNC opens the file
 * with O_TRUNC first and fails on the lock only after that, so an output
 * held open by another process (a viewer, the ranks of a killed mpirun)
 * would be emptied by a run that then stops. The writers ask first. */
#ifndef COMMON_FILE_HELD_H
#define COMMON_FILE_HELD_H

/* 1 when path exists and another process holds a lock on it; 0 otherwise
 * (no such file, or free: the test's own lock is released at once). */
int file_held(const char *path);

#endif
