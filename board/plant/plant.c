/* The host build's plant (plant.h). Every number below is a stated assumption or a
 * datasheet's typical value; docs/board.md lists them with their reasons. */
#include "plant.h"

#include <math.h>
#include <string.h>

#define DEG_PER_RAD (180.0 / 3.14159265358979323846)
#define M3_PER_ML 1e-6
#define NM_PER_KPA_TO_M3 1e-3 /* N*m/kPa -> N*m/Pa = m^3 */
#define DM3_S_BAR_TO_M3_S_PA 1e-8 /* dm^3/(s*bar) -> m^3/(s*Pa) */

struct pneumatics_params plant_default_pneumatics(double pressure_gain_nm_per_kpa)
{
    struct pneumatics_params p;
    p.supply_kpa = 350.0;        /* a 3.5 bar regulated supply: above every finger's limit (250 kPa) */
    p.atmosphere_kpa = 101.325;  /* standard atmosphere */
    p.temperature_k = 293.15;    /* room temperature, ISO 8778's reference */
    p.polytropic_index = 1.2;    /* between isothermal (1.0) and adiabatic (1.4): small chambers
                                  * filled in tens of ms exchange some heat with their walls */
    p.dead_volume_m3 = 10.0 * M3_PER_ML; /* a soft finger's chambers and tubing at rest: ~10 mL */
    p.volume_per_rad_m3 = pressure_gain_nm_per_kpa * NM_PER_KPA_TO_M3; /* = N by virtual work */
    /* miniature 2/2 solenoid valves with a ~0.55 mm orifice: effective area S ~ 0.25 mm^2 and
     * C ~ S/5 dm^3/(s*bar) = 0.05 (the usual conversion); b = 0.3 for a sharp-edged
     * orifice. The exhaust's is a little larger (0.07), as on boards that vent through a
     * bigger valve. With them a 0 -> 60 kPa step rises with a time constant of about
     * 30 ms, the valve lag the shipped profiles assume (sim.yaml's valve_lag). Response: 2 ms to open, 1.5 ms to close, of the order the datasheets of
     * such valves give (<= 5 ms). */
    p.inlet.sonic_conductance_m3_per_s_pa = 0.05 * DM3_S_BAR_TO_M3_S_PA;
    p.inlet.critical_ratio = 0.3;
    p.inlet.open_delay_s = 0.002;
    p.inlet.close_delay_s = 0.0015;
    p.exhaust.sonic_conductance_m3_per_s_pa = 0.07 * DM3_S_BAR_TO_M3_S_PA;
    p.exhaust.critical_ratio = 0.3;
    p.exhaust.open_delay_s = 0.002;
    p.exhaust.close_delay_s = 0.0015;
    return p;
}

struct plant_sensor_params plant_default_sensors(void)
{
    struct plant_sensor_params s;
    s.pressure_offset_mv = 200.0;
    s.pressure_sensitivity_mv_per_kpa = 6.4;
    s.pressure_noise_kpa = 0.5;  /* sim.yaml simulation.pressure_noise_kpa */
    s.angle_noise_deg = 0.3;     /* sim.yaml simulation.sensor_noise_deg */
    s.adc_ref_mv = 5000.0;
    s.adc_max_counts = 4095u;    /* 12 bits: sim.yaml's adc_step_mv 1.22 */
    return s;
}

int plant_init(struct plant *p, const struct finger_params *fingers, int n_fingers, uint32_t seed)
{
    memset(p, 0, sizeof *p);
    p->sensors = plant_default_sensors();
    p->rng = seed ? seed : 1u;
    n_fingers = n_fingers < 0 ? 0 : (n_fingers > PLANT_MAX_FINGERS ? PLANT_MAX_FINGERS : n_fingers);
    for (int i = 0; i < n_fingers; i++) {
        p->fingers[i] = fingers[i];
        p->pneumatics[i] = plant_default_pneumatics(fingers[i].pressure_gain_nm_per_kpa);
        pneumatics_init(&p->chamber[i]);
        finger_dynamics(&fingers[i], p->pneumatics[i].supply_kpa, &p->dynamics[i]);
        if (rtcore_sim_motion_start(&p->dynamics[i], &p->motion[i], &p->propagators[i], 0.0, 0.0, 0.0) != RTCORE_OK) {
            return -1;
        }
    }
    p->n_fingers = n_fingers;
    return 0;
}

void plant_step(struct plant *p, const int valves_open[][2], double dt_s)
{
    for (int i = 0; i < p->n_fingers; i++) {
        rtcore_sim_motion *f = &p->motion[i];
        struct pneumatics_state *c = &p->chamber[i];
        pneumatics_step(&p->pneumatics[i], c, valves_open[i][0], valves_open[i][1], f->angle_rad,
                        f->velocity_rad_per_s, dt_s);
        rtcore_sim_motion_advance(&p->dynamics[i], f, &p->propagators[i], c->pressure_kpa, 0.0, dt_s);
    }
}

static double uniform(struct plant *p)
{
    uint32_t x = p->rng; /* xorshift32 */
    x ^= x << 13;
    x ^= x >> 17;
    x ^= x << 5;
    p->rng = x;
    return ((double)x + 1.0) / 4294967297.0; /* (0, 1) */
}

static double gaussian(struct plant *p)
{
    const double u1 = uniform(p);
    const double u2 = uniform(p);
    return sqrt(-2.0 * log(u1)) * cos(2.0 * 3.14159265358979323846 * u2); /* Box-Muller */
}

uint16_t plant_adc(struct plant *p, uint8_t channel)
{
    const int i = channel / 2;
    if (i >= p->n_fingers) {
        return 0u;
    }
    const struct plant_sensor_params *s = &p->sensors;
    double mv;
    if (channel % 2 == 0) {
        const double kpa = p->chamber[i].pressure_kpa + s->pressure_noise_kpa * gaussian(p);
        mv = s->pressure_offset_mv + s->pressure_sensitivity_mv_per_kpa * kpa;
    } else {
        const struct finger_params *f = &p->fingers[i];
        const double angle_deg = p->motion[i].angle_rad * DEG_PER_RAD + s->angle_noise_deg * gaussian(p);
        mv = (angle_deg - f->sensor_offset_deg) / f->sensor_gain_deg_per_mv;
    }
    const double counts = floor(mv * (double)s->adc_max_counts / s->adc_ref_mv + 0.5);
    return (uint16_t)(counts < 0.0 ? 0.0 : (counts > (double)s->adc_max_counts ? (double)s->adc_max_counts : counts));
}
