/* run_tests.c — the one CUnit driver: registers every suite, runs them with
 * the basic interface and exits with the number of failures.
 * `run_tests --validate` adds the long validation suites; `run_tests SUITE
 * [TEST]` runs one suite or one test of it (names as printed). */
#include "common/scene_tests.h"
#include "fluid/fluid_tests.h"
#include "rigid/rigid_tests.h"

#include <CUnit/Basic.h>
#include <string.h>

int main(int argc, char **argv)
{
    int validate = 0;
    const char *only = NULL, *test = NULL;
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--validate") == 0) {
            validate = 1;
        } else if (only == NULL) {
            only = argv[i];
        } else {
            test = argv[i];
        }
    }
    if (CU_initialize_registry() != CUE_SUCCESS) {
        return 1;
    }
    fluid_register_tests(validate);
    scene_register_tests();
    scene_refused_register_tests();
    scene_bad_register_tests();
    exact_sum_register_tests();
    h5fields_register_tests();
    big_alloc_register_tests();
    fmi_vars_register_tests();
    rigid_register_tests();
    CU_basic_set_mode(CU_BRM_VERBOSE);
    if (only != NULL) {
        CU_pSuite s = CU_get_suite(only);
        if (s == NULL) {
            CU_cleanup_registry();
            return 1;
        }
        CU_pTest t = test != NULL ? CU_get_test(s, test) : NULL;
        if (test != NULL && t == NULL) {
            CU_cleanup_registry();
            return 1;
        }
        if (t != NULL) {
            CU_basic_run_test(s, t);
        } else {
            CU_basic_run_suite(s);
        }
    } else {
        CU_basic_run_tests();
    }
    const unsigned failures = CU_get_number_of_tests_failed() + CU_get_number_of_suites_failed();
    CU_cleanup_registry();
    return failures > 255 ? 255 : (int)failures;
}
