/* Fault injection for test images (inject.h). */
#include "inject.h"

#include <string.h>

void inject_init(struct inject *in, uint32_t seed)
{
    memset(in, 0, sizeof *in);
    in->rng = seed ? seed : 0x2545F491u;
}

void inject_clear(struct inject *in)
{
    memset(in->faults, 0, sizeof in->faults);
    in->count = 0u;
    in->head = 0u;
}

static uint32_t next_random(struct inject *in)
{
    uint32_t x = in->rng; /* xorshift32 */
    x ^= x << 13;
    x ^= x >> 17;
    x ^= x << 5;
    in->rng = x;
    return x;
}

static int time_reached(uint32_t now_us, uint32_t when_us)
{
    return (int32_t)(now_us - when_us) >= 0;
}

void inject_request(struct inject *in, uint8_t kind, uint8_t finger, uint16_t duration_ms, uint16_t value,
                    uint32_t now_us)
{
    if (kind == INJECT_CLEAR) {
        memset(in->faults, 0, sizeof in->faults);
        return;
    }
    if (kind >= INJECT_KINDS) {
        return;
    }
    struct inject_fault *f = &in->faults[kind];
    memset(f, 0, sizeof *f);
    f->active = 1u;
    f->finger = finger;
    f->value = value;
    f->forever = duration_ms == 0u;
    f->until_us = now_us + (uint32_t)duration_ms * 1000u;
    f->since_us = now_us;
    f->order = ++in->order;
}

uint8_t inject_expire(struct inject *in, uint32_t now_us)
{
    uint8_t ended = 0u;
    for (uint8_t k = 0; k < INJECT_KINDS; k++) {
        struct inject_fault *f = &in->faults[k];
        if (f->active && !f->forever && time_reached(now_us, f->until_us)) {
            f->active = 0u;
            ended++;
        }
    }
    return ended;
}

const struct inject_fault *inject_active(const struct inject *in, uint8_t kind)
{
    return kind < INJECT_KINDS && in->faults[kind].active ? &in->faults[kind] : 0;
}

int32_t inject_value(const struct inject *in, uint8_t kind, uint16_t fallback)
{
    const struct inject_fault *f = inject_active(in, kind);
    if (f == 0) {
        return -1;
    }
    return f->value ? (int32_t)f->value : (int32_t)fallback;
}

uint8_t inject_current(const struct inject *in)
{
    uint8_t kind = 0u;
    uint32_t newest = 0u;
    for (uint8_t k = 1; k < INJECT_KINDS; k++) {
        if (in->faults[k].active && in->faults[k].order > newest) {
            newest = in->faults[k].order;
            kind = k;
        }
    }
    return kind;
}

int inject_hits(const struct inject_fault *f, uint8_t finger)
{
    return f != 0 && (f->finger == INJECT_ALL_FINGERS || f->finger == finger);
}

static int percent(struct inject *in, uint8_t kind)
{
    const struct inject_fault *f = inject_active(in, kind);
    return f != 0 && (next_random(in) % 10000u) < (uint32_t)f->value * 100u;
}

int inject_outgoing(struct inject *in, struct board_unit *unit, uint32_t now_us)
{
    if (inject_active(in, INJECT_SILENCE) || inject_active(in, INJECT_BUS_OFF)) {
        return 0;
    }
    if (percent(in, INJECT_DROP)) {
        return 0;
    }
    if (percent(in, INJECT_CORRUPT) && unit->len > 0u) {
        const uint32_t r = next_random(in);
        unit->data[(r >> 3) % unit->len] ^= (uint8_t)(1u << (r & 7u));
    }
    const struct inject_fault *delay = inject_active(in, INJECT_DELAY);
    if (delay == 0 && in->count == 0u) {
        return 1;
    }
    /* first in, first out: nothing overtakes a held frame */
    uint32_t due_us = now_us + (delay ? (uint32_t)delay->value * 1000u : 0u);
    if (in->count > 0u) {
        const uint32_t last_due = in->due_us[(uint16_t)((in->head + in->count - 1u) % INJECT_QUEUE_UNITS)];
        if ((int32_t)(last_due - due_us) > 0) {
            due_us = last_due;
        }
    }
    if (in->count >= INJECT_QUEUE_UNITS) {
        in->queue_dropped++;
        return 0;
    }
    const uint16_t slot = (uint16_t)((in->head + in->count) % INJECT_QUEUE_UNITS);
    in->queue[slot] = *unit;
    in->due_us[slot] = due_us;
    in->count++;
    return 0;
}

int inject_release(struct inject *in, uint32_t now_us, struct board_unit *unit)
{
    if (in->count == 0u || !time_reached(now_us, in->due_us[in->head])) {
        return 0;
    }
    *unit = in->queue[in->head];
    in->head = (uint16_t)((in->head + 1u) % INJECT_QUEUE_UNITS);
    in->count--;
    return 1;
}
