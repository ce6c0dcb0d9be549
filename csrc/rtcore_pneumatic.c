/* The simulator's pneumatic valve mode (rtcore_pneumatic.h): the board's regulator and
 * PWM over the board's chamber physics, in fixed integration steps. */
#include <math.h>
#include <string.h>

#include "rtcore_pneumatic.h"

/* The board's own sources, compiled here (their directories are on the include path,
 * rtcore/_build.py BOARD_DIRS) with hidden visibility: one source of truth for the firmware
 * and the simulator, and the extension still exports only rtcore_ names. */
#pragma GCC visibility push(hidden)
#include "pneumatics.c"
#include "regulator.c"
#pragma GCC visibility pop

#define M3_PER_ML 1e-6
#define M3_PER_NM_PER_KPA 1e-3           /* N*m/kPa -> N*m/Pa = m^3 */
#define M3_PER_S_PA_PER_DM3_PER_S_BAR 1e-8 /* dm^3/(s*bar) -> m^3/(s*Pa) */
#define PWM_FULL_PERMILLE 1000u
#define MAX_STEP_US 100u
#define MAX_REGULATOR_PERIOD_US 2000u

/* the board's structs fit in the opaque words of rtcore_pneumatic_state (C99: a negative
 * array size stops the build) */
typedef char chamber_fits[sizeof(struct pneumatics_state) <= RTCORE_PNEUMATIC_CHAMBER_WORDS * sizeof(uint64_t) ? 1 : -1];
typedef char regulator_fits[sizeof(struct regulator) <= RTCORE_PNEUMATIC_REGULATOR_WORDS * sizeof(uint64_t) ? 1 : -1];

/* the board's state, copied out of and back into the opaque words (memcpy: no aliasing) */
typedef struct {
    struct pneumatics_state chamber;
    struct regulator regulator;
} board_state;

static void load(const rtcore_pneumatic_state *s, board_state *b)
{
    memcpy(&b->chamber, s->chamber, sizeof b->chamber);
    memcpy(&b->regulator, s->regulator, sizeof b->regulator);
}

static void store(const board_state *b, rtcore_pneumatic_state *s)
{
    memcpy(s->chamber, &b->chamber, sizeof b->chamber);
    memcpy(s->regulator, &b->regulator, sizeof b->regulator);
    s->chamber_kpa = b->chamber.pressure_kpa;
}

static int32_t finite_in(double x, double low, double high)
{
    return isfinite(x) && x >= low && x <= high;
}

static int32_t valve_valid(double conductance, double critical_ratio, double open_delay_s, double close_delay_s)
{
    return finite_in(conductance, 0.0, 1e3) && conductance > 0.0 && finite_in(critical_ratio, 0.0, 0.99)
           && finite_in(open_delay_s, 0.0, 1.0) && finite_in(close_delay_s, 0.0, 1.0);
}

int32_t rtcore_pneumatic_valid(const rtcore_pneumatic_config *c)
{
    if (c == 0) {
        return 0;
    }
    if (c->valve_model == RTCORE_VALVE_FIRST_ORDER) {
        return 1;
    }
    if (c->valve_model != RTCORE_VALVE_PNEUMATIC) {
        return 0;
    }
    return finite_in(c->supply_kpa, 0.0, 1e4) && c->supply_kpa > 0.0 && finite_in(c->atmosphere_kpa, 1.0, 1e3)
           && finite_in(c->temperature_k, 1.0, 1e3) && finite_in(c->polytropic_index, 1.0, 1.4)
           && finite_in(c->dead_volume_ml, 0.0, 1e6) && c->dead_volume_ml > 0.0
           && valve_valid(c->inlet_conductance_dm3_per_s_bar, c->inlet_critical_ratio, c->inlet_open_delay_s,
                          c->inlet_close_delay_s)
           && valve_valid(c->exhaust_conductance_dm3_per_s_bar, c->exhaust_critical_ratio,
                          c->exhaust_open_delay_s, c->exhaust_close_delay_s)
           && c->step_us > 0u && c->step_us <= MAX_STEP_US && c->regulator_period_us > 0u
           && c->regulator_period_us <= MAX_REGULATOR_PERIOD_US && c->regulator_period_us % c->step_us == 0u
           && c->pwm_period_us > 0u && c->pwm_period_us % c->step_us == 0u && c->min_pulse_us <= c->pwm_period_us
           && finite_in(c->deadband_kpa, 0.0, 1e3) && finite_in(c->gain_permille_per_kpa, 0.0, 1e6)
           && c->gain_permille_per_kpa > 0.0 && finite_in(c->vent_below_kpa, -1e3, 1e3);
}

void rtcore_pneumatic_reset(rtcore_pneumatic_state *s, double chamber_kpa)
{
    board_state b;
    memset(s, 0, sizeof *s);
    memset(&b, 0, sizeof b);
    pneumatics_init(&b.chamber);
    b.chamber.pressure_kpa = isfinite(chamber_kpa) ? chamber_kpa : 0.0;
    regulator_vent(&b.regulator);
    store(&b, s);
}

/* The board's struct params for a finger of pressure gain N (the plant's, plant.c). */
static void board_params(const rtcore_pneumatic_config *c, double pressure_gain_nm_per_kpa,
                         struct pneumatics_params *p, struct regulator_config *r)
{
    p->supply_kpa = c->supply_kpa;
    p->atmosphere_kpa = c->atmosphere_kpa;
    p->temperature_k = c->temperature_k;
    p->polytropic_index = c->polytropic_index;
    p->dead_volume_m3 = c->dead_volume_ml * M3_PER_ML;
    p->volume_per_rad_m3 = pressure_gain_nm_per_kpa * M3_PER_NM_PER_KPA;
    p->inlet.sonic_conductance_m3_per_s_pa = c->inlet_conductance_dm3_per_s_bar * M3_PER_S_PA_PER_DM3_PER_S_BAR;
    p->inlet.critical_ratio = c->inlet_critical_ratio;
    p->inlet.open_delay_s = c->inlet_open_delay_s;
    p->inlet.close_delay_s = c->inlet_close_delay_s;
    p->exhaust.sonic_conductance_m3_per_s_pa = c->exhaust_conductance_dm3_per_s_bar * M3_PER_S_PA_PER_DM3_PER_S_BAR;
    p->exhaust.critical_ratio = c->exhaust_critical_ratio;
    p->exhaust.open_delay_s = c->exhaust_open_delay_s;
    p->exhaust.close_delay_s = c->exhaust_close_delay_s;
    r->deadband_kpa = (float)c->deadband_kpa;
    r->gain_permille_per_kpa = (float)c->gain_permille_per_kpa;
    r->pwm_period_us = c->pwm_period_us;
    r->min_pulse_us = c->min_pulse_us;
    r->vent_below_kpa = (float)c->vent_below_kpa;
}

/* One integration step at step count s->steps: the regulator at its period's start (its
 * duties load into the PWM at once when 0 or full, else at the next PWM period), the PWM
 * phase opens or shuts each valve, the chamber follows. */
static void one_step(const rtcore_pneumatic_config *c, const struct pneumatics_params *p,
                     const struct regulator_config *r, rtcore_pneumatic_state *s, board_state *b,
                     double command_kpa, double angle_rad, double velocity_rad_per_s)
{
    const uint64_t t_us = (uint64_t)s->steps * c->step_us;
    const uint64_t phase_us = t_us % c->pwm_period_us;
    int inlet_open;
    int exhaust_open;
    if (t_us % c->regulator_period_us == 0u) {
        regulator_step(&b->regulator, r, (float)command_kpa, (float)b->chamber.pressure_kpa);
        if (b->regulator.inlet_permille == 0u || b->regulator.inlet_permille >= PWM_FULL_PERMILLE) {
            s->inlet_latched_permille = b->regulator.inlet_permille;
        }
        if (b->regulator.exhaust_permille == 0u || b->regulator.exhaust_permille >= PWM_FULL_PERMILLE) {
            s->exhaust_latched_permille = b->regulator.exhaust_permille;
        }
    }
    if (phase_us == 0u) {
        s->inlet_latched_permille = b->regulator.inlet_permille;
        s->exhaust_latched_permille = b->regulator.exhaust_permille;
    }
    inlet_open = phase_us * PWM_FULL_PERMILLE < (uint64_t)s->inlet_latched_permille * c->pwm_period_us;
    exhaust_open = phase_us * PWM_FULL_PERMILLE < (uint64_t)s->exhaust_latched_permille * c->pwm_period_us;
    pneumatics_step(p, &b->chamber, inlet_open, exhaust_open, angle_rad, velocity_rad_per_s,
                    (double)c->step_us * 1e-6);
    s->steps += 1;
}

double rtcore_pneumatic_advance(const rtcore_pneumatic_config *c, double pressure_gain_nm_per_kpa,
                                rtcore_pneumatic_state *s, double command_kpa, double angle_rad,
                                double velocity_rad_per_s, double duration_s)
{
    struct pneumatics_params p;
    struct regulator_config r;
    board_state b;
    double step_s;
    double sum_kpa = 0.0;
    int32_t taken = 0;
    if (c == 0 || s == 0 || c->valve_model != RTCORE_VALVE_PNEUMATIC || c->step_us == 0u
        || c->regulator_period_us == 0u || c->pwm_period_us == 0u) {
        return s == 0 ? NAN : s->chamber_kpa;
    }
    step_s = (double)c->step_us * 1e-6;
    board_params(c, pressure_gain_nm_per_kpa, &p, &r);
    if (!isfinite(angle_rad) || !isfinite(velocity_rad_per_s)) {
        angle_rad = 0.0; /* a diverged finger: the chamber at its rest volume, still regulated */
        velocity_rad_per_s = 0.0;
    }
    if (isfinite(duration_s) && duration_s > 0.0) {
        s->owed_s += duration_s;
    }
    load(s, &b);
    while (s->owed_s >= step_s * (1.0 - 1e-9)) {
        one_step(c, &p, &r, s, &b, command_kpa, angle_rad, velocity_rad_per_s);
        s->owed_s -= step_s;
        sum_kpa += b.chamber.pressure_kpa;
        taken += 1;
    }
    store(&b, s);
    if (s->owed_s < 0.0) {
        s->owed_s = 0.0;
    }
    return taken > 0 ? sum_kpa / (double)taken : s->chamber_kpa;
}
