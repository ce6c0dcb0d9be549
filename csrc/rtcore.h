/*
 * rtcore: the 100 Hz control step for a pneumatic soft hand (1 to 8 fingers).
 *
 * One call, rtcore_hand_step(), runs for every finger:
 *   sensor mV -> deg (linear calibration) -> Butterworth low-pass (order 2 or 4)
 *   -> filtered velocity and acceleration -> feedforward (PRBM model inversion)
 *   + PID (position) or PI on the signed normal force (force)
 *   -> saturation and rate limit -> pressure command, and the Moore-Penrose
 *   force estimate.
 *
 * Rules: C99, every piece of state in caller-allocated structs, no heap, no mutable
 * globals, no callbacks. Every exported symbol starts with rtcore_ (glibc exports a
 * legacy step() of its own). Physical quantities carry their unit in their name.
 *
 * The block between the CDEF markers is read verbatim by rtcore/_build.py and handed
 * to cffi, so the Python binding can never drift from this header: keep that block to
 * plain declarations and integer #defines.
 */
#ifndef RTCORE_H
#define RTCORE_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* BEGIN CDEF */
#define RTCORE_MAX_FINGERS 8
#define RTCORE_MAX_SECTIONS 2
/* Inputs (mV after calibration, references, pressures) beyond this magnitude are
 * implausible for any finger and are rejected, so no arithmetic downstream overflows. */
#define RTCORE_SANE_LIMIT 1000000

/* Finger modes (rtcore_inputs.mode). */
#define RTCORE_MODE_VENT 0
#define RTCORE_MODE_PRESSURE 1
#define RTCORE_MODE_POSITION 2
#define RTCORE_MODE_FORCE 3

/* Feedforward kinds (rtcore_finger_config.feedforward). */
#define RTCORE_FF_NONE 0
#define RTCORE_FF_QUASI_STATIC 1
#define RTCORE_FF_DYNAMIC 2

/* Status flags (rtcore_outputs.flags), one bit each. */
#define RTCORE_FLAG_SATURATED 1
#define RTCORE_FLAG_RATE_LIMITED 2
#define RTCORE_FLAG_SENSOR_REJECTED 4
#define RTCORE_FLAG_REFERENCE_REJECTED 8
#define RTCORE_FLAG_INTEGRATOR_HELD 16
#define RTCORE_FLAG_MODE_REJECTED 32
#define RTCORE_FLAG_OUTPUT_REJECTED 64
#define RTCORE_FLAG_NOT_CONFIGURED 128
#define RTCORE_FLAG_MODE_CHANGED 256

/* Return codes of rtcore_hand_configure() and rtcore_butter_design(). */
#define RTCORE_OK 0
#define RTCORE_ERR_NULL -1
#define RTCORE_ERR_FINGER_COUNT -2
#define RTCORE_ERR_SAMPLE_RATE -3
#define RTCORE_ERR_FILTER_ORDER -4
#define RTCORE_ERR_FILTER_CUTOFF -5
#define RTCORE_ERR_VELOCITY_CUTOFF -6
#define RTCORE_ERR_SENSOR -7
#define RTCORE_ERR_MODEL -8
#define RTCORE_ERR_GAINS -9
#define RTCORE_ERR_PRESSURE_LIMITS -10
#define RTCORE_ERR_EFFECTS -11
#define RTCORE_ERR_FEEDFORWARD -12

/*
 * Physics the model includes beyond the plain PRBM (physics.md, formats.md
 * "effects"). A zero leaves an effect out; asymmetric_stiffness_ratio = 1 is symmetric.
 * The extra torque is
 *   tau(theta, omega) = k_eff(theta)*theta + k3*theta^3 + c2*|omega|*omega
 *                       + Tc*tanh(omega/omega_s) + G*(1 - cos theta)
 * with k_eff = k for theta >= 0 and k*ratio for theta < 0. The chamber pressure acts
 * only above the dead zone: M = N*max(p - p0, 0). Valve lag and dead time are
 * compensated in the position feedforward by a first-order lead of (tau + delay).
 */
typedef struct {
    double valve_lag_tau_s;
    double dead_time_s;
    double coulomb_torque_nm;
    double coulomb_smoothing_deg_per_s;
    double cubic_stiffness_nm_per_rad3;
    double gravity_torque_nm;
    double asymmetric_stiffness_ratio;
    double quadratic_damping_nms2_per_rad2;
    double pressure_deadzone_kpa;
} rtcore_effects;

typedef struct {
    /* sensor: angle_deg = sensor_gain_deg_per_mv * mv + sensor_offset_deg */
    double sensor_gain_deg_per_mv;
    double sensor_offset_deg;
    /* Butterworth low-pass on the calibrated angle */
    int32_t filter_order;
    double filter_cutoff_hz;
    /* first-order low-pass on the differences that give velocity and acceleration */
    double velocity_cutoff_hz;
    /* PRBM: A th'' + B th' + k th = N p - J^T F */
    double inertia_kgm2;
    double damping_nms_per_rad;
    double stiffness_nm_per_rad;
    double pressure_gain_nm_per_kpa;
    double lever_arm_m;
    rtcore_effects effects;
    int32_t feedforward;
    int32_t force_estimate_dynamic;
    /* position PID on the filtered angle (error in deg, output in kPa) */
    double kp_kpa_per_deg;
    double ki_kpa_per_deg_s;
    double kd_kpa_s_per_deg;
    double derivative_cutoff_hz;
    double integrator_limit_kpa;
    /* force PI on the signed normal force (error in N, output in kPa) */
    double force_kp_kpa_per_n;
    double force_ki_kpa_per_n_s;
    /* pressure command limits */
    double pressure_min_kpa;
    double pressure_max_kpa;
    double pressure_rate_max_kpa_per_s;
} rtcore_finger_config;

typedef struct {
    int32_t n_fingers;
    double sample_rate_hz;
    rtcore_finger_config finger[RTCORE_MAX_FINGERS];
} rtcore_hand_config;

/* One second-order section in direct form II transposed. a0 is 1. */
typedef struct {
    double b0;
    double b1;
    double b2;
    double a1;
    double a2;
    double z1;
    double z2;
} rtcore_biquad;

typedef struct {
    /* derived at configure time */
    rtcore_biquad section[RTCORE_MAX_SECTIONS];
    int32_t n_sections;
    double velocity_alpha;
    double derivative_alpha;
    double chamber_alpha;
    double rest_mv;
    /* running state */
    int32_t filter_primed;
    int32_t mode;
    double last_good_mv;
    double angle_filt_deg;
    double velocity_deg_per_s;
    double accel_deg_per_s2;
    double integrator_kpa;
    double derivative_deg_per_s;
    double pressure_cmd_kpa;
    double chamber_model_kpa;
    double angle_ref_deg;
    double velocity_ref_deg_per_s;
    double accel_ref_deg_per_s2;
    double jerk_ref_deg_per_s3;
    double force_ref_n;
    double pressure_ref_kpa;
} rtcore_finger_state;

/* Allocate one of these (static, stack or ffi.new) and call rtcore_hand_configure. */
typedef struct {
    rtcore_hand_config config;
    rtcore_finger_state finger[RTCORE_MAX_FINGERS];
    int32_t configured;
    int32_t error_finger;
    double dt_s;
    uint64_t ticks;
} rtcore_hand;

typedef struct {
    double sensor_mv[RTCORE_MAX_FINGERS];
    /* measured chamber pressure; NaN when the valve board does not report it */
    double pressure_meas_kpa[RTCORE_MAX_FINGERS];
    int32_t mode[RTCORE_MAX_FINGERS];
    double angle_ref_deg[RTCORE_MAX_FINGERS];
    double velocity_ref_deg_per_s[RTCORE_MAX_FINGERS];
    double accel_ref_deg_per_s2[RTCORE_MAX_FINGERS];
    double jerk_ref_deg_per_s3[RTCORE_MAX_FINGERS];
    /* signed normal force at the force point, positive pressing in the bending direction */
    double force_ref_n[RTCORE_MAX_FINGERS];
    double pressure_ref_kpa[RTCORE_MAX_FINGERS];
} rtcore_inputs;

typedef struct {
    double pressure_cmd_kpa[RTCORE_MAX_FINGERS];
    double angle_deg[RTCORE_MAX_FINGERS];
    double angle_filt_deg[RTCORE_MAX_FINGERS];
    double velocity_deg_per_s[RTCORE_MAX_FINGERS];
    double accel_deg_per_s2[RTCORE_MAX_FINGERS];
    double feedforward_kpa[RTCORE_MAX_FINGERS];
    double pid_kpa[RTCORE_MAX_FINGERS];
    double chamber_pressure_kpa[RTCORE_MAX_FINGERS];
    /* the Moore-Penrose force estimate (physics.md section 3): the signed normal force
     * F_n = tau / r, positive pressing in the bending direction (what force control tracks,
     * and what a recording's force_est_n column holds), its x and y components, and |F_n| */
    double force_normal_n[RTCORE_MAX_FINGERS];
    double force_est_x_n[RTCORE_MAX_FINGERS];
    double force_est_y_n[RTCORE_MAX_FINGERS];
    double force_magnitude_n[RTCORE_MAX_FINGERS];
    uint32_t flags[RTCORE_MAX_FINGERS];
} rtcore_outputs;

/* Validate config, copy it into hand, design the filters and reset all state.
 * Returns RTCORE_OK or a negative RTCORE_ERR_*; hand->error_finger names the finger
 * (-1 for hand-level errors). On error the hand is left unconfigured: its step vents. */
int32_t rtcore_hand_configure(rtcore_hand *hand, const rtcore_hand_config *config);

/* Reset every finger (filters re-prime on the next good sample, integrators to 0,
 * mode VENT, command 0 kPa). rtcore_finger_reset does it for one finger. */
void rtcore_hand_reset(rtcore_hand *hand);
void rtcore_finger_reset(rtcore_hand *hand, int32_t finger);

/* One control tick for every configured finger. Returns the OR of all output flags. */
uint32_t rtcore_hand_step(rtcore_hand *hand, const rtcore_inputs *in, rtcore_outputs *out);

/* Butterworth low-pass design (bilinear transform with prewarping), as cascaded
 * sections of 6 doubles each [b0 b1 b2 1 a1 a2] (scipy's sos layout).
 * Returns the number of sections written, or a negative RTCORE_ERR_*. */
int32_t rtcore_butter_design(int32_t order, double cutoff_hz, double sample_rate_hz,
                             double *sos_out, int32_t max_sections);

/* A short English name for a return code. */
const char *rtcore_error_name(int32_t code);

/* ---- The simulated hand (csrc/rtcore_sim.c) -----------------------------------------
 * The PRBM of every finger with the same torque model and effects as the controller,
 * integrated with RK4 at sample_period/substeps, or finer where a stiff term (dry
 * friction's smoothed slope, a stiff contact) needs it; the valve is a first-order lag behind a
 * dead time, integrated exactly (the dead time's breakpoints split the sub-steps); an
 * optional object is a spring-damper at the force point; the flex sensor reads the angle
 * through the inverse calibration with noise and ADC quantisation.
 */
#define RTCORE_SIM_HISTORY 1024
#define RTCORE_ERR_SIM_HISTORY -13

typedef struct {
    double inertia_kgm2;
    double damping_nms_per_rad;
    double stiffness_nm_per_rad;
    double pressure_gain_nm_per_kpa;
    double lever_arm_m;
    rtcore_effects effects;
    /* the valve regulates within what the supply allows */
    double supply_min_kpa;
    double supply_max_kpa;
    /* an object touched past contact_angle_deg; stiffness 0 means no object */
    double contact_angle_deg;
    double contact_stiffness_n_per_m;
    double contact_damping_ns_per_m;
    /* the sensor: mv = (angle_deg + noise - offset) / gain, quantised to adc_step_mv */
    double sensor_gain_deg_per_mv;
    double sensor_offset_deg;
    double sensor_noise_deg;
    double adc_step_mv;
    double pressure_noise_kpa;
} rtcore_sim_finger;

typedef struct {
    int32_t n_fingers;
    double sample_rate_hz;
    int32_t substeps;
    uint64_t seed;
    rtcore_sim_finger finger[RTCORE_MAX_FINGERS];
} rtcore_sim_config;

typedef struct {
    double angle_rad;
    double velocity_rad_per_s;
    double chamber_kpa;
    double contact_force_n;
    /* commands of the last samples, newest at head, for the dead time */
    double command_kpa[RTCORE_SIM_HISTORY];
    int32_t head;
    int32_t delay_samples;
    double delay_fraction;
    /* longest RK4 step that keeps the fastest mode accurate (stiff friction, contact) */
    double max_step_s;
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
 * angle_out_deg[k+1] follows command k. chamber_out_kpa may be NULL. Returns RTCORE_OK
 * or a negative RTCORE_ERR_*. */
int32_t rtcore_sim_run(const rtcore_sim_finger *finger, double sample_rate_hz, int32_t substeps,
                       int32_t n_samples, const double *pressure_cmd_kpa, double angle0_deg,
                       double velocity0_deg_per_s, double chamber0_kpa, double *angle_out_deg,
                       double *chamber_out_kpa);
/* ---- The supervisor's clock (csrc/rtcore_clock.c) -----------------------------------
 * CLOCK_MONOTONIC in ns, and an absolute-deadline schedule: deadline k is
 * start_ns + k*period_ns, so the schedule never drifts whatever a tick costs.
 */
int64_t rtcore_clock_now_ns(void);
/* Sleep (clock_nanosleep, TIMER_ABSTIME) until deadline_ns - spin_ns, then spin on the
 * clock until deadline_ns. Returns the wake-up time in ns, or a negative errno:
 * -EINTR (4) when a signal woke it early, so the caller can handle it and sleep again. */
int64_t rtcore_sleep_until_ns(int64_t deadline_ns, int64_t spin_ns);
/* The deadline after tick *index that ends at after_ns: index+1, or when that deadline
 * has passed already (a deadline miss), the first one still ahead; *index is updated. */
int64_t rtcore_next_deadline_ns(int64_t start_ns, int64_t period_ns, int64_t after_ns,
                                int64_t *index);
/* The machine's floor: a bare loop of n_ticks on the same schedule, from first_index.
 * wake_late_ns[i] is how late tick i woke, index_out[i] its schedule index, *misses the
 * ticks that woke after their period had ended. Returns the next index, or -1. */
int64_t rtcore_floor_loop(int64_t start_ns, int64_t period_ns, int64_t first_index,
                          int32_t n_ticks, int64_t spin_ns, int64_t *wake_late_ns,
                          int64_t *index_out, int32_t *misses);
/* mlockall(MCL_CURRENT | MCL_FUTURE) and munlockall(): 0 or the errno. */
int32_t rtcore_lock_memory(void);
int32_t rtcore_unlock_memory(void);
/* ---- The recording ring (csrc/rtcore_ring.c) -----------------------------------------
 * One producer (the tick) and one consumer (the writer), rows of n_cols doubles in
 * caller-provided (shared) memory. A push writes its row into slot count % capacity, then
 * publishes count + 1 with release semantics, so while the count reads n the slot of row
 * n - capacity may be half overwritten: a reader trusts the last capacity - 1 rows only.
 * ring_count reads the count with acquire semantics, after a fence that completes the
 * caller's earlier loads (the seqlock check after a copy; csrc/rtcore_ring.c). */
int64_t rtcore_ring_count(const int64_t *count);
/* One supervisor tick as one ring row, written straight into the ring: t_s, state, then
 * blocks of n_fingers in the order angle_ref_deg, pressure_kpa (sent_kpa), pressure_meas_kpa,
 * angle_deg, angle_filt_deg, velocity_deg_per_s, force_est_n (out->force_normal_n, the signed
 * normal force that force control tracks, not the magnitude out->force_magnitude_n), force_ref_n,
 * mode, flags (hand_service/recwriter.py QUANTITIES). Returns the new count, or -1 when n_cols
 * is not 2 + 10 * n_fingers. */
int64_t rtcore_ring_push_tick(double *rows, int64_t *count, int32_t capacity, int32_t n_cols,
                              int32_t n_fingers, const rtcore_inputs *in, const rtcore_outputs *out,
                              const double *sent_kpa, double t_s, int32_t state);

/* ---- The safety gate (csrc/rtcore_gate.c) --------------------------------------------
 * The supervisor's checks on every tick, on the control step's own input and output
 * structs, in code apart from the step's: a fault here must vent even if the step is
 * wrong. Each check returns RTCORE_GATE_OK or a cause and fills *result with the first
 * finger at fault, the offending value and the limit or expectation it broke.
 */
#define RTCORE_GATE_OK 0
#define RTCORE_GATE_NON_FINITE 1
#define RTCORE_GATE_ANGLE_OUT_OF_RANGE 2
#define RTCORE_GATE_PRESSURE_OVER_LIMIT 3
#define RTCORE_GATE_LEAK_OR_BURST 4
#define RTCORE_GATE_SENSOR_REJECTED 5
#define RTCORE_GATE_OVERRUN_STREAK 6
#define RTCORE_GATE_STALE_SENSOR 7
#define RTCORE_GATE_TRANSPORT_LOST 8

typedef struct {
    int32_t n_fingers;
    double angle_min_deg;
    double angle_max_deg;
    double pressure_min_kpa[RTCORE_MAX_FINGERS];
    double pressure_max_kpa[RTCORE_MAX_FINGERS];
    double leak_tolerance_kpa;
    int32_t leak_ticks;
    /* the measured chamber pressure is expected to follow the sent command through a
     * first-order lag: expected += follow_alpha * (sent - expected) every tick */
    double follow_alpha[RTCORE_MAX_FINGERS];
    /* ticks in a row the step may hold a rejected sensor reading before it is a fault */
    int32_t sensor_rejected_ticks;
    /* deadline misses in a row that are a fault */
    int32_t overrun_streak;
    /* the firmware's samples in a row that never reached the host: a stale sensor */
    int32_t stale_sensor_ticks;
    /* no sample at all for this long, on the host's clock: the transport is lost */
    int64_t transport_timeout_ns;
} rtcore_gate_config;

typedef struct {
    rtcore_gate_config config;
    double expected_kpa[RTCORE_MAX_FINGERS];
    int32_t leak_ticks[RTCORE_MAX_FINGERS];
    int32_t rejected_ticks[RTCORE_MAX_FINGERS];
    int32_t overruns; /* deadline misses in a row */
    int32_t has_frame; /* last_frame_ns holds a time */
    int64_t last_frame_ns; /* the wake-up of the tick with the newest sample, or of the first check */
} rtcore_gate;

typedef struct {
    int32_t cause;
    int32_t finger;
    double value;
    double limit;
} rtcore_gate_result;

void rtcore_gate_reset(rtcore_gate *gate);
/* Sensor mV finite; a measured pressure finite, or NaN (not reported), never infinite. */
int32_t rtcore_gate_inputs(const rtcore_gate *gate, const rtcore_inputs *in,
                           rtcore_gate_result *result);
/* Angle and command finite; angle within [min, max]; command at most the finger's
 * maximum and not below min(pressure_min_kpa, 0) (between 0 and a positive minimum is
 * the ramp out of a vent); a sensor reading the step has held (rejected) for
 * sensor_rejected_ticks ticks in a row. */
int32_t rtcore_gate_outputs(rtcore_gate *gate, const rtcore_outputs *out,
                            rtcore_gate_result *result);
/* Leak or burst: the measured pressure stays more than leak_tolerance_kpa away from the
 * expectation for leak_ticks ticks. Then the expectation moves toward sent_kpa. */
int32_t rtcore_gate_follow(rtcore_gate *gate, const double *sent_kpa, const rtcore_inputs *in,
                           rtcore_gate_result *result);
/* A streak of deadline misses: missed_last (the tick before missed its deadline) adds one,
 * a met deadline starts again; overrun_streak in a row is a fault (value: the streak). */
int32_t rtcore_gate_overrun(rtcore_gate *gate, int32_t missed_last, rtcore_gate_result *result);
/* The link at now_ns. fresh: a new sample this tick, after lost_in_a_row of the firmware's
 * samples that never arrived (stale_sensor_ticks of them is a stale sensor; value: that
 * count). Without one, silence since the last sample (or since the first check) of
 * transport_timeout_ns is a lost transport (value: the silence in ns). */
int32_t rtcore_gate_frame(rtcore_gate *gate, int32_t fresh, int64_t lost_in_a_row, int64_t now_ns,
                          rtcore_gate_result *result);

/* ---- The supervisor's tick (csrc/rtcore_tick.c) --------------------------------------
 * Everything a supervisor tick does between reading the sensors and sending the valve
 * commands, in one call on caller-owned structs: the gate's checks on the way in, the
 * references for the supervisor's state (a trajectory row, the API's targets, a hold or a
 * vent), the control step, the gate's checks on the way out, and the command to send.
 * The supervisor's state machine, the wording of a fault and the transports stay in
 * Python; each check's finding is in the struct for it to word.
 */
/* The references a tick feeds the step (the supervisor's state) */
#define RTCORE_REFS_VENT 0 /* every finger vents (INIT, DISARMED, ARMED, FAULT, ESTOP) */
#define RTCORE_REFS_HOLD 1 /* HOLD: every reference stays where it is, at rest */
#define RTCORE_REFS_RUN 2 /* RUNNING: the trajectory while it plays, else the targets */

/* What a tick found: bits of the return value */
#define RTCORE_TICK_OVERRUN 1
#define RTCORE_TICK_SAMPLE 2
#define RTCORE_TICK_FRAME 4
#define RTCORE_TICK_OUTPUT 8
#define RTCORE_TICK_LEAK 16
#define RTCORE_TICK_FAULTS 31
#define RTCORE_TICK_TRAJECTORY_END 32

/* A trajectory on the tick grid: n_ticks rows of n_fingers (the tick's), row-major, in
 * caller memory that outlives its use. driven[i] 0: finger i follows its target instead. */
typedef struct {
    const int32_t *mode;
    const double *angle_deg;
    const double *velocity_deg_per_s;
    const double *accel_deg_per_s2;
    const double *jerk_deg_per_s3;
    const double *force_n;
    int64_t n_ticks; /* 0: no trajectory */
    int32_t loop; /* from its start again at its end; else its last row becomes the targets */
    int32_t driven[RTCORE_MAX_FINGERS];
} rtcore_trajectory;

typedef struct {
    int32_t n_fingers;
    rtcore_hand *hand;
    rtcore_inputs *inputs;
    rtcore_outputs *outputs;
    rtcore_gate *gate;
    /* the API's targets, for the fingers no trajectory drives */
    int32_t target_mode[RTCORE_MAX_FINGERS];
    double target_angle_deg[RTCORE_MAX_FINGERS];
    double target_force_n[RTCORE_MAX_FINGERS];
    double target_pressure_kpa[RTCORE_MAX_FINGERS];
    rtcore_trajectory trajectory;
    int64_t trajectory_tick; /* the row the next RUNNING tick plays */
    int32_t trajectory_done; /* its end has been reached: the targets hold its last row */
    /* the command this tick sends: the step's, or 0 kPa when vented or at fault */
    double sent_kpa[RTCORE_MAX_FINGERS];
    /* the recording ring a tick that found nothing pushes its row into in
     * rtcore_tick_sim_at (rtcore_ring_push_tick); ring_rows 0: not recording */
    double *ring_rows;
    int64_t *ring_count;
    int32_t ring_capacity;
    int32_t ring_cols;
    /* what each check found this tick (cause RTCORE_GATE_OK: nothing) */
    rtcore_gate_result overrun;
    rtcore_gate_result sample;
    rtcore_gate_result frame;
    rtcore_gate_result output;
    rtcore_gate_result follow;
} rtcore_tick;

/* The tick up to the send. The caller has written a fresh sample into inputs->sensor_mv and
 * inputs->pressure_meas_kpa (fresh = 1, after lost_in_a_row lost ones) or left the last one.
 * Runs the overrun, sample and frame checks, the references for refs (RTCORE_REFS_*), the
 * step and the output checks, then sets sent_kpa: the step's command, or 0 kPa when refs
 * vents, vent is set (the caller found a fault of its own) or a check found one. Returns
 * RTCORE_TICK_* bits: the checks that found a fault, and RTCORE_TICK_TRAJECTORY_END when a
 * trajectory that does not loop ended (the targets now hold its last row: HOLD). */
int32_t rtcore_tick_control(rtcore_tick *tick, int32_t refs, int32_t vent, int32_t missed_last,
                            int32_t fresh, int64_t lost_in_a_row, int64_t woke_ns);
/* After the send: the leak-or-burst check on sent_kpa. RTCORE_TICK_LEAK or 0. */
int32_t rtcore_tick_follow(rtcore_tick *tick);

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
/* A whole tick on the simulated hand: on_tick, latest into the step's inputs, control,
 * send sent_kpa (its period left pending), follow. The RTCORE_TICK_* bits of both halves. */
int32_t rtcore_tick_sim(rtcore_tick *tick, rtcore_sim_link *link, int64_t tick_index, int32_t refs,
                        int32_t missed_last, int64_t woke_ns);
/* The scheduled tick on the simulated hand, with no Python between the wake-up and the
 * end: sleep to deadline_ns (rtcore_sleep_until_ns, spin_ns), rtcore_tick_sim, and when
 * it found nothing (the state did not change) the ring row of t_s and state. times_ns[0]
 * is the wake-up, times_ns[1] the end. Returns the RTCORE_TICK_* bits, the row left to
 * the caller when any is set; or -1 with nothing done when the sleep failed (times_ns[0]:
 * -EINTR, a signal woke it early, or another -errno). */
int32_t rtcore_tick_sim_at(rtcore_tick *tick, rtcore_sim_link *link, int64_t deadline_ns,
                           int64_t spin_ns, int64_t tick_index, int32_t refs, int32_t missed_last,
                           double t_s, int32_t state, int64_t *times_ns);
/* END CDEF */

#ifdef __cplusplus
}
#endif

#endif /* RTCORE_H */
