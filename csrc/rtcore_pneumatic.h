/*
 * rtcore_pneumatic: the simulator's pneumatic valve mode. A chamber between a supply and
 * the atmosphere through an inlet and an exhaust on/off valve (the board's physics,
 * board/plant/pneumatics.c, compiled into this extension as it is into the host firmware),
 * driven by the board's own pressure regulator (board/core/regulator.c): every
 * regulator_period_us it sets the inlet and exhaust PWM duties from the command and the
 * chamber pressure, and each valve is open for the first duty share of every
 * pwm_period_us, as the host build's HAL drives it (board/host/hal_host.c: a new duty loads
 * at the next PWM period, 0 and full duty at once).
 *
 * rtcore_sim_advance.c calls rtcore_pneumatic_advance for a finger whose valve_model is
 * RTCORE_VALVE_PNEUMATIC instead of its first-order lag and dead time: the lag and dead
 * time the controller's feedforward compensates then emerge from the valves' delays, the
 * orifices, the chamber's volume and the regulator.
 *
 * The block between the CDEF markers is read verbatim by rtcore/_build.py.
 */
#ifndef RTCORE_PNEUMATIC_H
#define RTCORE_PNEUMATIC_H

#include <stdint.h>

#include "pneumatics.h"
#include "regulator.h"

#ifdef __cplusplus
extern "C" {
#endif

/* BEGIN CDEF */
#define RTCORE_VALVE_FIRST_ORDER 0
#define RTCORE_VALVE_PNEUMATIC 1

/* room for the board's struct pneumatics_state and struct regulator, held opaque here
 * (rtcore_pneumatic.c checks at compile time that they fit) */
#define RTCORE_PNEUMATIC_CHAMBER_WORDS 12
#define RTCORE_PNEUMATIC_REGULATOR_WORDS 2

typedef struct {
    int32_t valve_model; /* RTCORE_VALVE_FIRST_ORDER: the first-order lag + dead time of the
                          * finger's effects; RTCORE_VALVE_PNEUMATIC: the fields below */
    double supply_kpa;                 /* gauge */
    double atmosphere_kpa;             /* absolute */
    double temperature_k;              /* supply and chamber */
    double polytropic_index;           /* 1 isothermal .. 1.4 adiabatic */
    double dead_volume_ml;             /* the chamber and its tubing at angle 0; the volume
                                        * grows by the finger's pressure gain N per rad */
    double inlet_conductance_dm3_per_s_bar;   /* ISO 6358 C */
    double inlet_critical_ratio;              /* ISO 6358 b */
    double inlet_open_delay_s;
    double inlet_close_delay_s;
    double exhaust_conductance_dm3_per_s_bar;
    double exhaust_critical_ratio;
    double exhaust_open_delay_s;
    double exhaust_close_delay_s;
    /* the board's regulator (board/core/regulator.h) */
    uint32_t regulator_period_us;      /* the inner loop: <= 2000 (>= 500 Hz) */
    uint32_t pwm_period_us;
    uint32_t min_pulse_us;
    double deadband_kpa;
    double gain_permille_per_kpa;
    double vent_below_kpa;
    uint32_t step_us;                  /* integration step: <= 100, divides both periods */
} rtcore_pneumatic_config;

typedef struct {
    double chamber_kpa;               /* gauge, after the newest step */
    uint64_t chamber[RTCORE_PNEUMATIC_CHAMBER_WORDS];     /* struct pneumatics_state */
    uint64_t regulator[RTCORE_PNEUMATIC_REGULATOR_WORDS]; /* struct regulator */
    int32_t inlet_latched_permille;   /* the duties the valves' PWM runs this period */
    int32_t exhaust_latched_permille;
    int64_t steps;                    /* integration steps since the reset */
    double owed_s;                    /* time asked for and not yet stepped (< one step) */
} rtcore_pneumatic_state;

/* 1 when the config can run: any config whose valve_model is RTCORE_VALVE_FIRST_ORDER, a
 * pneumatic one with finite, physical values and periods as the fields say; else 0. */
int32_t rtcore_pneumatic_valid(const rtcore_pneumatic_config *config);
/* The chamber at chamber_kpa, both valves shut, the regulator venting (as at power-up). */
void rtcore_pneumatic_reset(rtcore_pneumatic_state *state, double chamber_kpa);
/* Advance duration_s with command_kpa held (a NaN command vents, as on the board), the
 * finger at angle_rad moving at velocity_rad_per_s; pressure_gain_nm_per_kpa is the finger's
 * N (the chamber's growth per rad, by virtual work). Returns the chamber's mean gauge
 * pressure over the steps taken (its pressure now when the time was under one step). */
double rtcore_pneumatic_advance(const rtcore_pneumatic_config *config, double pressure_gain_nm_per_kpa,
                                rtcore_pneumatic_state *state, double command_kpa, double angle_rad,
                                double velocity_rad_per_s, double duration_s);
/* END CDEF */

#ifdef __cplusplus
}
#endif

#endif /* RTCORE_PNEUMATIC_H */
