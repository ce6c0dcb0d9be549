/*
 * rtcore_sim: the simulated hand (csrc/rtcore_sim*.c) and the simulated link that runs it
 * beside the supervisor's tick in the same process (csrc/rtcore_sim_link.c).
 *
 * The PRBM of every finger with the same torque model and effects as the controller: its
 * linear part (A, B, k) integrated exactly whatever the step, the rest of the torque (the
 * effects, the object) by ETDRK4, in steps of at most sample_period/substeps and of what
 * those terms and the valve lag need (csrc/rtcore_sim_step_size.c); the plain linear finger takes
 * one step per sample at any stiffness. The valve is a first-order lag (the fill's, or the
 * vent's while the chamber falls: rtcore_valve_tau_s) behind a dead time,
 * integrated exactly (the dead time's breakpoints split the period), or, for a finger whose
 * pneumatic.valve_model asks for it, the valve board's pneumatics (rtcore_pneumatic.h); an
 * optional object is a spring-damper at the force point, an optional hysteresis a Dahl
 * loop in the angle; the flex sensor reads the angle through the inverse
 * calibration with noise and ADC quantisation.
 *
 * The block between the CDEF markers is read verbatim by rtcore/_build.py (with the
 * other headers' blocks, in the order listed there) and handed to cffi: keep it to
 * plain declarations and integer #defines.
 */
#ifndef RTCORE_SIM_H
#define RTCORE_SIM_H

#include <stdint.h>

#include "rtcore_pneumatic.h"
#include "rtcore_sim_plant.h"
#include "rtcore_step.h"

#ifdef __cplusplus
extern "C" {
#endif

/* BEGIN CDEF */
#define RTCORE_SIM_HISTORY 1024
#define RTCORE_ERR_SIM_HISTORY -13

typedef struct {
    int32_t n_fingers;
    double sample_rate_hz;
    int32_t substeps;
    uint64_t seed;
    rtcore_sim_finger finger[RTCORE_MAX_FINGERS];
} rtcore_sim_config;

typedef struct {
    rtcore_sim_motion motion; /* the finger's dynamics (rtcore_sim_plant.h) */
    double contact_force_n;
    /* commands of the last samples, newest at head, for the dead time */
    double command_kpa[RTCORE_SIM_HISTORY];
    int32_t head;
    int32_t delay_samples;
    double delay_fraction;
    rtcore_pneumatic_state pneumatic; /* the pneumatic valve mode's chamber and regulator */
} rtcore_sim_finger_state;

typedef struct {
    rtcore_sim_config config;
    rtcore_sim_finger_state finger[RTCORE_MAX_FINGERS];
    double dt_s;
    double time_s;
    uint64_t rng_state;
    double rng_spare;
    int32_t rng_has_spare;
    int32_t configured;
    int32_t error_finger;
} rtcore_sim;

typedef struct {
    double sensor_mv[RTCORE_MAX_FINGERS];
    double pressure_meas_kpa[RTCORE_MAX_FINGERS];
    double angle_deg[RTCORE_MAX_FINGERS];
    double velocity_deg_per_s[RTCORE_MAX_FINGERS];
    double chamber_pressure_kpa[RTCORE_MAX_FINGERS];
    double contact_force_n[RTCORE_MAX_FINGERS];
} rtcore_sim_outputs;

/* Validate and apply a configuration; every finger at rest, vented. */
int32_t rtcore_sim_configure(rtcore_sim *sim, const rtcore_sim_config *config);
/* Place a finger (e.g. a pushed tip before release); the valve history is filled with
 * chamber_kpa, as if it had been commanded for ever. */
void rtcore_sim_set_state(rtcore_sim *sim, int32_t finger, double angle_deg,
                          double velocity_deg_per_s, double chamber_kpa);
/* Read the sensors now, without advancing time. */
void rtcore_sim_sample(rtcore_sim *sim, rtcore_sim_outputs *out);
/* Hold pressure_cmd_kpa[i] for one sample period, then read the sensors. */
void rtcore_sim_step(rtcore_sim *sim, const double *pressure_cmd_kpa, rtcore_sim_outputs *out);
/* Noise-free batch run of one finger, for fitting: angle_out_deg[0] = angle0_deg and
 * angle_out_deg[k+1] follows command k. chamber_out_kpa may be NULL. substeps >= 1: steps
 * of at most a sample period / substeps; 0: the steps the dynamics need, and over a run of
 * samples that hold one valve input, steps of several periods (csrc/rtcore_sim_span.c).
 * Returns RTCORE_OK or a negative RTCORE_ERR_*. */
int32_t rtcore_sim_run(const rtcore_sim_finger *finger, double sample_rate_hz, int32_t substeps,
                       int32_t n_samples, const double *pressure_cmd_kpa, double angle0_deg,
                       double velocity0_deg_per_s, double chamber0_kpa, double *angle_out_deg,
                       double *chamber_out_kpa);

/* The simulated hand as a link in the same process: it samples once per command it holds
 * for a sample period, and lives through the deadlines the host skipped holding the last
 * command (hand_service/transports/sim.py). Counters as a bus link has them. A sent
 * command's period is simulated later, by rtcore_sim_link_advance: in the host's slack
 * after the tick, as a board's firmware runs beside the host, or at the latest when the
 * next sample or command needs it. Either way the hand's time and samples are the same. */
typedef struct {
    rtcore_sim *sim;
    rtcore_sim_outputs *out;
    double *command_kpa; /* the command the simulated valves hold */
    int32_t open;
    int32_t fresh; /* a sample not yet taken */
    int32_t pending; /* a sent command whose sample period is not simulated yet */
    int32_t has_tick;
    int64_t last_tick_index;
    int64_t sequence; /* samples taken */
    int64_t frames_in;
    int64_t frames_out;
} rtcore_sim_link;

/* Simulate the period of the command sent last, if that is still to do. */
void rtcore_sim_link_advance(rtcore_sim_link *link);
/* The host's tick tick_index is about to read: the deadlines it skipped since the last
 * one pass for the hand, each a sample period holding the last command. */
void rtcore_sim_link_on_tick(rtcore_sim_link *link, int64_t tick_index);
/* The newest sample into sensor_mv and pressure_meas_kpa if there is one not taken: 1, else 0. */
int32_t rtcore_sim_link_latest(rtcore_sim_link *link, double *sensor_mv, double *pressure_meas_kpa);
/* Hold pressure_cmd_kpa for the next sample period (nothing when closed). */
void rtcore_sim_link_send(rtcore_sim_link *link, const double *pressure_cmd_kpa);
/* END CDEF */

#ifdef __cplusplus
}
#endif

#endif /* RTCORE_SIM_H */
