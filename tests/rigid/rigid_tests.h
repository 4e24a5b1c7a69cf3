/* rigid_tests.h — registration of the rigid component's CUnit suites. */
#ifndef TESTS_RIGID_TESTS_H
#define TESTS_RIGID_TESTS_H

/* Adds every rigid suite to the current CUnit registry. */
void rigid_register_tests(void);

#endif
