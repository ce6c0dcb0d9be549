/* The hand the host build's plant simulates by default: the five fingers of the shipped
 * profiles (firmware_profiles/sim.yaml's hand block, the default hand of docs/physics.md
 * section 2), in the profile's order. tests/board/test_board_build.py checks these numbers
 * against the profile, so the two cannot drift apart. */
#include "host.h"

const struct finger_params host_default_hand[HOST_DEFAULT_FINGERS] = {
    /* mass_kg, length_m, gamma, k N*m/rad, B N*m*s/rad, N N*m/kPa, sensor deg/mV, offset deg */
    {0.045, 0.075, 0.85, 0.6541, 0.0011, 8.2197e-3, 0.095, -47.5},    /* thumb */
    {0.050, 0.095, 0.85, 0.570, 0.0031, 8.9535e-3, 0.1, -50.0},       /* index */
    {0.052, 0.100, 0.85, 0.5778, 0.00127, 1.2101e-2, 0.105, -52.5},   /* middle */
    {0.050, 0.095, 0.85, 0.5069, 0.00178, 7.9624e-3, 0.098, -49.0},   /* ring */
    {0.042, 0.080, 0.85, 0.5886, 0.0011224, 9.2457e-3, 0.102, -51.0}, /* little */
};

const char *const host_default_finger_names[HOST_DEFAULT_FINGERS] = {"thumb", "index", "middle", "ring", "little"};
