/* Start-up of the Cortex-M7 image: the vector table, the reset handler (copy .data, zero
 * .bss, enable the FPU, call main) and the fault handlers. No C library start files, no
 * heap. */
#include <stdint.h>

#include "mps2.h"

/* the linker script's symbols: addresses, not objects (their difference is the size) */
extern uint32_t _data_load[], _data_start[], _data_end[], _bss_start[], _bss_end[], _stack_top[];

int main(void);
void reset_handler(void);
void default_handler(void);

void default_handler(void)
{
    /* an unexpected exception or fault: stop with every valve as it is. On a real board the
     * hardware watchdog then resets the MCU, which boots vented; QEMU's machine has none, so
     * the image spins here and the host sees the board go silent. */
    for (;;) {
    }
}

void reset_handler(void)
{
    const uintptr_t data_words = ((uintptr_t)_data_end - (uintptr_t)_data_start) / sizeof(uint32_t);
    for (uintptr_t i = 0u; i < data_words; i++) {
        _data_start[i] = _data_load[i];
    }
    const uintptr_t bss_words = ((uintptr_t)_bss_end - (uintptr_t)_bss_start) / sizeof(uint32_t);
    for (uintptr_t i = 0u; i < bss_words; i++) {
        _bss_start[i] = 0u;
    }
    SCB_CPACR |= (0xFu << 20); /* CP10 and CP11: full access to the FPU */
    __asm__ volatile("dsb\n\tisb" ::: "memory");
    (void)main();
    for (;;) {
    }
}

typedef void (*vector_fn)(void);

/* 16 system exceptions, then the external interrupts up to timer 0's (IRQ 8) */
__attribute__((section(".vectors"), used)) static const vector_fn vectors[16 + 9] = {
    (vector_fn)(uintptr_t)_stack_top,
    reset_handler,
    default_handler, /* NMI */
    default_handler, /* HardFault */
    default_handler, /* MemManage */
    default_handler, /* BusFault */
    default_handler, /* UsageFault */
    0, 0, 0, 0,
    default_handler, /* SVCall */
    default_handler, /* DebugMon */
    0,
    default_handler, /* PendSV */
    default_handler, /* SysTick (not enabled: the clock reads its counter) */
    uart0_rx_handler, /* IRQ 0: UART0 RX */
    default_handler,  /* IRQ 1: UART0 TX (not enabled) */
    default_handler, default_handler, default_handler, /* IRQ 2-4: UART1, UART2 (not enabled) */
    default_handler, default_handler, default_handler, /* IRQ 5-7 (not enabled) */
    timer0_handler,   /* IRQ 8: timer 0, the main loop's wake-up */
};
