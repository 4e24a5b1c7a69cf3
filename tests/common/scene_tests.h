/* scene_tests.h — CUnit suites for common/scene.c (the scene reader). */
#ifndef TESTS_COMMON_SCENE_TESTS_H
#define TESTS_COMMON_SCENE_TESTS_H

/* Adds the "scene: valid input" suite to the current CUnit registry. The caller has
 * called CU_initialize_registry; errors are left in CU_get_error(). */
void scene_register_tests(void);
/* Adds the suite of bad input (test_scene_refused.c). */
void scene_refused_register_tests(void);
/* Adds the table of bad scenes (test_scene_bad.c). */
void scene_bad_register_tests(void);

/* Adds the "exact_sum" suite (test_exact_sum.c: common/exact_sum.h). */
void exact_sum_register_tests(void);
/* Adds the "h5fields" suite (test_h5fields.c: common/h5fields.c in a host that uses HDF5). */
void h5fields_register_tests(void);
/* Adds the "big_alloc" suite (test_big_alloc.c: common/big_alloc.h). */
void big_alloc_register_tests(void);
/* Adds the "fmi_vars" suite (test_fmi_vars.c: the FMUs' variable lists). */
void fmi_vars_register_tests(void);

/* The base scene of the scene tests (26 lines, loads with STATUS_OK). */
extern const char scene_test_base[];

#endif
