/* Pressure limits (saturation, then rate limit) and the anti-windup decision. */
#include <math.h>

#include "rtcore_internal.h"

/* Saturate unsat_kpa to [min, max], then move at most rate*dt from previous_kpa.
 * Conditional integration: when the command was limited in the direction the error
 * pushes it, the integrator keeps its old value (flag INTEGRATOR_HELD); otherwise it
 * takes the new one. The integrator is finally clamped to +-integrator_limit_kpa. */
rtcore_limited rtcore_limit_command(const rtcore_finger_config *c, double unsat_kpa,
                                    double previous_kpa, double dt_s, double error,
                                    double integrator_old_kpa, double integrator_new_kpa)
{
    rtcore_limited r;
    const double step_kpa = c->pressure_rate_max_kpa_per_s * dt_s;
    const double lowest_kpa = previous_kpa - step_kpa;
    const double highest_kpa = previous_kpa + step_kpa;
    double command = unsat_kpa;
    double integrator = integrator_new_kpa;

    r.flags = 0u;
    if (command > c->pressure_max_kpa) {
        command = c->pressure_max_kpa;
        r.flags |= (uint32_t)RTCORE_FLAG_SATURATED;
    } else if (command < c->pressure_min_kpa) {
        command = c->pressure_min_kpa;
        r.flags |= (uint32_t)RTCORE_FLAG_SATURATED;
    }
    if (command > highest_kpa) {
        command = highest_kpa;
        r.flags |= (uint32_t)RTCORE_FLAG_RATE_LIMITED;
    } else if (command < lowest_kpa) {
        command = lowest_kpa;
        r.flags |= (uint32_t)RTCORE_FLAG_RATE_LIMITED;
    }
    if ((unsat_kpa > command && error > 0.0) || (unsat_kpa < command && error < 0.0)) {
        integrator = integrator_old_kpa;
        r.flags |= (uint32_t)RTCORE_FLAG_INTEGRATOR_HELD;
    }
    if (integrator > c->integrator_limit_kpa) {
        integrator = c->integrator_limit_kpa;
    } else if (integrator < -c->integrator_limit_kpa) {
        integrator = -c->integrator_limit_kpa;
    }
    r.command_kpa = command;
    r.integrator_kpa = integrator;
    return r;
}
