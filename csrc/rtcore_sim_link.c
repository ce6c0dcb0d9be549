/* The simulated hand as a link in the same process (rtcore_sim.h): the sample it takes
 * once per command it holds for a sample period, the deadlines the host skipped, and the
 * period of a sent command simulated later, in the host's slack. rtcore_tick_sim
 * (csrc/rtcore_tick.c) runs a whole tick on it. */

#include "rtcore_sim.h"

void rtcore_sim_link_advance(rtcore_sim_link *link)
{
    if (link == 0 || link->sim == 0 || link->command_kpa == 0 || !link->pending) {
        return;
    }
    link->pending = 0;
    rtcore_sim_step(link->sim, link->command_kpa, link->out);
    link->fresh = 1;
}

void rtcore_sim_link_on_tick(rtcore_sim_link *link, int64_t tick_index)
{
    int64_t last;
    int64_t k;
    int32_t had;
    if (link == 0) {
        return;
    }
    rtcore_sim_link_advance(link);
    last = link->last_tick_index;
    had = link->has_tick;
    link->last_tick_index = tick_index;
    link->has_tick = 1;
    if (!link->open || !had || tick_index <= last + 1 || link->sim == 0 || link->command_kpa == 0) {
        return;
    }
    for (k = last + 1; k < tick_index; ++k) {
        rtcore_sim_step(link->sim, link->command_kpa, link->out);
    }
    link->fresh = 1;
}

int32_t rtcore_sim_link_latest(rtcore_sim_link *link, double *sensor_mv, double *pressure_meas_kpa)
{
    int32_t i;
    rtcore_sim_link_advance(link);
    if (link == 0 || link->out == 0 || link->sim == 0 || !link->open || !link->fresh || sensor_mv == 0
        || pressure_meas_kpa == 0) {
        return 0;
    }
    link->fresh = 0;
    link->frames_in += 1;
    link->sequence += 1;
    for (i = 0; i < link->sim->config.n_fingers && i < RTCORE_MAX_FINGERS; ++i) {
        sensor_mv[i] = link->out->sensor_mv[i];
        pressure_meas_kpa[i] = link->out->pressure_meas_kpa[i];
    }
    return 1;
}

void rtcore_sim_link_send(rtcore_sim_link *link, const double *pressure_cmd_kpa)
{
    int32_t i;
    if (link == 0 || link->sim == 0 || link->command_kpa == 0 || !link->open || pressure_cmd_kpa == 0) {
        return;
    }
    rtcore_sim_link_advance(link); /* a period still pending is the last command's */
    for (i = 0; i < link->sim->config.n_fingers && i < RTCORE_MAX_FINGERS; ++i) {
        link->command_kpa[i] = pressure_cmd_kpa[i];
    }
    link->frames_out += 1;
    link->pending = 1;
}
