/* decomp.h — the fluid's block of the grid when it runs on several MPI ranks
 * (README "MPI"; issue 13).
 *
 * The global grid of N[0] x N[1] x N[2] cells is cut into dims[0] x dims[1]
 * x dims[2] blocks along a Cartesian communicator (MPI_Dims_create, or the
 * scene's run.ranks); block sizes differ by at most one cell per axis. Each
 * rank holds its block with the usual single ghost layer (grid.h). A face of
 * the block is either a face of the domain (walls.c builds its links; a
 * periodic face with one rank along its axis is the local ghost-layer copy)
 * or an exchange face: the neighbour's populations that cross it arrive by
 * decomp_exchange, which is the periodic copy of walls.c with the other side
 * on another rank (5 populations per face cell, none for corners).
 *
 * MPI is used only when the process's master initialised it (the coupler
 * does when started by mpirun) and the world has more than one rank;
 * otherwise (an FMU under fmpy, the tests) the fluid is one block and no MPI
 * function is called. Every collective here is called by all ranks in the
 * same order; a rank never leaves a step early while others continue
 * (decomp_agree). */
#ifndef FLUID_DECOMP_H
#define FLUID_DECOMP_H

#include "../common/exact_sum.h"
#include "../common/scene.h"
#include "../common/status.h"
#include "grid.h"
#include "layout.h"

#include <stddef.h>

/* Fewest cells of a block along a cut axis: the boundary schemes and the
 * refill of spheres reach two cells beyond a block face, and those two
 * layers of the blocks before and after a block must not be the same cells
 * (a periodic axis cut in two). */
enum { DECOMP_MIN_CELLS = 4 };

typedef struct {
    int size, rank;        /* 1 and 0 without MPI */
    int dims[3], coords[3];
    int N[3];              /* global interior cells */
    int lo[3], n[3];       /* this block: global cells lo .. lo + n - 1 (0-based) */
    int nbr[3][2];         /* rank across face (axis, side) by exchange; -1: a face of the domain */
    int periodic[3];       /* periodic axes of the domain */
    void *comm;            /* MPI_Comm * (the Cartesian one) or NULL */
    unsigned char *buf;    /* send and receive buffers of one axis (4 x xbytes_max, from decomp_init) */
    size_t cap, xbytes_max;
    void *req;             /* MPI_Request[4] of the exchange in flight */
    int xnreq, xa;         /* its requests and axis */
    int xlo[3], xhi[3];    /* its cells */
    size_t xbytes;         /* its bytes per message */
    double halo_bytes;     /* bytes this rank sends per step */
    double halo_seconds;   /* wall time in the exchanges so far (packing, waiting, unpacking) */
} decomp_t;

/* The block of this rank for a grid of N cells; errors name the scene file
 * and run.ranks. */
status_t decomp_init(decomp_t *d, const scene_t *s, const int N[3], const log_t *log);
void decomp_free(decomp_t *d);
/* The blocks of `world` ranks without a communicator, for rank `rank`: what
 * decomp_init sets up (for `coupler check --ranks N`). With world > 1 MPI
 * must be initialised (MPI_Dims_create). */
status_t decomp_layout(decomp_t *d, const scene_t *s, const int N[3], int world, int rank, const log_t *log);
/* The cells over which the ghost layers of axis a are copied, for a grid of
 * n interior cells (allocated coordinates): the ghost rows of the axes done
 * before a, and, for an exchange with other ranks, of the domain's walls
 * too (walls.c walls_halo_begin, decomp_exchange_begin, the halo bytes of
 * decomp_layout). */
void decomp_exchange_range(const decomp_t *d, const int n[3], int a, int lo[3], int hi[3]);
/* The block of the rank at coords: global first cell and cells. */
void decomp_block(const decomp_t *d, const int coords[3], int lo[3], int n[3]);
/* The rank at coords (wrapped on periodic axes), -1 beyond a domain face. */
int decomp_rank_at(const decomp_t *d, const int coords[3]);

static inline int decomp_parallel(const decomp_t *d) { return d->comm != NULL; }
/* 1 when face (axis a, side) of the block is filled by the exchange. */
static inline int decomp_exchanged(const decomp_t *d, int a, int side) { return d->nbr[a][side] >= 0; }

/* Exchange of axis a over the cells lo..hi (allocated coordinates, ghosts of
 * the axes done before included: walls.c walls_halo_begin): the populations
 * that cross the faces of a, in the layout state of p. In two halves, so
 * that the update of the inner cells runs while the messages travel
 * (fluid.c): begin packs the outgoing values and posts the messages,
 * progress lets MPI move them on, end waits and unpacks. One axis at a
 * time; the populations the exchange reads and writes must not change in
 * between (the outer layers and the ghost layer). */
void decomp_exchange_begin(decomp_t *d, const grid_t *g, const pops_t *p, int a, const int lo[3], const int hi[3]);
void decomp_exchange_progress(decomp_t *d);
void decomp_exchange_end(decomp_t *d, const grid_t *g, const pops_t *p);

/* Collectives (identity without MPI). */
status_t decomp_agree(const decomp_t *d, status_t st);         /* the worst status of all ranks */
void decomp_sum(const decomp_t *d, xsum_t *s, int count);       /* exact sums over ranks, in place */
void decomp_max(const decomp_t *d, double *v, int count);       /* maxima over ranks, in place */
void decomp_bcast(const decomp_t *d, void *buf, size_t bytes);  /* from rank 0 */
/* Rank `root`'s text to every rank (buf of cap bytes, NUL-terminated). */
void decomp_bcast_text(const decomp_t *d, char *buf, size_t cap, int root);

#endif
