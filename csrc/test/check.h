/* Shared by the plain-C tests of rtcore (csrc/test/): the CHECK counter, a seeded
 * random source, and the index finger of docs/physics.md with a linear sensor. */
#ifndef RTCORE_TEST_CHECK_H
#define RTCORE_TEST_CHECK_H

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "../rtcore.h"

extern int failures;
extern int checks;

#define CHECK(cond, ...)                                                  \
    do {                                                                  \
        ++checks;                                                         \
        if (!(cond)) {                                                    \
            ++failures;                                                   \
            fprintf(stderr, "FAIL %s:%d: %s: ", __FILE__, __LINE__, #cond); \
            fprintf(stderr, __VA_ARGS__);                                 \
            fprintf(stderr, "\n");                                        \
        }                                                                 \
    } while (0)

#define PI 3.14159265358979323846

double uniform(uint64_t *s);
rtcore_finger_config index_finger(void);
rtcore_hand_config one_finger(void);
void clear_inputs(rtcore_inputs *in);
double mv_for_deg(const rtcore_finger_config *c, double deg);

/* each file's tests */
void run_step_tests(void);
void run_loop_tests(void);
void run_supervisor_tests(void);
void run_tick_tests(void);
void run_sim_tests(void);

#endif
