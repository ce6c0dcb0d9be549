/* The simulator's integrator: the plain linear finger exact against closed forms at one
 * step per sample and over spans of held samples (under-, critically and over-damped,
 * undamped), no overflow however stiff the plant and long the step, a diverging finger
 * that ends its run, a sliver of a segment that changes nothing, spans against a step
 * per sample, and a damped contact. */
#include "check.h"

static rtcore_sim_finger plain_finger(double inertia, double damping, double stiffness)
{
    rtcore_sim_finger f;
    memset(&f, 0, sizeof(f));
    f.prbm.inertia_kgm2 = inertia;
    f.prbm.damping_nms_per_rad = damping;
    f.prbm.stiffness_nm_per_rad = stiffness;
    f.prbm.pressure_gain_nm_per_kpa = 0.01;
    f.prbm.lever_arm_m = 0.04;
    f.prbm.effects.coulomb_smoothing_deg_per_s = 2.0;
    f.prbm.effects.asymmetric_stiffness_ratio = 1.0;
    f.supply_max_kpa = 300.0;
    f.sensor_gain_deg_per_mv = 1.0;
    return f;
}

/* θ(t) of A·θ'' + B·θ' + k·θ = 0 from θ(0) = theta0 at rest, by the textbook case */
static double free_decay(double a, double b, double k, double theta0, double t)
{
    const double sigma = b / (2.0 * a);
    const double disc = sigma * sigma - k / a;
    if (disc > 0.0) {
        const double d = sqrt(disc);
        const double l1 = -sigma + d;
        const double l2 = -sigma - d;
        return theta0 * (l1 * exp(l2 * t) - l2 * exp(l1 * t)) / (l1 - l2);
    }
    if (disc < 0.0) {
        const double w = sqrt(-disc);
        return theta0 * exp(-sigma * t) * (cos(w * t) + sigma / w * sin(w * t));
    }
    return theta0 * (1.0 + sigma * t) * exp(-sigma * t);
}

static void check_free_decay(double a, double b, double k, double rate_hz, const char *name)
{
    enum { N = 40 };
    const rtcore_sim_finger f = plain_finger(a, b, k);
    double command[N];
    double angle[N];
    double worst = 0.0;
    int i;
    for (i = 0; i < N; ++i) {
        command[i] = 0.0;
    }
    int substeps;
    for (substeps = 1; substeps >= 0; --substeps) { /* 0: the held zero is one span */
        CHECK(rtcore_sim_run(&f, rate_hz, substeps, N, command, 30.0, 0.0, 0.0, angle, 0) == RTCORE_OK, "%s runs",
              name);
        for (i = 0; i < N; ++i) {
            const double exact = free_decay(a, b, k, 30.0, (double)i / rate_hz);
            worst = fmax(worst, fabs(angle[i] - exact));
        }
        CHECK(worst < 1e-9, "%s, substeps %d: exact (%g deg off)", name, substeps, worst);
    }
}

/* a step of pressure from rest: θss − (the free decay from θss), whatever the step */
static void check_stiff_long_steps(void)
{
    enum { N = 6 };
    const rtcore_sim_finger f = plain_finger(1e-6, 1.0, 0.5); /* B/A = 1e6/s: d·h ~ 2e6 */
    const double static_deg = 0.01 * 100.0 / 0.5 * 180.0 / PI;
    double command[N];
    double angle[N];
    int i;
    for (i = 0; i < N; ++i) {
        command[i] = 100.0;
    }
    CHECK(rtcore_sim_run(&f, 0.25, 1, N, command, 0.0, 0.0, 0.0, angle, 0) == RTCORE_OK, "stiff runs");
    for (i = 1; i < N; ++i) {
        const double exact = static_deg - free_decay(1e-6, 1.0, 0.5, static_deg, 4.0 * (double)i);
        CHECK(isfinite(angle[i]) && fabs(angle[i] - exact) < 1e-9 * static_deg,
              "a slow mode of 2 s against a fast one of 1 us, one step per 4 s sample: %.12g, exact %.12g",
              angle[i], exact);
    }
}

/* a softening spring that runs away: the run ends, the angle goes non-finite or huge */
static void check_divergence_ends(void)
{
    enum { N = 200 };
    rtcore_sim_finger f = plain_finger(1.6e-4, 0.003, 0.57);
    double command[N];
    double angle[N];
    double chamber[N];
    int i;
    f.prbm.effects.cubic_stiffness_nm_per_rad3 = -5.0;
    f.prbm.effects.quadratic_damping_nms2_per_rad2 = 0.001;
    for (i = 0; i < N; ++i) {
        command[i] = i == 7 ? (double)NAN : 200.0;
    }
    CHECK(rtcore_sim_run(&f, 100.0, 10, N, command, 0.0, 0.0, 0.0, angle, chamber) == RTCORE_OK, "runs away");
    CHECK(!isfinite(angle[N - 1]) || fabs(angle[N - 1]) > 1e6, "diverged: %g deg", angle[N - 1]);
    CHECK(chamber[N - 1] == 200.0 && chamber[8] == 0.0, "the chamber still follows (a NaN vents): %g, %g",
          chamber[N - 1], chamber[8]);
    f.prbm.effects.quadratic_damping_nms2_per_rad2 = 0.0; /* spans of it, at 1 kHz */
    CHECK(rtcore_sim_run(&f, 1000.0, 0, N, command, 0.0, 0.0, 0.0, angle, chamber) == RTCORE_OK, "runs away");
    CHECK(!isfinite(angle[N - 1]) || fabs(angle[N - 1]) > 1e6, "diverged over spans: %g deg", angle[N - 1]);
    CHECK(chamber[N - 1] == 200.0 && chamber[8] == 0.0, "the chamber still follows: %g, %g", chamber[N - 1],
          chamber[8]);
}

/* Held levels at 1 kHz with the steps left to the dynamics (substeps 0): spans of several
 * periods, cut by the object's surface and the dead zone's crossing, agree with a step per
 * sample; a negative substeps is refused. */
static void check_spans(void)
{
    enum { N = 3000 };
    static double command[N];
    static double spanned[N];
    static double stepped[N];
    static double chamber_spanned[N];
    static double chamber_stepped[N];
    rtcore_sim_finger f = plain_finger(1.6e-4, 0.003, 0.57);
    double worst = 0.0;
    double lowest = INFINITY;
    double highest = -INFINITY;
    int i;
    f.prbm.effects.valve_lag_tau_s = 0.03;
    f.prbm.effects.dead_time_s = 0.0137;
    f.prbm.effects.gravity_torque_nm = 0.05;
    f.prbm.effects.pressure_deadzone_kpa = 20.0;
    f.contact_angle_deg = 40.0;
    f.contact_stiffness_n_per_m = 2000.0;
    f.contact_damping_ns_per_m = 5.0;
    for (i = 0; i < N; ++i) {
        command[i] = (double)((i / 300) * 37 % 120); /* a level every 0.3 s */
    }
    int friction;
    for (friction = 0; friction < 2; ++friction) { /* with dry friction: the cubic inside a step */
        f.prbm.effects.coulomb_torque_nm = friction ? 0.01 : 0.0;
        CHECK(rtcore_sim_run(&f, 1000.0, 0, N, command, -5.0, 0.0, 0.0, spanned, chamber_spanned) == RTCORE_OK,
              "spans");
        CHECK(rtcore_sim_run(&f, 1000.0, 1, N, command, -5.0, 0.0, 0.0, stepped, chamber_stepped) == RTCORE_OK,
              "steps");
        for (i = 0; i < N; ++i) {
            worst = fmax(worst, fabs(spanned[i] - stepped[i]));
            lowest = fmin(lowest, stepped[i]);
            highest = fmax(highest, stepped[i]);
            CHECK(fabs(chamber_spanned[i] - chamber_stepped[i]) < 1e-9, "chamber at %d: %g against %g", i,
                  chamber_spanned[i], chamber_stepped[i]);
        }
        CHECK(highest > 40.0 && worst < 1e-4 * (highest - lowest),
              "friction %d: spans within 1e-4 of the range: %g deg of %g", friction, worst, highest - lowest);
    }
    CHECK(rtcore_sim_run(&f, 1000.0, -1, N, command, 0.0, 0.0, 0.0, spanned, 0) == RTCORE_ERR_SAMPLE_RATE,
          "substeps -1 refused");
}

/* a dead time a hair above 0 leaves a sliver of a segment: no NaN from it, and no change */
static void check_sliver_of_a_segment(void)
{
    enum { N = 20 };
    rtcore_sim_finger f = plain_finger(1.6e-4, 0.003, 0.57);
    double command[N];
    double plain[N];
    double sliver[N];
    int i;
    f.prbm.effects.valve_lag_tau_s = 0.03;
    f.prbm.effects.gravity_torque_nm = 0.01;
    for (i = 0; i < N; ++i) {
        command[i] = 10.0 * (double)(i % 7);
    }
    CHECK(rtcore_sim_run(&f, 100.0, 1, N, command, 0.0, 0.0, 0.0, plain, 0) == RTCORE_OK, "runs");
    f.prbm.effects.dead_time_s = 1e-200;
    CHECK(rtcore_sim_run(&f, 100.0, 1, N, command, 0.0, 0.0, 0.0, sliver, 0) == RTCORE_OK, "runs");
    for (i = 0; i < N; ++i) {
        CHECK(isfinite(sliver[i]) && fabs(sliver[i] - plain[i]) < 1e-12, "sample %d: %g against %g", i,
              sliver[i], plain[i]);
    }
}

/* A valve that vents slower than it fills (valve_vent_tau_s): the chamber rises with the
 * fill's lag and falls with the vent's, each exactly, in steps per sample and in spans. */
static void check_vent_lag(void)
{
    enum { N = 1000 };
    static double command[N];
    static double angle[N];
    static double chamber[N];
    rtcore_sim_finger f = plain_finger(1.6e-4, 0.003, 0.57);
    const double fill_s = 0.02;
    const double vent_s = 0.08;
    const double dt_s = 1e-3;
    int32_t substeps;
    int i;
    f.prbm.effects.valve_lag_tau_s = fill_s;
    f.prbm.effects.valve_vent_tau_s = vent_s;
    for (i = 0; i < N; ++i) {
        command[i] = i < N / 2 ? 100.0 : 0.0;
    }
    for (substeps = 0; substeps <= 1; ++substeps) {
        const double top_kpa = 100.0 * (1.0 - exp(-0.5 / fill_s));
        CHECK(rtcore_sim_run(&f, 1.0 / dt_s, substeps, N, command, 0.0, 0.0, 0.0, angle, chamber) == RTCORE_OK,
              "runs");
        for (i = 0; i < N; ++i) {
            const double t_s = (double)i * dt_s; /* the sample's output is the state it starts from */
            const double expected = i <= N / 2 ? 100.0 * (1.0 - exp(-t_s / fill_s))
                                              : top_kpa * exp(-(t_s - 0.5) / vent_s);
            CHECK(fabs(chamber[i] - expected) < 1e-9, "substeps %d, sample %d: %.12g against %.12g", substeps, i,
                  chamber[i], expected);
        }
    }
    f.prbm.effects.valve_vent_tau_s = -0.01;
    CHECK(rtcore_sim_run(&f, 1.0 / dt_s, 1, N, command, 0.0, 0.0, 0.0, angle, chamber) != RTCORE_OK,
          "a negative vent lag refused");
}

/* The loop in the angle: after a long travel up, z has turned over to +1, so a finger held
 * at p rests at (N·p − T)/k, below the plain finger's N·p/k; after travelling back down far
 * enough, at (N·p + T)/k above it. Steps per sample and spans alike. A loop without a travel
 * is refused. */
static void check_hysteresis_loop(void)
{
    enum { N = 600 };
    static double command[N];
    static double angle[N];
    rtcore_sim_finger f = plain_finger(1e-5, 0.05, 0.5); /* over-damped: rests within 0.1 s */
    const double torque_nm = 0.05;
    int32_t substeps;
    int i;
    f.hysteresis_torque_nm = torque_nm;
    f.hysteresis_travel_deg = 2.0;
    for (i = 0; i < N; ++i) { /* up to 80 kPa over 2 s, held 1 s; from 160 kPa down to 80, held */
        command[i] = i < 300 ? fmin(80.0, 0.4 * (double)i) : fmax(80.0, 160.0 - 0.4 * (double)(i - 300));
    }
    command[300] = 160.0;
    for (substeps = 0; substeps <= 1; ++substeps) {
        const double up_deg = (0.01 * 80.0 - torque_nm) / 0.5 * 180.0 / 3.141592653589793;
        const double down_deg = (0.01 * 80.0 + torque_nm) / 0.5 * 180.0 / 3.141592653589793;
        CHECK(rtcore_sim_run(&f, 100.0, substeps, N, command, 0.0, 0.0, 0.0, angle, 0) == RTCORE_OK, "runs");
        CHECK(fabs(angle[299] - up_deg) < 1e-3, "substeps %d: rests at %.6f deg after the way up, not %.6f",
              (int)substeps, angle[299], up_deg);
        CHECK(fabs(angle[N - 1] - down_deg) < 1e-3, "substeps %d: rests at %.6f deg after the way down, not %.6f",
              (int)substeps, angle[N - 1], down_deg);
    }
    f.hysteresis_travel_deg = 0.0;
    CHECK(rtcore_sim_run(&f, 100.0, 0, N, command, 0.0, 0.0, 0.0, angle, 0) == RTCORE_ERR_MODEL,
          "a loop without a travel is refused");
}

/* the contact effect with its Kelvin-Voigt damper: not static (a held level settles where
 * the undamped contact does, to the ringing left after 1.5 s), it damps the arrival (less
 * overshoot), spans agree with a step per sample, and a negative damper is refused */
static void check_damped_contact(void)
{
    enum { N = 3000 };
    static double command[N];
    static double damped[N];
    static double undamped[N];
    static double stepped[N];
    rtcore_sim_finger f = plain_finger(1.6e-4, 0.003, 0.57);
    double peak_damped = -INFINITY;
    double peak_undamped = -INFINITY;
    double worst = 0.0;
    int i;
    f.prbm.effects.contact_stiffness_nm_per_radn = 5.0;
    f.prbm.effects.contact_onset_deg = 20.0;
    f.prbm.effects.contact_exponent = 1.5;
    for (i = 0; i < N; ++i) {
        command[i] = i < N / 2 ? 120.0 : 60.0; /* a step past the onset, then one back toward it */
    }
    CHECK(rtcore_sim_run(&f, 1000.0, 1, N, command, 0.0, 0.0, 0.0, undamped, 0) == RTCORE_OK, "undamped runs");
    f.prbm.effects.contact_damping_nms_per_rad = 0.05;
    CHECK(rtcore_sim_run(&f, 1000.0, 1, N, command, 0.0, 0.0, 0.0, stepped, 0) == RTCORE_OK, "damped runs");
    CHECK(rtcore_sim_run(&f, 1000.0, 0, N, command, 0.0, 0.0, 0.0, damped, 0) == RTCORE_OK, "damped spans");
    for (i = 0; i < N; ++i) {
        CHECK(isfinite(damped[i]), "damped angle %d finite", i);
        worst = fmax(worst, fabs(damped[i] - stepped[i]));
        if (i < N / 2) {
            peak_damped = fmax(peak_damped, stepped[i]);
            peak_undamped = fmax(peak_undamped, undamped[i]);
        }
    }
    CHECK(fabs(stepped[N / 2 - 1] - undamped[N / 2 - 1]) < 1e-4 && fabs(stepped[N - 1] - undamped[N - 1]) < 1e-4,
          "the damper is not static: %g and %g against %g and %g", stepped[N / 2 - 1], stepped[N - 1],
          undamped[N / 2 - 1], undamped[N - 1]);
    CHECK(stepped[N / 2 - 1] > 20.0 && peak_damped < peak_undamped,
          "past the onset (%g deg), the damper takes overshoot: peak %g against %g", stepped[N / 2 - 1],
          peak_damped, peak_undamped);
    CHECK(worst < 1e-4 * (peak_damped - stepped[0]), "spans within 1e-4 of the range: %g deg", worst);
    f.prbm.effects.contact_damping_nms_per_rad = -0.01;
    CHECK(rtcore_sim_run(&f, 1000.0, 1, N, command, 0.0, 0.0, 0.0, stepped, 0) != RTCORE_OK,
          "a negative contact damping is refused");
}

void run_sim_tests(void)
{
    const double a = 1.6e-4;
    const double k = 0.57;
    const double critical = 2.0 * sqrt(k * a);
    check_free_decay(a, 0.003, k, 25.0, "under-damped");
    check_free_decay(a, 0.0, k, 100.0, "undamped");
    check_free_decay(a, critical, k, 25.0, "critically damped");
    check_free_decay(a, critical * (1.0 + 1e-7), k, 25.0, "a hair over critical");
    check_free_decay(a, critical * (1.0 - 1e-7), k, 25.0, "a hair under critical");
    check_free_decay(1e-5, 0.05, 0.5, 25.0, "over-damped (B/A = 5000/s)");
    check_free_decay(1e-5, 0.2, 0.5, 1000.0, "over-damped (B/A = 20000/s) at 1 kHz");
    check_stiff_long_steps();
    check_divergence_ends();
    check_sliver_of_a_segment();
    check_spans();
    check_vent_lag();
    check_hysteresis_loop();
    check_damped_contact();
}
