/* One sample period of a simulated finger: the valve's dead time and lag (held segments,
 * cut where the chamber crosses the dead zone's threshold) or the pneumatic valve model,
 * driving the finger's integration (rtcore_sim_plant.c). */
#include <math.h>

#include "rtcore_sim_internal.h"

/* A held segment, split where the chamber crosses the dead zone's threshold, so that the
 * torque is smooth within each part. */
static void integrate_held(const sim_plant *p, rtcore_sim_finger_state *s, rtcore_propagator_cache *cache,
                           double input_kpa, double duration_s, double request_cap_s)
{
    const double tau_s = p->finger->prbm.effects.valve_lag_tau_s;
    const double deadzone_kpa = p->finger->prbm.effects.pressure_deadzone_kpa;
    const double start_kpa = s->chamber_kpa;
    if (tau_s > 0.0 && deadzone_kpa > 0.0
        && ((start_kpa < deadzone_kpa && input_kpa > deadzone_kpa)
            || (start_kpa > deadzone_kpa && input_kpa < deadzone_kpa))) {
        const double cross_s = tau_s * log((start_kpa - input_kpa) / (deadzone_kpa - input_kpa));
        if (cross_s > 0.0 && cross_s < duration_s) {
            rtcore_sim_integrate_segment(p, s, cache, input_kpa, cross_s, request_cap_s);
            rtcore_sim_integrate_segment(p, s, cache, input_kpa, duration_s - cross_s, request_cap_s);
            return;
        }
    }
    rtcore_sim_integrate_segment(p, s, cache, input_kpa, duration_s, request_cap_s);
}

/* The valve regulates within its supply; a garbled (NaN) command vents to the floor. */
static double saturate(const rtcore_sim_finger *f, double command_kpa)
{
    if (isnan(command_kpa) || command_kpa < f->supply_min_kpa) {
        return f->supply_min_kpa;
    }
    return command_kpa > f->supply_max_kpa ? f->supply_max_kpa : command_kpa;
}

static double delayed_command(const rtcore_sim_finger_state *s, int32_t samples_back)
{
    return s->command_kpa[(s->head - samples_back + RTCORE_SIM_HISTORY) % RTCORE_SIM_HISTORY];
}

/* The pneumatic valve mode (rtcore_pneumatic.h): the chamber's physics and the board's
 * regulator replace the lag and the dead time. The period is cut into pieces of the
 * regulator's period; over each the finger is driven by the chamber's mean pressure there,
 * the chamber by the finger's volume at the piece's start. */
static void advance_pneumatic(const rtcore_sim_finger *f, rtcore_sim_finger_state *s, rtcore_propagator_cache *cache,
                              double command_kpa, double dt_s, double step_cap_s)
{
    rtcore_sim_finger held = *f;
    sim_plant plant;
    const double piece_s = (double)f->pneumatic.regulator_period_us * 1e-6;
    const int32_t pieces = (int32_t)ceil(dt_s / piece_s - 1e-9);
    int32_t k;
    held.prbm.effects.valve_lag_tau_s = 0.0; /* the segment's input is the chamber itself */
    rtcore_sim_plant_for(&held, &plant);
    for (k = 0; k < pieces; ++k) {
        const double mean_kpa = rtcore_pneumatic_advance(&f->pneumatic, f->prbm.pressure_gain_nm_per_kpa,
                                                         &s->pneumatic, command_kpa, s->angle_rad,
                                                         s->velocity_rad_per_s, dt_s / (double)pieces);
        rtcore_sim_integrate_segment(&plant, s, cache, mean_kpa, dt_s / (double)pieces, step_cap_s);
    }
    s->chamber_kpa = s->pneumatic.chamber_kpa;
    s->contact_force_n = rtcore_sim_contact_force_n(f, s->angle_rad, s->velocity_rad_per_s);
}

/* One sample period after pushing command_kpa: the dead time puts at most one breakpoint
 * inside the period, where the older command gives way to the newer one. The step is at
 * most dt/substeps (what the caller asks for) and what the finger's parameters allow
 * (more, up to dt/substeps, once the finger has settled: rtcore_sim_settled_step_s).
 * `plant` is rtcore_sim_plant_for(f): it depends on the finger alone, so a run over many
 * samples derives it once (rtcore_sim_run). */
void rtcore_sim_advance_sample(const sim_plant *plant, rtcore_sim_finger_state *s, rtcore_propagator_cache *cache,
                               double command_kpa, double dt_s, int32_t substeps)
{
    const rtcore_sim_finger *f = plant->finger;
    const double step_cap_s = dt_s / (double)substeps; /* the parameters' bound applies inside */
    if (f->pneumatic.valve_model == RTCORE_VALVE_PNEUMATIC) {
        advance_pneumatic(f, s, cache, command_kpa, dt_s, step_cap_s);
        return;
    }
    s->head = (s->head + 1) % RTCORE_SIM_HISTORY;
    s->command_kpa[s->head] = saturate(f, command_kpa);
    if (s->delay_fraction > 0.0) {
        const double first_s = s->delay_fraction * dt_s;
        integrate_held(plant, s, cache, delayed_command(s, s->delay_samples + 1), first_s, step_cap_s);
        integrate_held(plant, s, cache, delayed_command(s, s->delay_samples), dt_s - first_s, step_cap_s);
    } else {
        integrate_held(plant, s, cache, delayed_command(s, s->delay_samples), dt_s, step_cap_s);
    }
    s->contact_force_n = rtcore_sim_contact_force_n(f, s->angle_rad, s->velocity_rad_per_s);
}
