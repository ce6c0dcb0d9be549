/* One sample period of a simulated finger (rtcore_sim_advance.h): the valve's dead time
 * (held segments, which the finger's dynamics integrate with the valve's lag:
 * rtcore_sim_plant.c) or the pneumatic valve model. */
#include <math.h>

#include "rtcore_internal.h"
#include "rtcore_sim_advance.h"
#include "rtcore_sim_internal.h"

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

/* the command pushed at this sample into the dead time's history, saturated */
static void push_command(const rtcore_sim_finger *f, rtcore_sim_finger_state *s, double command_kpa)
{
    s->head = (s->head + 1) % RTCORE_SIM_HISTORY;
    s->command_kpa[s->head] = saturate(f, command_kpa);
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
    held.prbm.effects.valve_vent_tau_s = 0.0;
    rtcore_sim_plant_for(&held, &plant);
    for (k = 0; k < pieces; ++k) {
        const double mean_kpa = rtcore_pneumatic_advance(&f->pneumatic, f->prbm.pressure_gain_nm_per_kpa,
                                                         &s->pneumatic, command_kpa, s->motion.angle_rad,
                                                         s->motion.velocity_rad_per_s, dt_s / (double)pieces);
        rtcore_sim_integrate_held(&plant, &s->motion, cache, mean_kpa, 0.0, dt_s / (double)pieces, step_cap_s, 0);
    }
    s->motion.chamber_kpa = s->pneumatic.chamber_kpa;
    s->contact_force_n = rtcore_sim_contact_force_n(f, s->motion.angle_rad, s->motion.velocity_rad_per_s);
}

/* One sample period after pushing command_kpa: the dead time puts at most one breakpoint
 * inside the period, where the older command gives way to the newer one. The step is at
 * most dt/substeps (what the caller asks for) and what the finger's parameters allow
 * (more, up to dt/substeps, once the finger has settled, rtcore_sim_settled_step_s, or
 * while dry friction holds it: rtcore_sim_plant.c).
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
    push_command(f, s, command_kpa);
    if (s->delay_fraction > 0.0) {
        const double first_s = s->delay_fraction * dt_s;
        rtcore_sim_integrate_held(plant, &s->motion, cache, delayed_command(s, s->delay_samples + 1), 0.0, first_s,
                                  step_cap_s, 0);
        rtcore_sim_integrate_held(plant, &s->motion, cache, delayed_command(s, s->delay_samples), 0.0, dt_s - first_s,
                                  step_cap_s, 0);
    } else {
        rtcore_sim_integrate_held(plant, &s->motion, cache, delayed_command(s, s->delay_samples), 0.0, dt_s,
                                  step_cap_s, 0);
    }
    s->contact_force_n = rtcore_sim_contact_force_n(f, s->motion.angle_rad, s->motion.velocity_rad_per_s);
}

/* The command held over sample i from now (the valve's input after the dead time): the
 * i-th of command_kpa, saturated, for i >= 0, and the history's before. */
static double held_command(const rtcore_sim_finger *f, const rtcore_sim_finger_state *s, const double *command_kpa,
                           int32_t i)
{
    return i >= 0 ? saturate(f, command_kpa[i]) : delayed_command(s, -1 - i);
}

/* How many of the next `available` sample periods (command_kpa[0] the one pushed now)
 * hold one and the same valve input throughout, dead time's breakpoint included, and that
 * input: 0 when fewer than two do (a command that changes every sample costs two reads). */
int32_t rtcore_sim_held_samples(const rtcore_sim_finger *f, const rtcore_sim_finger_state *s, const double *command_kpa,
                                int32_t available, double *held_kpa)
{
    const int32_t d = s->delay_samples;
    double input_kpa;
    int32_t count = 2;
    if (available < 2) { /* (a pneumatic valve is never in a span: rtcore_sim_span_eligible) */
        return 0;
    }
    input_kpa = held_command(f, s, command_kpa, -d);
    if (held_command(f, s, command_kpa, 1 - d) != input_kpa
        || (s->delay_fraction > 0.0 && held_command(f, s, command_kpa, -d - 1) != input_kpa)) {
        return 0;
    }
    while (count < available && held_command(f, s, command_kpa, count - d) == input_kpa) {
        ++count;
    }
    *held_kpa = input_kpa;
    return count;
}

/* `count` sample periods under the one input held_kpa (rtcore_sim_held_samples), as one
 * segment (rtcore_sim_span.c): the angle at each sample into span's angle_out_deg, the
 * chamber's into chamber_out_kpa (may be NULL). */
void rtcore_sim_advance_span(const sim_plant *plant, rtcore_sim_finger_state *s, rtcore_propagator_cache *cache,
                             sim_span *span, const double *command_kpa, int32_t count, double held_kpa,
                             double *chamber_out_kpa)
{
    const rtcore_sim_finger *f = plant->finger;
    const double chamber0_kpa = s->motion.chamber_kpa;
    const double tau_s = rtcore_valve_tau_s(&f->prbm.effects, held_kpa - chamber0_kpa);
    int32_t i;
    for (i = 0; i < count; ++i) {
        push_command(f, s, command_kpa[i]);
    }
    span->count = count;
    span->next = 1;
    span->t0_s = 0.0;
    rtcore_sim_integrate_held(plant, &s->motion, cache, held_kpa, 0.0, (double)count * span->dt_s,
                              rtcore_sim_span_cap_s(plant, span->dt_s), span);
    for (i = span->next; i <= count; ++i) { /* none but after a divergence: the state it left */
        span->angle_out_deg[i - 1] = s->motion.angle_rad * RTCORE_DEG_PER_RAD;
    }
    if (chamber_out_kpa != 0) {
        for (i = 1; i <= count; ++i) {
            const double t_s = (double)i * span->dt_s;
            chamber_out_kpa[i - 1] = tau_s > 0.0 ? rtcore_sim_chamber_at(chamber0_kpa, held_kpa, tau_s, t_s) : held_kpa;
        }
    }
    s->contact_force_n = rtcore_sim_contact_force_n(f, s->motion.angle_rad, s->motion.velocity_rad_per_s);
}
