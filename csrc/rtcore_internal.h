/* Internal helpers shared by the rtcore translation units. Not part of the API:
 * nothing here is in the cffi cdef. Names keep the rtcore_ prefix because they have
 * external linkage inside the extension module. */
#ifndef RTCORE_INTERNAL_H
#define RTCORE_INTERNAL_H

#include <stdint.h>

#include "rtcore_step.h"

#define RTCORE_PI 3.14159265358979323846
#define RTCORE_DEG_PER_RAD (180.0 / RTCORE_PI)
#define RTCORE_RAD_PER_DEG (RTCORE_PI / 180.0)

/* filter.c */
void rtcore_biquad_design_lowpass(rtcore_biquad *bq, double tan_half, double q);
void rtcore_biquad_prime(rtcore_biquad *bq, double x);
double rtcore_biquad_run(rtcore_biquad *bq, double x);
double rtcore_first_order_alpha(double cutoff_hz, double dt_s);
int32_t rtcore_butter_sections(rtcore_biquad *sections, int32_t max_sections, int32_t order,
                               double cutoff_hz, double sample_rate_hz);

/* model.c: the torque model is shared by the controller and the simulator */
int rtcore_effects_valid(const rtcore_effects *e);
double rtcore_valve_tau_s(const rtcore_effects *e, double rising);
double rtcore_model_torque_nm(const rtcore_prbm *m, double angle_rad, double velocity_rad_per_s);
double rtcore_model_stiffness_nm_per_rad(const rtcore_prbm *m, double angle_rad);
double rtcore_model_side_torque_nm(const rtcore_prbm *m, double angle_rad, double velocity_rad_per_s,
                                   int32_t in_contact);
double rtcore_model_friction_tanh(const rtcore_effects *e, double velocity_rad_per_s);
double rtcore_model_side_torque_with_nm(const rtcore_prbm *m, double angle_rad, double velocity_rad_per_s,
                                        int32_t in_contact, double friction_tanh);
int32_t rtcore_contact_reached(const rtcore_effects *e, double angle_rad);
double rtcore_contact_push_nm(const rtcore_effects *e, double angle_rad, double velocity_rad_per_s);
double rtcore_contact_side_torque_nm(const rtcore_effects *e, double angle_rad, double velocity_rad_per_s,
                                     int32_t in_contact);
double rtcore_contact_stiffness_nm_per_rad(const rtcore_effects *e, double angle_rad);
double rtcore_model_slope_bound_nm_per_rad(const rtcore_effects *e, double angle_rad, double reach_rad);
double rtcore_stiffening_torque_nm(const rtcore_prbm *m, double angle_rad, double effective_kpa);
double rtcore_stiffened_gain_share(const rtcore_prbm *m, double angle_rad);
double rtcore_model_torque_rate_nm_per_s(const rtcore_prbm *m, double angle_rad,
                                         double velocity_rad_per_s, double accel_rad_per_s2);
double rtcore_deadzone_invert_kpa(const rtcore_effects *e, double pressure_kpa);
double rtcore_effective_pressure_kpa(const rtcore_effects *e, double pressure_kpa);
double rtcore_position_feedforward_kpa(const rtcore_finger_config *c, const rtcore_finger_state *s);
void rtcore_creep_reference_update(const rtcore_finger_config *c, rtcore_finger_state *s, int32_t entered,
                                   double dt_s);
void rtcore_hysteresis_reference_update(const rtcore_finger_config *c, rtcore_finger_state *s, int32_t entered);
void rtcore_hysteresis_angle_update(const rtcore_finger_config *c, rtcore_finger_state *s);
double rtcore_force_feedforward_kpa(const rtcore_finger_config *c, double angle_rad,
                                    double force_ref_n, double hysteresis_z, double torque_rate_nm_per_s);
double rtcore_force_normal_n(const rtcore_finger_config *c, double chamber_pressure_kpa,
                             double angle_rad, double velocity_rad_per_s,
                             double accel_rad_per_s2, double hysteresis_z);

/* pid.c */
typedef struct {
    double command_kpa;
    double integrator_kpa;
    uint32_t flags;
} rtcore_limited;
rtcore_limited rtcore_limit_command(const rtcore_finger_config *c, double unsat_kpa,
                                    double previous_kpa, double dt_s, double error,
                                    double integrator_old_kpa, double integrator_new_kpa);

#endif /* RTCORE_INTERNAL_H */
