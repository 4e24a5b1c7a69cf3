/* kernel_single.c — the fused kernels with single-precision storage:
 * kernel.c compiled with KERNEL_SINGLE (names with _f32; see kernel.c). */
#define KERNEL_SINGLE 1
#include "kernel.c"
