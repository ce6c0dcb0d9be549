/* The PRBM and its effects: torque model, feedforward by model inversion, and the
 * Moore-Penrose force estimate (docs/physics.md sections 1, 3 and 4). */
#include <math.h>

#include "rtcore_internal.h"

/* The valve's lag toward a pressure that rises (rising > 0: fill; else vent): the vent's
 * own where it has one (valve_vent_tau_s > 0), else valve_lag_tau_s both ways. */
double rtcore_valve_tau_s(const rtcore_effects *e, double rising)
{
    return rising > 0.0 || !(e->valve_vent_tau_s > 0.0) ? e->valve_lag_tau_s : e->valve_vent_tau_s;
}

int rtcore_effects_valid(const rtcore_effects *e)
{
    return isfinite(e->valve_lag_tau_s) && e->valve_lag_tau_s >= 0.0
           && isfinite(e->valve_vent_tau_s) && e->valve_vent_tau_s >= 0.0
           && isfinite(e->dead_time_s) && e->dead_time_s >= 0.0
           && isfinite(e->coulomb_torque_nm) && e->coulomb_torque_nm >= 0.0
           && (e->coulomb_torque_nm == 0.0
               || (isfinite(e->coulomb_smoothing_deg_per_s) && e->coulomb_smoothing_deg_per_s > 0.0))
           && isfinite(e->cubic_stiffness_nm_per_rad3) && isfinite(e->gravity_torque_nm)
           && isfinite(e->asymmetric_stiffness_ratio) && e->asymmetric_stiffness_ratio > 0.0
           && isfinite(e->quadratic_damping_nms2_per_rad2) && e->quadratic_damping_nms2_per_rad2 >= 0.0
           && isfinite(e->pressure_deadzone_kpa) && e->pressure_deadzone_kpa >= 0.0
           && isfinite(e->contact_stiffness_nm_per_radn) && e->contact_stiffness_nm_per_radn >= 0.0
           && (e->contact_stiffness_nm_per_radn == 0.0
               || (isfinite(e->contact_onset_deg) && isfinite(e->contact_exponent) && e->contact_exponent >= 1.0
                   && e->contact_exponent <= 3.0 && isfinite(e->contact_damping_nms_per_rad)
                   && e->contact_damping_nms_per_rad >= 0.0))
           && isfinite(e->pressure_stiffening_gain) && e->pressure_stiffening_gain >= 0.0
           && (e->pressure_stiffening_gain == 0.0
               || (isfinite(e->pressure_stiffening_ref_kpa) && e->pressure_stiffening_ref_kpa > 0.0))
           && isfinite(e->creep_stiffness_ratio) && e->creep_stiffness_ratio >= 0.0
           && (e->creep_stiffness_ratio == 0.0 || (isfinite(e->creep_time_s) && e->creep_time_s > 0.0))
           && isfinite(e->hysteresis_torque_nm) && e->hysteresis_torque_nm >= 0.0
           && (e->hysteresis_torque_nm == 0.0
               || (isfinite(e->hysteresis_travel_deg) && e->hysteresis_travel_deg > 0.0));
}

/* The pressure's stiffening at effective pressure effective_kpa: k*c*(p_eff/p_ref)*theta. */
double rtcore_stiffening_torque_nm(const rtcore_prbm *m, double angle_rad, double effective_kpa)
{
    const rtcore_effects *e = &m->effects;
    if (!(e->pressure_stiffening_gain > 0.0)) {
        return 0.0;
    }
    return m->stiffness_nm_per_rad * e->pressure_stiffening_gain * (effective_kpa / e->pressure_stiffening_ref_kpa)
           * angle_rad;
}

/* The share of N a stiffened finger keeps at angle_rad: the pressure's torque net of its
 * stiffening is N*p_eff*(1 - s*theta), s = k*c/(N*p_ref); at least STIFFENED_GAIN_FLOOR, so
 * that the feedforward's inversion stays finite where the stiffening would eat the gain. */
static const double STIFFENED_GAIN_FLOOR = 0.1;

double rtcore_stiffened_gain_share(const rtcore_prbm *m, double angle_rad)
{
    const rtcore_effects *e = &m->effects;
    if (!(e->pressure_stiffening_gain > 0.0) || !(m->pressure_gain_nm_per_kpa > 0.0)) {
        return 1.0;
    }
    return fmax(1.0 - rtcore_stiffening_torque_nm(m, angle_rad, 1.0) / m->pressure_gain_nm_per_kpa,
                STIFFENED_GAIN_FLOOR);
}

/* How far past the contact's onset angle_rad is (0 before it, or without a contact). */
static double contact_depth_rad(const rtcore_effects *e, double angle_rad)
{
    const double depth_rad = angle_rad - e->contact_onset_deg * RTCORE_RAD_PER_DEG;
    return e->contact_stiffness_nm_per_radn > 0.0 && depth_rad > 0.0 ? depth_rad : 0.0;
}

/* The contact's spring, Kc*(theta - theta_c)^n past its onset (0 before it). */
static double contact_spring_nm(const rtcore_effects *e, double angle_rad)
{
    const double depth_rad = contact_depth_rad(e, angle_rad);
    return depth_rad > 0.0 ? e->contact_stiffness_nm_per_radn * pow(depth_rad, e->contact_exponent) : 0.0;
}

/* Whether angle_rad is past the contact's onset (never without a contact). */
int32_t rtcore_contact_reached(const rtcore_effects *e, double angle_rad)
{
    return contact_depth_rad(e, angle_rad) > 0.0;
}

/* The contact's push in contact, Kc*max(theta - theta_c, 0)^n + Cc*omega, continued across
 * the onset (the damper's share does not vanish there: the simulator keeps one side of it
 * for a whole step) and not yet limited to pushing. */
double rtcore_contact_push_nm(const rtcore_effects *e, double angle_rad, double velocity_rad_per_s)
{
    return contact_spring_nm(e, angle_rad) + e->contact_damping_nms_per_rad * velocity_rad_per_s;
}

/* The contact's torque with its damper in contact (in_contact) or not: the push, pushing
 * only (a finger leaving faster than the spring relaxes leaves the damper behind), or the
 * spring's alone (0 before the onset). */
double rtcore_contact_side_torque_nm(const rtcore_effects *e, double angle_rad, double velocity_rad_per_s,
                                     int32_t in_contact)
{
    double push_nm;
    if (!in_contact) {
        return contact_spring_nm(e, angle_rad);
    }
    push_nm = rtcore_contact_push_nm(e, angle_rad, velocity_rad_per_s);
    return push_nm > 0.0 ? push_nm : 0.0;
}

/* Its slope d/dtheta, n*Kc*(theta - theta_c)^(n-1) past the onset. */
double rtcore_contact_stiffness_nm_per_rad(const rtcore_effects *e, double angle_rad)
{
    const double depth_rad = contact_depth_rad(e, angle_rad);
    return depth_rad > 0.0
               ? e->contact_exponent * e->contact_stiffness_nm_per_radn * pow(depth_rad, e->contact_exponent - 1.0)
               : 0.0;
}

/* A bound on the slopes that grow with the angle (the cubic spring's, the contact's) for
 * angles within reach_rad of angle_rad: what the simulator's steps must resolve. */
double rtcore_model_slope_bound_nm_per_rad(const rtcore_effects *e, double angle_rad, double reach_rad)
{
    const double far_rad = fabs(angle_rad) + reach_rad;
    return 3.0 * fabs(e->cubic_stiffness_nm_per_rad3) * far_rad * far_rad
           + rtcore_contact_stiffness_nm_per_rad(e, angle_rad + reach_rad);
}

/* k, or k * ratio when bending backwards (asymmetric_stiffness). */
static double linear_stiffness_nm_per_rad(const rtcore_prbm *m, double angle_rad)
{
    if (angle_rad < 0.0) {
        return m->stiffness_nm_per_rad * m->effects.asymmetric_stiffness_ratio;
    }
    return m->stiffness_nm_per_rad;
}

/* Torque the finger's structure resists with at (angle, velocity), beyond A*th'', with
 * the contact taken as in_contact says (rtcore_contact_side_torque_nm): B is not included
 * (the callers add B*th' where the dynamics call for it). */
double rtcore_model_side_torque_nm(const rtcore_prbm *m, double angle_rad, double velocity_rad_per_s,
                                   int32_t in_contact)
{
    return rtcore_model_side_torque_with_nm(m, angle_rad, velocity_rad_per_s, in_contact,
                                            rtcore_model_friction_tanh(&m->effects, velocity_rad_per_s));
}

/* tanh(θ'/ω_s), dry friction's share of Tc at θ' (0 without it) */
double rtcore_model_friction_tanh(const rtcore_effects *e, double velocity_rad_per_s)
{
    if (e->coulomb_torque_nm == 0.0) {
        return 0.0;
    }
    return tanh(velocity_rad_per_s / (e->coulomb_smoothing_deg_per_s * RTCORE_RAD_PER_DEG));
}

/* The same with friction_tanh = rtcore_model_friction_tanh at velocity_rad_per_s, which a
 * caller that needs it for more than one torque at that velocity takes once */
double rtcore_model_side_torque_with_nm(const rtcore_prbm *m, double angle_rad, double velocity_rad_per_s,
                                        int32_t in_contact, double friction_tanh)
{
    const rtcore_effects *e = &m->effects;
    double torque = linear_stiffness_nm_per_rad(m, angle_rad) * angle_rad;

    torque += e->cubic_stiffness_nm_per_rad3 * angle_rad * angle_rad * angle_rad;
    torque += e->quadratic_damping_nms2_per_rad2 * fabs(velocity_rad_per_s) * velocity_rad_per_s;
    if (e->coulomb_torque_nm != 0.0) {
        torque += e->coulomb_torque_nm * friction_tanh;
    }
    if (e->gravity_torque_nm != 0.0) {
        torque += e->gravity_torque_nm * (1.0 - cos(angle_rad));
    }
    if (e->contact_stiffness_nm_per_radn > 0.0) {
        torque += rtcore_contact_side_torque_nm(e, angle_rad, velocity_rad_per_s, in_contact);
    }
    return torque;
}

/* The same with the contact where the angle is (past its onset or not). */
double rtcore_model_torque_nm(const rtcore_prbm *m, double angle_rad, double velocity_rad_per_s)
{
    return rtcore_model_side_torque_nm(m, angle_rad, velocity_rad_per_s, rtcore_contact_reached(&m->effects, angle_rad));
}

/* d tau / d theta: the local stiffness, with velocity held fixed. */
double rtcore_model_stiffness_nm_per_rad(const rtcore_prbm *m, double angle_rad)
{
    const rtcore_effects *e = &m->effects;
    double stiffness = linear_stiffness_nm_per_rad(m, angle_rad)
                       + 3.0 * e->cubic_stiffness_nm_per_rad3 * angle_rad * angle_rad;
    if (e->gravity_torque_nm != 0.0) {
        stiffness += e->gravity_torque_nm * sin(angle_rad);
    }
    if (e->contact_stiffness_nm_per_radn > 0.0) {
        stiffness += rtcore_contact_stiffness_nm_per_rad(e, angle_rad);
    }
    return stiffness;
}

/* d/dt of rtcore_model_torque_nm along a trajectory. */
double rtcore_model_torque_rate_nm_per_s(const rtcore_prbm *m, double angle_rad,
                                         double velocity_rad_per_s, double accel_rad_per_s2)
{
    const rtcore_effects *e = &m->effects;
    double d_velocity = 2.0 * e->quadratic_damping_nms2_per_rad2 * fabs(velocity_rad_per_s);
    if (e->coulomb_torque_nm != 0.0) {
        const double smoothing_rad_per_s = e->coulomb_smoothing_deg_per_s * RTCORE_RAD_PER_DEG;
        const double th = tanh(velocity_rad_per_s / smoothing_rad_per_s);
        d_velocity += e->coulomb_torque_nm * (1.0 - th * th) / smoothing_rad_per_s;
    }
    double rate = rtcore_model_stiffness_nm_per_rad(m, angle_rad) * velocity_rad_per_s;
    if (rtcore_contact_reached(e, angle_rad)) {
        /* in contact the damper's Cc*theta'' too; while it pushes at all (else none of it) */
        if (rtcore_contact_push_nm(e, angle_rad, velocity_rad_per_s) > 0.0) {
            d_velocity += e->contact_damping_nms_per_rad;
        } else {
            rate -= rtcore_contact_stiffness_nm_per_rad(e, angle_rad) * velocity_rad_per_s;
        }
    }
    return rate + d_velocity * accel_rad_per_s2;
}

/* Pressure that produces a wanted effective pressure through the dead zone. */
double rtcore_deadzone_invert_kpa(const rtcore_effects *e, double pressure_kpa)
{
    if (e->pressure_deadzone_kpa > 0.0 && pressure_kpa > 0.0) {
        return pressure_kpa + e->pressure_deadzone_kpa;
    }
    return pressure_kpa;
}

/* The part of the chamber pressure that makes torque: max(p - p0, 0) with a dead zone. */
double rtcore_effective_pressure_kpa(const rtcore_effects *e, double pressure_kpa)
{
    const double p0 = e->pressure_deadzone_kpa;
    if (p0 > 0.0) {
        return pressure_kpa > p0 ? pressure_kpa - p0 : 0.0;
    }
    return pressure_kpa;
}

/* The creep branch's dashpot driven by the angle reference, T*x' = theta_ref - x over the
 * tick (the reference held); on entering position mode the branch is taken as relaxed at
 * the filtered angle, where the finger has been. */
void rtcore_creep_reference_update(const rtcore_finger_config *c, rtcore_finger_state *s, int32_t entered,
                                   double dt_s)
{
    const rtcore_effects *e = &c->prbm.effects;
    if (!(e->creep_stiffness_ratio > 0.0)) {
        return;
    }
    if (entered) {
        s->creep_ref_deg = s->angle_filt_deg;
    }
    s->creep_ref_deg = s->angle_ref_deg + (s->creep_ref_deg - s->angle_ref_deg) * exp(-dt_s / e->creep_time_s);
}

/* The hysteresis loop's state driven by the angle reference led by the valve lag (the
 * fill's while the reference bends, the vent's while it opens) + dead time, theta_ref + (tau + delay)*theta_ref': where the finger will be when a command sent
 * now reaches the chamber (the lead the other terms take as a rate; the loop's rate jumps
 * at a turn, so it is led by its angle instead). Dahl's dz/dtheta = (sign dtheta - z)/theta_h
 * is solved exactly over that angle's travel since the last tick (a travel that does not
 * turn is one exponential). On entering position mode the loop is taken at its middle,
 * z = 0, from the filtered angle: the finger's own z is not known from one angle. A state
 * gone non-finite starts over there too. */
void rtcore_hysteresis_reference_update(const rtcore_finger_config *c, rtcore_finger_state *s, int32_t entered)
{
    const rtcore_effects *e = &c->prbm.effects;
    const double led_deg = s->angle_ref_deg
                           + (rtcore_valve_tau_s(e, s->velocity_ref_deg_per_s) + e->dead_time_s)
                                 * s->velocity_ref_deg_per_s;
    double travel_deg;
    if (!(e->hysteresis_torque_nm > 0.0)) {
        return;
    }
    if (entered || !isfinite(s->hysteresis_ref_z) || !isfinite(s->hysteresis_ref_angle_deg)) {
        s->hysteresis_ref_z = 0.0;
        s->hysteresis_ref_angle_deg = s->angle_filt_deg;
    }
    travel_deg = led_deg - s->hysteresis_ref_angle_deg;
    if (travel_deg != 0.0 && isfinite(travel_deg)) {
        const double toward = travel_deg > 0.0 ? 1.0 : -1.0;
        s->hysteresis_ref_z = toward + (s->hysteresis_ref_z - toward) * exp(-fabs(travel_deg) / e->hysteresis_travel_deg);
        s->hysteresis_ref_angle_deg = led_deg;
    }
}

/* The hysteresis loop's state driven by the filtered angle, every tick in every mode: the
 * loop the finger itself runs as far as the controller can tell, for the force estimate and
 * the force feedforward (the inverse of the loop's torque, H*z: it adds no dynamics of its
 * own, z moving with the angle only). Dahl's law is solved exactly over the filtered
 * angle's travel since the last tick, as the reference's loop; the first angle seen (or a
 * state gone non-finite) starts the loop at its middle, z = 0. */
void rtcore_hysteresis_angle_update(const rtcore_finger_config *c, rtcore_finger_state *s)
{
    const rtcore_effects *e = &c->prbm.effects;
    double travel_deg;
    if (!(e->hysteresis_torque_nm > 0.0)) {
        return;
    }
    if (!isfinite(s->hysteresis_z) || !isfinite(s->hysteresis_angle_deg)) {
        s->hysteresis_z = 0.0;
        s->hysteresis_angle_deg = s->angle_filt_deg;
    }
    travel_deg = s->angle_filt_deg - s->hysteresis_angle_deg;
    if (travel_deg != 0.0 && isfinite(travel_deg)) {
        const double toward = travel_deg > 0.0 ? 1.0 : -1.0;
        s->hysteresis_z = toward + (s->hysteresis_z - toward) * exp(-fabs(travel_deg) / e->hysteresis_travel_deg);
        s->hysteresis_angle_deg = s->angle_filt_deg;
    }
}

/* The loop's torque H*z (0 without the effect). */
static double hysteresis_torque_nm(const rtcore_effects *e, double hysteresis_z)
{
    return e->hysteresis_torque_nm > 0.0 ? e->hysteresis_torque_nm * hysteresis_z : 0.0;
}

/* Position feedforward from the held references in s (deg based). Quasi-static:
 * N p = tau(th, 0). Dynamic: N p = A th'' + B th' + tau(th, th'). Both add the lead
 * (valve lag + dead time) * dp/dt, with dp/dt from the reference's own derivatives and the
 * lag the fill's or the vent's as dp/dt rises or falls. */
double rtcore_position_feedforward_kpa(const rtcore_finger_config *c, const rtcore_finger_state *s)
{
    const double angle = s->angle_ref_deg * RTCORE_RAD_PER_DEG;
    const double velocity = s->velocity_ref_deg_per_s * RTCORE_RAD_PER_DEG;
    const double accel = s->accel_ref_deg_per_s2 * RTCORE_RAD_PER_DEG;
    const double jerk = s->jerk_ref_deg_per_s3 * RTCORE_RAD_PER_DEG;
    const rtcore_prbm *m = &c->prbm;
    const double share = rtcore_stiffened_gain_share(m, angle);
    const double gain = m->pressure_gain_nm_per_kpa * share;
    double torque;
    double torque_rate;

    if (c->feedforward == RTCORE_FF_DYNAMIC) {
        torque = m->inertia_kgm2 * accel + m->damping_nms_per_rad * velocity
                 + rtcore_model_torque_nm(m, angle, velocity);
        torque_rate = m->inertia_kgm2 * jerk + m->damping_nms_per_rad * accel
                      + rtcore_model_torque_rate_nm_per_s(m, angle, velocity, accel);
    } else if (c->feedforward == RTCORE_FF_QUASI_STATIC) {
        /* the quasi-static torque depends on th only: d/dt = (d tau / d th) th' */
        torque = rtcore_model_torque_nm(m, angle, 0.0);
        torque_rate = rtcore_model_stiffness_nm_per_rad(m, angle) * velocity;
    } else {
        return 0.0;
    }
    if (m->effects.creep_stiffness_ratio > 0.0) {
        /* the creep branch's torque beta*k*(theta - x) and its rate, x from the reference */
        const double creep_rad = s->creep_ref_deg * RTCORE_RAD_PER_DEG;
        const double branch_nm_per_rad = m->effects.creep_stiffness_ratio * m->stiffness_nm_per_rad;
        torque += branch_nm_per_rad * (angle - creep_rad);
        torque_rate += branch_nm_per_rad * (velocity - (angle - creep_rad) / m->effects.creep_time_s);
    }
    if (m->effects.hysteresis_torque_nm > 0.0) {
        /* the loop's torque H*z, z already led (rtcore_hysteresis_reference_update): no rate */
        torque += m->effects.hysteresis_torque_nm * s->hysteresis_ref_z;
    }
    if (m->effects.pressure_stiffening_gain > 0.0 && share > STIFFENED_GAIN_FLOOR) {
        /* p_eff = torque / G(theta), G falling with theta: d/dt adds torque*k*c/p_ref*theta'/G */
        torque_rate += torque * rtcore_stiffening_torque_nm(m, 1.0, 1.0) * velocity / gain;
    }
    return rtcore_deadzone_invert_kpa(&m->effects, torque / gain)
           + (rtcore_valve_tau_s(&m->effects, torque_rate) + m->effects.dead_time_s) * torque_rate / gain;
}

/* Force feedforward (paper Eq. 4): N p = tau(th, 0) + H z + r F_n, since J^T F = r F_n;
 * z the loop's state from the filtered angle (rtcore_hysteresis_angle_update). torque_rate
 * is that torque's rate (N m/s) where the caller knows it (impedance mode: the spring's
 * and the virtual spring's along the filtered angle; 0 for a held force): the lead
 * (valve lag + dead time) * rate / N puts the pressure where the valve will take it. */
double rtcore_force_feedforward_kpa(const rtcore_finger_config *c, double angle_rad,
                                    double force_ref_n, double hysteresis_z, double torque_rate_nm_per_s)
{
    const rtcore_prbm *m = &c->prbm;
    const double torque = rtcore_model_torque_nm(m, angle_rad, 0.0) + hysteresis_torque_nm(&m->effects, hysteresis_z)
                          + m->lever_arm_m * force_ref_n;
    const double gain = m->pressure_gain_nm_per_kpa * rtcore_stiffened_gain_share(m, angle_rad);
    return rtcore_deadzone_invert_kpa(&m->effects, torque / gain)
           + (rtcore_valve_tau_s(&m->effects, torque_rate_nm_per_s) + m->effects.dead_time_s)
                 * torque_rate_nm_per_s / gain;
}

/* Signed normal force at the force point (paper Eq. 5 with (J^T)+ = J / r^2):
 * F_n = (N p_eff - tau - H z) / r, static or dynamic; z the loop's state from the filtered
 * angle (rtcore_hysteresis_angle_update). */
double rtcore_force_normal_n(const rtcore_finger_config *c, double chamber_pressure_kpa,
                             double angle_rad, double velocity_rad_per_s,
                             double accel_rad_per_s2, double hysteresis_z)
{
    const rtcore_prbm *m = &c->prbm;
    const double effective_kpa = rtcore_effective_pressure_kpa(&m->effects, chamber_pressure_kpa);
    double torque = m->pressure_gain_nm_per_kpa * effective_kpa - rtcore_stiffening_torque_nm(m, angle_rad, effective_kpa)
                    - hysteresis_torque_nm(&m->effects, hysteresis_z);
    if (c->force_estimate_dynamic) {
        torque -= m->inertia_kgm2 * accel_rad_per_s2 + m->damping_nms_per_rad * velocity_rad_per_s
                  + rtcore_model_torque_nm(m, angle_rad, velocity_rad_per_s);
    } else {
        torque -= rtcore_model_torque_nm(m, angle_rad, 0.0);
    }
    return torque / m->lever_arm_m;
}
