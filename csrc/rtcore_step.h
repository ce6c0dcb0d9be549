/*
 * rtcore_step: the 100 Hz control step for a pneumatic soft hand (1 to 8 fingers),
 * in csrc/rtcore_step.c (its configuration and reset in csrc/rtcore_config.c) with
 * csrc/rtcore_filter.c, rtcore_model.c and rtcore_pid.c.
 *
 * One call, rtcore_hand_step(), runs for every finger:
 *   sensor mV -> deg (linear calibration) -> Butterworth low-pass (order 2 or 4)
 *   -> filtered velocity and acceleration -> feedforward (PRBM model inversion)
 *   + PID (position) or PI on the signed normal force (force; impedance, whose force
 *   reference is a virtual spring and damper about the angle reference)
 *   -> saturation and rate limit -> pressure command, and the Moore-Penrose
 *   force estimate.
 *
 * Its constants, return codes and structs (rtcore_inputs, rtcore_outputs, ...) are
 * shared by the other units (rtcore.h lists them).
 *
 * The block between the CDEF markers is read verbatim by rtcore/_build.py (with the
 * other headers' blocks, in the order listed there) and handed to cffi: keep it to
 * plain declarations and integer #defines.
 */
#ifndef RTCORE_STEP_H
#define RTCORE_STEP_H

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
/* Impedance: the finger follows angle_ref_deg (and velocity_ref_deg_per_s) with a virtual
 * stiffness and damping about it, by force control on the force estimate:
 *   F_ref = K (angle_ref - angle) + D (velocity_ref - velocity)
 * K and D are rtcore_inputs.impedance_stiffness_n_per_deg and impedance_damping_n_s_per_deg. */
#define RTCORE_MODE_IMPEDANCE 4

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
 * Physics the model includes beyond the plain PRBM (docs/physics.md, docs/formats.md
 * "effects"). A zero leaves an effect out; asymmetric_stiffness_ratio = 1 is symmetric.
 * The extra torque is
 *   tau(theta, omega) = k_eff(theta)*theta + k3*theta^3 + c2*|omega|*omega
 *                       + Tc*tanh(omega/omega_s) + G*(1 - cos theta)
 *                       + max(Kc*(theta - theta_c)^n + Cc*omega, 0) for theta > theta_c
 * with k_eff = k for theta >= 0 and k*ratio for theta < 0, and the last term a contact met
 * past theta_c (contact_stiffness_nm_per_radn 0: none; n in [1, 3]), a spring with a
 * Kelvin-Voigt damper Cc in parallel while in contact, pushing only. The chamber pressure
 * acts only above the dead zone: M = N*max(p - p0, 0), and stiffens the finger by
 * k*c*(p_eff/p_ref)*theta (pressure_stiffening_gain c, 0: none), so the pressure's torque
 * is G(theta)*p_eff with G = N - k*c*theta/p_ref. Valve lag and dead time are
 * compensated in the position feedforward by a first-order lead of (tau + delay), tau the
 * fill's or the vent's as the pressure rises or falls (rtcore_valve_tau_s).
 */
typedef struct {
    double valve_lag_tau_s;
    /* the chamber's lag while it vents (the command below it); 0: valve_lag_tau_s both ways */
    double valve_vent_tau_s;
    double dead_time_s;
    double coulomb_torque_nm;
    double coulomb_smoothing_deg_per_s;
    double cubic_stiffness_nm_per_rad3;
    double gravity_torque_nm;
    double asymmetric_stiffness_ratio;
    double quadratic_damping_nms2_per_rad2;
    double pressure_deadzone_kpa;
    double contact_stiffness_nm_per_radn;
    double contact_onset_deg;
    double contact_exponent;
    double contact_damping_nms_per_rad;
    double pressure_stiffening_gain;
    double pressure_stiffening_ref_kpa;
    /* creep: a standard-linear-solid branch beside k, a spring ratio*k in series with a
     * dashpot of time constant creep_time_s (the simulated finger's; ratio 0: none) */
    double creep_stiffness_ratio;
    double creep_time_s;
    /* hysteresis: the controller's model of the finger's rate-independent loop, -H*z with
     * dz/dtheta = (sign theta' - z)/theta_h (Dahl); the position feedforward adds H*z, z
     * driven by the angle reference led by the valve lag + dead time (the simulated finger's own loop is
     * rtcore_sim_finger.hysteresis_*, which the simulator uses; it ignores these two).
     * Torque 0: none */
    double hysteresis_torque_nm;
    double hysteresis_travel_deg;
} rtcore_effects;

/*
 * The PRBM of one finger (docs/physics.md section 1), shared by the controller's finger
 * (rtcore_finger_config.prbm) and the simulated finger (rtcore_sim_finger.prbm):
 *   A th'' + B th' + k th = N p - J^T F,   |J| = r
 * with th the bending angle (rad), p the chamber pressure (kPa) and F the force at the
 * force point (N); effects (above) turns k th into tau(theta, omega) and N p into
 * N*max(p - p0, 0).
 */
typedef struct {
    double inertia_kgm2;             /* A, kg m^2 */
    double damping_nms_per_rad;      /* B, N m s/rad */
    double stiffness_nm_per_rad;     /* k, N m/rad */
    double pressure_gain_nm_per_kpa; /* N, N m/kPa */
    double lever_arm_m;              /* r, pivot to force point, m (simulator: 0, no force point) */
    rtcore_effects effects;
} rtcore_prbm;

typedef struct {
    /* sensor: angle_deg = sensor_gain_deg_per_mv * mv + sensor_offset_deg */
    double sensor_gain_deg_per_mv;
    double sensor_offset_deg;
    /* Butterworth low-pass on the calibrated angle */
    int32_t filter_order;
    double filter_cutoff_hz;
    /* first-order low-pass on the differences that give velocity and acceleration */
    double velocity_cutoff_hz;
    rtcore_prbm prbm;
    int32_t feedforward;
    int32_t force_estimate_dynamic;
    /* 1: the force estimate and force feedforward carry the model's hysteresis loop, driven
     * by the filtered angle (only where the finger has the loop: one it lacks is positive
     * feedback); 0: they leave it out */
    int32_t force_estimate_hysteresis;
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
    double chamber_alpha;      /* the chamber model's per tick while it fills */
    double chamber_vent_alpha; /* and while it vents */
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
    double impedance_stiffness_n_per_deg;
    double impedance_damping_n_s_per_deg;
    /* the creep branch's dashpot as the angle reference would move it (position mode) */
    double creep_ref_deg;
    /* the hysteresis loop's state as the angle reference would move it (position mode),
     * in [-1, 1], and the led reference angle it last saw */
    double hysteresis_ref_z;
    double hysteresis_ref_angle_deg;
    /* the hysteresis loop's state as the filtered angle moves it (every mode), in [-1, 1],
     * and the filtered angle it last saw (NaN: none yet): the force estimate's and the
     * force feedforward's loop torque H*z */
    double hysteresis_z;
    double hysteresis_angle_deg;
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
    /* impedance mode: virtual stiffness (N of tip force per deg short of angle_ref_deg)
     * and damping (N per deg/s); finite and >= 0, else the last usable value is held */
    double impedance_stiffness_n_per_deg[RTCORE_MAX_FINGERS];
    double impedance_damping_n_s_per_deg[RTCORE_MAX_FINGERS];
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
    /* the Moore-Penrose force estimate (docs/physics.md section 3): the signed normal force
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
/* END CDEF */

#ifdef __cplusplus
}
#endif

#endif /* RTCORE_STEP_H */
