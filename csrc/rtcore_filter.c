/* Butterworth low-pass design (bilinear transform with prewarping) and the
 * second-order sections it runs as. */
#include <math.h>

#include "rtcore_internal.h"
#include "rtcore_step.h"

/* One low-pass section of an analogue prototype 1/(u^2 + u/q + 1), u = s/wc, mapped by
 * the bilinear transform with the cutoff prewarped: tan_half = tan(pi*fc/fs). */
void rtcore_biquad_design_lowpass(rtcore_biquad *bq, double tan_half, double q)
{
    const double k2 = tan_half * tan_half;
    const double a0 = 1.0 + tan_half / q + k2;
    bq->b0 = k2 / a0;
    bq->b1 = 2.0 * k2 / a0;
    bq->b2 = k2 / a0;
    bq->a1 = 2.0 * (k2 - 1.0) / a0;
    bq->a2 = (1.0 - tan_half / q + k2) / a0;
    bq->z1 = 0.0;
    bq->z2 = 0.0;
}

/* Set the state to the steady state of a constant input x. */
void rtcore_biquad_prime(rtcore_biquad *bq, double x)
{
    const double gain = (bq->b0 + bq->b1 + bq->b2) / (1.0 + bq->a1 + bq->a2);
    const double y = gain * x;
    bq->z2 = bq->b2 * x - bq->a2 * y;
    bq->z1 = bq->b1 * x - bq->a1 * y + bq->z2;
}

/* Direct form II transposed. */
double rtcore_biquad_run(rtcore_biquad *bq, double x)
{
    const double y = bq->b0 * x + bq->z1;
    bq->z1 = bq->b1 * x - bq->a1 * y + bq->z2;
    bq->z2 = bq->b2 * x - bq->a2 * y;
    return y;
}

/* Pole of a first-order low-pass, exact for a constant input over one sample. */
double rtcore_first_order_alpha(double cutoff_hz, double dt_s)
{
    return exp(-2.0 * RTCORE_PI * cutoff_hz * dt_s);
}

int32_t rtcore_butter_sections(rtcore_biquad *sections, int32_t max_sections, int32_t order,
                               double cutoff_hz, double sample_rate_hz)
{
    int32_t n_sections;
    int32_t k;
    double tan_half;

    if (sections == 0) {
        return RTCORE_ERR_NULL;
    }
    if (order != 2 && order != 4) {
        return RTCORE_ERR_FILTER_ORDER;
    }
    if (!isfinite(sample_rate_hz) || !(sample_rate_hz > 0.0)) {
        return RTCORE_ERR_SAMPLE_RATE;
    }
    if (!isfinite(cutoff_hz) || !(cutoff_hz > 0.0) || !(cutoff_hz < 0.5 * sample_rate_hz)) {
        return RTCORE_ERR_FILTER_CUTOFF;
    }
    n_sections = order / 2;
    if (max_sections < n_sections) {
        return RTCORE_ERR_FILTER_ORDER;
    }
    tan_half = tan(RTCORE_PI * cutoff_hz / sample_rate_hz);
    for (k = 0; k < n_sections; ++k) {
        /* the k-th conjugate pole pair of the prototype: 1/q = 2 sin(pi (2k+1) / 2n) */
        const double q = 1.0 / (2.0 * sin(RTCORE_PI * (double)(2 * k + 1) / (double)(2 * order)));
        rtcore_biquad_design_lowpass(&sections[k], tan_half, q);
    }
    return n_sections;
}

int32_t rtcore_butter_design(int32_t order, double cutoff_hz, double sample_rate_hz,
                             double *sos_out, int32_t max_sections)
{
    rtcore_biquad sections[RTCORE_MAX_SECTIONS];
    int32_t n_sections;
    int32_t k;

    if (sos_out == 0) {
        return RTCORE_ERR_NULL;
    }
    n_sections = rtcore_butter_sections(sections, max_sections < RTCORE_MAX_SECTIONS
                                                      ? max_sections : RTCORE_MAX_SECTIONS,
                                        order, cutoff_hz, sample_rate_hz);
    for (k = 0; k < n_sections; ++k) {
        sos_out[6 * k + 0] = sections[k].b0;
        sos_out[6 * k + 1] = sections[k].b1;
        sos_out[6 * k + 2] = sections[k].b2;
        sos_out[6 * k + 3] = 1.0;
        sos_out[6 * k + 4] = sections[k].a1;
        sos_out[6 * k + 5] = sections[k].a2;
    }
    return n_sections;
}
