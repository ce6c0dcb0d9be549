/* One pneumatic chamber between a supply and the atmosphere, through an inlet and an
 * exhaust on/off valve: the physics, in pure C (no globals, no I/O), so the host build's
 * plant, the project's simulator and `calibrate valve` can share it.
 *
 * Flow through each valve: ISO 6358 (sonic conductance C, critical pressure ratio b)
 *
 *     q_m = C * p_up * rho_0 * sqrt(T_0 / T_up) * phi(p_down / p_up)
 *     phi(r) = 1                                 r <= b   (choked)
 *     phi(r) = sqrt(1 - ((r - b) / (1 - b))^2)   r >  b   (subsonic)
 *
 * with absolute pressures, rho_0 = 1.185 kg/m^3 and T_0 = 293.15 K (ISO 8778's reference
 * atmosphere). The flow runs from the higher pressure to the lower, either way.
 *
 * The chamber: polytropic air, its temperature taken as the supply's,
 *
 *     dp/dt = (n * R * T / V) * (q_in - q_out) - (n * p / V) * dV/dt
 *     V(theta) = V_0 + (dV/dtheta) * max(theta, 0)
 *
 * dV/dtheta is the finger's pressure gain N in SI units (m^3/rad = N*m/Pa): by virtual
 * work the torque a pressure makes, N*p, equals p*dV/dtheta, so the chamber's growth and
 * the PRBM's pressure gain are the same number (docs/physics.md section 1).
 *
 * Each valve opens open_delay_s after it is commanded open and closes close_delay_s after
 * it is commanded shut (a solenoid's magnetic build-up and the armature's travel); a command
 * that changes back within the delay never moves it. The lag and dead time a pressure step
 * shows are then emergent: the valves' delays, the orifices and the volume.
 */
#ifndef BOARD_PNEUMATICS_H
#define BOARD_PNEUMATICS_H

#define PNEUMATICS_RHO0_KG_PER_M3 1.185
#define PNEUMATICS_T0_K 293.15
#define PNEUMATICS_R_J_PER_KG_K 287.05

struct pneumatic_valve_params {
    double sonic_conductance_m3_per_s_pa; /* ISO 6358 C */
    double critical_ratio;                /* ISO 6358 b (0..1) */
    double open_delay_s;
    double close_delay_s;
};

struct pneumatic_valve_state {
    int commanded_open;
    int open;
    double since_change_s; /* how long the command has differed from the valve */
};

struct pneumatics_params {
    double supply_kpa;           /* gauge */
    double atmosphere_kpa;       /* absolute */
    double temperature_k;        /* supply and chamber */
    double polytropic_index;     /* n: 1 isothermal .. 1.4 adiabatic */
    double dead_volume_m3;       /* V_0: the chamber at theta = 0 */
    double volume_per_rad_m3;    /* dV/dtheta */
    struct pneumatic_valve_params inlet;
    struct pneumatic_valve_params exhaust;
};

struct pneumatics_state {
    double pressure_kpa; /* gauge */
    struct pneumatic_valve_state inlet;
    struct pneumatic_valve_state exhaust;
    double inflow_kg_per_s; /* the newest step's, for tests and logs */
};

/* ISO 6358 mass flow from p_up to p_down (absolute, Pa; may be either way round: negative
 * when the flow runs back). */
double pneumatics_iso6358_kg_per_s(const struct pneumatic_valve_params *valve, double p_up_pa,
                                   double p_down_pa, double t_up_k);

/* The chamber volume at a bend angle. */
double pneumatics_volume_m3(const struct pneumatics_params *p, double angle_rad);

void pneumatics_init(struct pneumatics_state *s);

/* Advance dt_s with the valves commanded open or shut (1/0), the finger at angle_rad moving
 * at velocity_rad_per_s. dt_s of 100 us or less keeps the explicit step accurate. */
void pneumatics_step(const struct pneumatics_params *p, struct pneumatics_state *s, int inlet_open_cmd,
                     int exhaust_open_cmd, double angle_rad, double velocity_rad_per_s, double dt_s);

#endif
