/* The plant's C tests (make -C board test-core): ISO 6358 flow, valve delays, the chamber's
 * fill and vent, the finger's static gain and its steps (the simulator's, csrc/rtcore_sim_plant.h). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "finger.h"
#include "plant.h"
#include "pneumatics.h"

static int failures;

#define CHECK(cond)                                                                          \
    do {                                                                                     \
        if (!(cond)) {                                                                       \
            fprintf(stderr, "%s:%d: %s: check failed: %s\n", __FILE__, __LINE__, __func__, #cond); \
            failures++;                                                                      \
        }                                                                                    \
    } while (0)

static void test_iso6358(void)
{
    const struct pneumatic_valve_params v = {1e-9, 0.3, 0.0, 0.0};
    const double choked = 1e-9 * 400e3 * PNEUMATICS_RHO0_KG_PER_M3;
    CHECK(fabs(pneumatics_iso6358_kg_per_s(&v, 400e3, 100e3, PNEUMATICS_T0_K) - choked) < 1e-15);
    CHECK(fabs(pneumatics_iso6358_kg_per_s(&v, 400e3, 120e3, PNEUMATICS_T0_K) - choked) < 1e-15); /* r = b */
    double last = choked;
    for (double r = 0.35; r < 1.0; r += 0.05) { /* subsonic: falls to 0 as r -> 1 */
        const double q = pneumatics_iso6358_kg_per_s(&v, 400e3, r * 400e3, PNEUMATICS_T0_K);
        CHECK(q < last && q > 0.0);
        last = q;
    }
    CHECK(pneumatics_iso6358_kg_per_s(&v, 400e3, 400e3, PNEUMATICS_T0_K) == 0.0);
    CHECK(pneumatics_iso6358_kg_per_s(&v, 100e3, 400e3, PNEUMATICS_T0_K) < 0.0); /* runs back */
    /* a hotter upstream gas is less dense: sqrt(T0/T) */
    const double hot = pneumatics_iso6358_kg_per_s(&v, 400e3, 100e3, 4.0 * PNEUMATICS_T0_K);
    CHECK(fabs(hot - choked / 2.0) < 1e-15);
}

static void test_valve_delay_and_fill(void)
{
    const struct pneumatics_params p = plant_default_pneumatics(8.95e-3);
    struct pneumatics_state s;
    pneumatics_init(&s);
    const double dt = 50e-6;
    for (int i = 0; i < 20; i++) { /* 1 ms: not yet open */
        pneumatics_step(&p, &s, 1, 0, 0.0, 0.0, dt);
    }
    CHECK(!s.inlet.open && s.pressure_kpa == 0.0);
    for (int i = 0; i < 30; i++) {
        pneumatics_step(&p, &s, 1, 0, 0.0, 0.0, dt);
    }
    CHECK(s.inlet.open && s.pressure_kpa > 0.0);
    double t = 2.5e-3;
    double t_half = -1.0;
    while (t < 2.0) {
        pneumatics_step(&p, &s, 1, 0, 0.0, 0.0, dt);
        t += dt;
        if (t_half < 0.0 && s.pressure_kpa > p.supply_kpa / 2.0) {
            t_half = t;
        }
        CHECK(s.pressure_kpa <= p.supply_kpa + 1e-9);
    }
    CHECK(s.pressure_kpa > 0.99 * p.supply_kpa);
    CHECK(t_half > 0.01 && t_half < 0.5);
    printf("test-plant: the default chamber fills to half the supply in %.1f ms\n", t_half * 1e3);
    /* a pulse shorter than the opening delay never opens the exhaust */
    const double full = s.pressure_kpa;
    for (int i = 0; i < 30; i++) {
        pneumatics_step(&p, &s, 0, 1, 0.0, 0.0, dt); /* 1.5 ms */
    }
    for (int i = 0; i < 100; i++) {
        pneumatics_step(&p, &s, 0, 0, 0.0, 0.0, dt);
    }
    CHECK(fabs(s.pressure_kpa - full) < 1e-9);
    for (int i = 0; i < 40000; i++) {
        pneumatics_step(&p, &s, 0, 1, 0.0, 0.0, dt);
        CHECK(s.pressure_kpa >= -1e-9);
    }
    CHECK(s.pressure_kpa < 0.5);
}

static void test_closed_chamber_compresses_as_it_grows(void)
{
    const struct pneumatics_params p = plant_default_pneumatics(8.95e-3);
    struct pneumatics_state s;
    pneumatics_init(&s);
    s.pressure_kpa = 100.0;
    const double p0_pa = 201.325e3;
    const double v0 = pneumatics_volume_m3(&p, 0.2);
    double angle = 0.2;
    for (int i = 0; i < 1000; i++) { /* the finger bends further with both valves shut */
        pneumatics_step(&p, &s, 0, 0, angle, 0.2 / 0.05, 50e-6);
        angle += 0.2 / 1000.0;
    }
    const double v1 = pneumatics_volume_m3(&p, angle);
    const double expected_pa = p0_pa * pow(v0 / v1, p.polytropic_index); /* p V^n = const */
    CHECK(fabs((s.pressure_kpa * 1e3 + 101.325e3) - expected_pa) < 0.005 * expected_pa);
}

static void test_finger_static_gain(void)
{
    const struct finger_params f = {0.05, 0.095, 0.85, 0.57, 0.0031, 8.9535e-3, 0.1, -50.0};
    rtcore_sim_finger dynamics;
    rtcore_sim_motion s;
    rtcore_propagator_cache cache;
    finger_dynamics(&f, 350.0, &dynamics);
    CHECK(rtcore_sim_motion_start(&dynamics, &s, &cache, 0.0, 0.0, 0.0) == RTCORE_OK);
    for (int i = 0; i < 200000; i++) { /* 10 s: the oscillation dies out */
        rtcore_sim_motion_advance(&dynamics, &s, &cache, 50.0, 0.0, 50e-6);
    }
    CHECK(fabs(s.angle_rad - 8.9535e-3 * 50.0 / 0.57) < 1e-4);
}

/* The plant's steps are the simulator's exact ones: 200 of 50 us under a held pressure land
 * where one of 10 ms does, and a finger the simulator refuses leaves the plant empty. */
static void test_plant_steps_the_finger_exactly(void)
{
    const struct finger_params f = {0.05, 0.095, 0.85, 0.57, 0.0031, 8.9535e-3, 0.1, -50.0};
    static struct plant p;
    const int shut[1][2] = {{0, 0}};
    rtcore_sim_motion one;
    CHECK(plant_init(&p, &f, 1, 7u) == 0 && p.n_fingers == 1);
    /* both valves shut and a chamber that does not grow as the finger bends: 80 kPa held */
    p.chamber[0].pressure_kpa = 80.0;
    p.pneumatics[0].volume_per_rad_m3 = 0.0;
    one = p.motion[0];
    for (int i = 0; i < 200; i++) {
        plant_step(&p, shut, 50e-6);
    }
    rtcore_sim_motion_advance(&p.dynamics[0], &one, 0, 80.0, 0.0, 0.01);
    CHECK(fabs(p.chamber[0].pressure_kpa - 80.0) < 1e-9);
    CHECK(fabs(p.motion[0].angle_rad - one.angle_rad) < 1e-12 && one.angle_rad > 0.01);
    const struct finger_params massless = {0.0, 0.095, 0.85, 0.57, 0.0031, 8.9535e-3, 0.1, -50.0};
    CHECK(plant_init(&p, &massless, 1, 7u) == -1 && p.n_fingers == 0);
}

static void test_plant_sensors(void)
{
    const struct finger_params f = {0.05, 0.095, 0.85, 0.57, 0.0031, 8.9535e-3, 0.1, -50.0};
    static struct plant p;
    plant_init(&p, &f, 1, 7u);
    double mv_sum = 0.0;
    for (int i = 0; i < 1000; i++) {
        mv_sum += plant_adc(&p, 1) * 5000.0 / 4095.0;
    }
    CHECK(fabs(mv_sum / 1000.0 - 500.0) < 2.0); /* 0 deg: (0 - -50) / 0.1 = 500 mV */
    double kpa_sum = 0.0;
    for (int i = 0; i < 1000; i++) {
        kpa_sum += (plant_adc(&p, 0) * 5000.0 / 4095.0 - 200.0) / 6.4;
    }
    CHECK(fabs(kpa_sum / 1000.0) < 0.2);
    CHECK(plant_adc(&p, 2) == 0u); /* no such finger */
}

int main(void)
{
    test_iso6358();
    test_valve_delay_and_fill();
    test_closed_chamber_compresses_as_it_grows();
    test_finger_static_gain();
    test_plant_steps_the_finger_exactly();
    test_plant_sensors();
    if (failures) {
        fprintf(stderr, "test-plant: %d check(s) failed\n", failures);
        return EXIT_FAILURE;
    }
    printf("test-plant: all passed\n");
    return EXIT_SUCCESS;
}
