/* fluid_tests.h — registration of the fluid component's CUnit suites. */
#ifndef TESTS_FLUID_TESTS_H
#define TESTS_FLUID_TESTS_H

void fluid_register_tests(int validate);
void lattice_register_tests(void);
void boundary_register_tests(void);
void kernel_register_tests(void);
void layouts_register_tests(void);
void moments_register_tests(void);
void schedules_register_tests(void);
void flows_register_tests(int validate);
void spheres_register_tests(int validate);
void sphere_motion_register_tests(void);
void approach_register_tests(int validate);

#endif
