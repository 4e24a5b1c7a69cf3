/* check_ranks.h — the MPI part of `coupler check`: the blocks of N ranks. */
#ifndef COUPLER_CHECK_RANKS_H
#define COUPLER_CHECK_RANKS_H

#include "../common/scene.h"
#include "../common/status.h"

/* Prints the decomposition of a grid of N cells over `world` ranks as the
 * fluid would lay it out (fluid/decomp.h decomp_layout, for every rank):
 * dims, each rank's block, its memory and the halo bytes it sends per step,
 * and totals (its warnings go to log, whose sink counts them). Returns STATUS_ERROR
 * (logged, with decomp_layout's message) when the grid cannot be cut so.
 * With world > 1 MPI must be initialised (MPI_Dims_create). */
status_t check_ranks(const scene_t *s, const int N[3], int world, const log_t *log);

#endif
