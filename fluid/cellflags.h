/* cellflags.h — the flags of the grid's cells, two cells to a byte.
 *
 * A cell's flags take four bits (fluid_internal.h CELL_*, spheres.h FLAG_*:
 * solid, ghost, and the sphere stage's own mark and fresh bits), so cell i
 * keeps them in the low (i even) or high (i odd) half of byte i / 2: half a
 * byte per cell instead of one, which brings the in-place grid in double to
 * 152.5 bytes per allocated cell (README "Speed and memory"). Two cells share
 * a byte, so writers of cells next to each other must not run at once,
 * except through cellflags_or_atomic (the spheres' mark, in parallel over
 * spheres); every other write is in a serial loop. */
#ifndef FLUID_CELLFLAGS_H
#define FLUID_CELLFLAGS_H

#include <stddef.h>
#include <stdint.h>

/* bytes for n cells */
static inline size_t cellflags_bytes(size_t n) { return (n + 1) / 2; }

static inline __attribute__((always_inline)) unsigned cellflags_get(const uint8_t *f, size_t i)
{
    return (unsigned)(f[i >> 1] >> ((i & 1) << 2)) & 0xFu;
}

static inline void cellflags_set(uint8_t *f, size_t i, unsigned v)
{
    const unsigned s = (unsigned)(i & 1) << 2;
    f[i >> 1] = (uint8_t)((f[i >> 1] & ~(0xFu << s)) | ((v & 0xFu) << s));
}

static inline void cellflags_or_atomic(uint8_t *f, size_t i, unsigned v)
{
    __atomic_fetch_or(&f[i >> 1], (uint8_t)((v & 0xFu) << ((i & 1) << 2)), __ATOMIC_RELAXED);
}

#endif
