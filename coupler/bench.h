/* bench.h — `coupler bench`: fluid kernel MLUPS against memory bandwidth. */
#ifndef COUPLER_BENCH_H
#define COUPLER_BENCH_H

/* sizes: cubic grid edges; nsizes 0 means 128. json: one object per line. */
int bench_main(const int *sizes, int nsizes, int json);
/* The whole wall time of `coupler run SCENE --steps N` with the scene's bodies
 * and without them (bodies=[], connections=[]), best of three each, and the ratio:
 * the cost of the particles. */
int bench_coupled(const char *scene, long steps, const char *lib_dir, int json);

#endif
