/* test_rigid_main.c — registers every rigid suite (rigid_tests.h). */
#include "rigid_tests.h"

void test_body_register(void);
void test_dynamics_register(void);
void test_connection_register(void);
void test_contact_register(void);
void test_topology_register(void);
void test_input_register(void);
void test_lubrication_register(void);
void test_walls_register(void);

void rigid_register_tests(void)
{
    test_body_register();
    test_dynamics_register();
    test_connection_register();
    test_contact_register();
    test_topology_register();
    test_input_register();
    test_lubrication_register();
    test_walls_register();
}
