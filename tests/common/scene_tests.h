/* scene_tests.h — CUnit suites for common/scene.c (the scene reader). */
#ifndef TESTS_COMMON_SCENE_TESTS_H
#define TESTS_COMMON_SCENE_TESTS_H

/* Adds the "scene" suites to the current CUnit registry. The caller has
 * called CU_initialize_registry; errors are left in CU_get_error(). */
void scene_register_tests(void);

#endif
