/*
 * rtcore: the real-time core of a pneumatic soft hand's controller (1 to 8 fingers), as
 * one header per C unit, all included here:
 *
 *   rtcore_step.h   the 100 Hz control step: filter, model (PRBM and effects), PID, the
 *                   step's configs and state, its inputs and outputs, the return codes
 *                   (csrc/rtcore_config.c, rtcore_step.c, rtcore_filter.c, rtcore_model.c,
 *                   rtcore_pid.c)
 *   rtcore_pneumatic.h  the simulator's pneumatic valve mode (rtcore_pneumatic.c over the
 *                   board's board/plant/pneumatics.c and board/core/regulator.c)
 *   rtcore_exact.h  the exact linear finger's propagators and their cache (rtcore_exact.c)
 *   rtcore_sim_plant.h  the simulated finger's dynamics, the one finger simulator, alone
 *                   for a caller that drives the chamber (rtcore_sim_plant.c,
 *                   rtcore_sim_step_size.c, rtcore_sim_span.c, rtcore_exact.c)
 *   rtcore_sim.h    the simulated hand on top: valve, sensors, and its in-process link
 *                   (rtcore_sim.c, rtcore_sim_advance.c, rtcore_sim_link.c)
 *   rtcore_clock.h  the supervisor's clock and deadline schedule (rtcore_clock.c)
 *   rtcore_ring.h   the recording ring (rtcore_ring.c)
 *   rtcore_gate.h   the safety gate (rtcore_gate.c)
 *   rtcore_tick.h   the supervisor's tick, also on the simulated link (rtcore_tick.c)
 *   rtcore_can.h    the host's can-v1 codec and the tick over it (rtcore_can.c, around
 *                   the pack/unpack cantools generates from the DBC at build time)
 *
 * Internals shared between the units are in rtcore_internal.h, not part of the API.
 *
 * Rules: C99, every piece of state in caller-allocated structs, no heap, no mutable
 * globals, no callbacks. Every exported symbol starts with rtcore_ (glibc exports a
 * legacy step() of its own). Physical quantities carry their unit in their name.
 *
 * Each header above has one block between CDEF markers. rtcore/_build.py joins those
 * blocks, in the dependency order listed there, and hands them to cffi, so the Python
 * binding can never drift from the headers; API mode then compiles this header, so the C
 * compiler checks every declaration against the real definitions. This header has no
 * CDEF block of its own.
 */
#ifndef RTCORE_H
#define RTCORE_H

#include "rtcore_step.h"
#include "rtcore_pneumatic.h"
#include "rtcore_exact.h"
#include "rtcore_sim_plant.h"
#include "rtcore_sim.h"
#include "rtcore_clock.h"
#include "rtcore_ring.h"
#include "rtcore_gate.h"
#include "rtcore_tick.h"
#include "rtcore_can.h"

#endif /* RTCORE_H */
