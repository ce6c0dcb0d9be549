/* One sample period of a simulated finger's valve (csrc/rtcore_sim_advance.c), for the
 * simulated hand above it (rtcore_sim.c): the dead time's history of commands, the lag or
 * the pneumatic valve model, driving the finger's dynamics below it (rtcore_sim_plant.c).
 * Not part of the API: nothing here is in the cffi cdef. */
#ifndef RTCORE_SIM_ADVANCE_H
#define RTCORE_SIM_ADVANCE_H

#include <stdint.h>

#include "rtcore_exact.h"
#include "rtcore_sim.h"
#include "rtcore_sim_internal.h"

/* One sample period after pushing command_kpa, in steps of at most dt_s/substeps. `plant`
 * is rtcore_sim_plant_for(the finger), which a run over many samples derives once. */
void rtcore_sim_advance_sample(const sim_plant *plant, rtcore_sim_finger_state *s,
                               rtcore_propagator_cache *cache, double command_kpa, double dt_s, int32_t substeps);
/* How many of the next `available` sample periods hold one valve input (0 when fewer than
 * two), and that input into held_kpa. */
int32_t rtcore_sim_held_samples(const rtcore_sim_finger *f, const rtcore_sim_finger_state *s, const double *command_kpa,
                                int32_t available, double *held_kpa);
/* `count` sample periods under held_kpa as one segment (rtcore_sim_span.c). */
void rtcore_sim_advance_span(const sim_plant *plant, rtcore_sim_finger_state *s, rtcore_propagator_cache *cache,
                             sim_span *span, const double *command_kpa, int32_t count, double held_kpa,
                             double *chamber_out_kpa);

#endif /* RTCORE_SIM_ADVANCE_H */
