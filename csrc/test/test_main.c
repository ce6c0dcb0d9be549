/*
 * Plain-C tests of rtcore. Built and run by tests/rtcore/test_c_driver.py, once with -O2
 * and once with -fsanitize=address,undefined. Exit status 0 when every check holds.
 */
#include "check.h"

int main(void)
{
    run_step_tests();
    run_loop_tests();
    run_supervisor_tests();
    run_tick_tests();
    run_sim_tests();
    printf("%d checks, %d failures\n", checks, failures);
    return failures == 0 ? 0 : 1;
}
