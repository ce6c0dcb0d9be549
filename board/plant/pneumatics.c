/* The pneumatics of one chamber (pneumatics.h). */
#include "pneumatics.h"

#include <math.h>
#include <string.h>

#define PA_PER_KPA 1000.0

static double phi(double ratio, double b)
{
    if (ratio <= b) {
        return 1.0;
    }
    if (ratio >= 1.0) {
        return 0.0;
    }
    const double x = (ratio - b) / (1.0 - b);
    return sqrt(1.0 - x * x);
}

double pneumatics_iso6358_kg_per_s(const struct pneumatic_valve_params *valve, double p_up_pa,
                                   double p_down_pa, double t_up_k)
{
    if (!(p_up_pa > 0.0) || !(p_down_pa > 0.0) || !(t_up_k > 0.0)) {
        return 0.0;
    }
    double sign = 1.0;
    if (p_down_pa > p_up_pa) {
        const double t = p_up_pa;
        p_up_pa = p_down_pa;
        p_down_pa = t;
        sign = -1.0;
    }
    return sign * valve->sonic_conductance_m3_per_s_pa * p_up_pa * PNEUMATICS_RHO0_KG_PER_M3
        * sqrt(PNEUMATICS_T0_K / t_up_k) * phi(p_down_pa / p_up_pa, valve->critical_ratio);
}

double pneumatics_volume_m3(const struct pneumatics_params *p, double angle_rad)
{
    return p->dead_volume_m3 + p->volume_per_rad_m3 * (angle_rad > 0.0 ? angle_rad : 0.0);
}

void pneumatics_init(struct pneumatics_state *s)
{
    memset(s, 0, sizeof *s);
}

static void valve_step(struct pneumatic_valve_state *v, const struct pneumatic_valve_params *p, int cmd,
                       double dt_s)
{
    cmd = cmd != 0;
    if (cmd != v->commanded_open) {
        v->commanded_open = cmd;
        v->since_change_s = 0.0;
    }
    if (v->open != cmd) {
        v->since_change_s += dt_s;
        if (v->since_change_s >= (cmd ? p->open_delay_s : p->close_delay_s)) {
            v->open = cmd;
        }
    }
}

void pneumatics_step(const struct pneumatics_params *p, struct pneumatics_state *s, int inlet_open_cmd,
                     int exhaust_open_cmd, double angle_rad, double velocity_rad_per_s, double dt_s)
{
    if (!(dt_s > 0.0) || !isfinite(angle_rad) || !isfinite(velocity_rad_per_s)) {
        return;
    }
    valve_step(&s->inlet, &p->inlet, inlet_open_cmd, dt_s);
    valve_step(&s->exhaust, &p->exhaust, exhaust_open_cmd, dt_s);
    const double atm_pa = p->atmosphere_kpa * PA_PER_KPA;
    const double supply_pa = atm_pa + p->supply_kpa * PA_PER_KPA;
    const double chamber_pa = atm_pa + s->pressure_kpa * PA_PER_KPA;
    const double t_k = p->temperature_k;
    const double in_kg_per_s = s->inlet.open ? pneumatics_iso6358_kg_per_s(&p->inlet, supply_pa, chamber_pa, t_k) : 0.0;
    const double out_kg_per_s = s->exhaust.open ? pneumatics_iso6358_kg_per_s(&p->exhaust, chamber_pa, atm_pa, t_k) : 0.0;
    const double volume_m3 = pneumatics_volume_m3(p, angle_rad);
    const double dv_dt = angle_rad > 0.0 ? p->volume_per_rad_m3 * velocity_rad_per_s : 0.0;
    const double n = p->polytropic_index;
    const double dp_dt = n * PNEUMATICS_R_J_PER_KG_K * t_k / volume_m3 * (in_kg_per_s - out_kg_per_s)
                         - n * chamber_pa / volume_m3 * dv_dt;
    double next_pa = chamber_pa + dp_dt * dt_s;
    /* the explicit step must not carry the chamber past the pressure it flows towards */
    if (s->inlet.open && !s->exhaust.open && chamber_pa <= supply_pa && next_pa > supply_pa) {
        next_pa = supply_pa;
    }
    if (s->exhaust.open && !s->inlet.open && chamber_pa >= atm_pa && next_pa < atm_pa) {
        next_pa = atm_pa;
    }
    if (next_pa < 1.0) {
        next_pa = 1.0; /* an absolute pressure stays positive */
    }
    s->pressure_kpa = (next_pa - atm_pa) / PA_PER_KPA;
    s->inflow_kg_per_s = in_kg_per_s - out_kg_per_s;
}
