/* bench.h — `coupler bench`: fluid kernel MLUPS against memory bandwidth. */
#ifndef COUPLER_BENCH_H
#define COUPLER_BENCH_H

/* sizes: cubic grid edges; nsizes 0 means 128. json: one object per line. */
int bench_main(const int *sizes, int nsizes, int json);

#endif
