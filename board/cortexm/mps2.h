/* The registers of QEMU's mps2-an500 machine (an Arm MPS2 board with the AN500 FPGA image:
 * a Cortex-M7 with a double-precision FPU) that the Cortex-M port uses: SysTick and the
 * NVIC (Arm v7-M), two CMSDK APB UARTs and the CMSDK APB watchdog. */
#ifndef BOARD_MPS2_H
#define BOARD_MPS2_H

#include <stdint.h>

#define REG32(addr) (*(volatile uint32_t *)(uintptr_t)(addr))

/* the system clock that drives the CPU, SysTick's processor clock and the APB peripherals */
#define MPS2_SYSCLK_HZ 25000000u

#define SCB_CPACR REG32(0xE000ED88u)

#define SYST_CSR REG32(0xE000E010u)
#define SYST_RVR REG32(0xE000E014u)
#define SYST_CVR REG32(0xE000E018u)
#define SYST_CSR_ENABLE 1u
#define SYST_CSR_CLKSOURCE_CPU 4u

#define NVIC_ISER0 REG32(0xE000E100u)
#define NVIC_UART0_RX_IRQ 0u
#define NVIC_TIMER0_IRQ 8u

/* CMSDK APB timer 0: a periodic interrupt that wakes the main loop from WFI */
#define TIMER0_BASE 0x40000000u
#define TIMER0_CTRL REG32(TIMER0_BASE + 0x00u)
#define TIMER0_RELOAD REG32(TIMER0_BASE + 0x08u)
#define TIMER0_INTCLEAR REG32(TIMER0_BASE + 0x0Cu)
#define TIMER_CTRL_EN 1u
#define TIMER_CTRL_IRQ_EN 8u

/* CMSDK APB UART: UART0 carries serial-v1, UART1 the image's log lines */
#define UART0_BASE 0x40004000u
#define UART1_BASE 0x40005000u
#define UART_DATA(base) REG32((base) + 0x00u)
#define UART_STATE(base) REG32((base) + 0x04u)
#define UART_CTRL(base) REG32((base) + 0x08u)
#define UART_INTCLEAR(base) REG32((base) + 0x0Cu)
#define UART_BAUDDIV(base) REG32((base) + 0x10u)
#define UART_STATE_TX_FULL 1u
#define UART_STATE_RX_FULL 2u
#define UART_CTRL_TX_EN 1u
#define UART_CTRL_RX_EN 2u
#define UART_CTRL_RX_INT_EN 8u
#define UART_INT_RX 2u

/* CMSDK APB watchdog (Arm DDI 0479): the first time-out raises NMI, the second resets */
#define WDOG_BASE 0x40008000u
#define WDOG_LOAD REG32(WDOG_BASE + 0x000u)
#define WDOG_CTRL REG32(WDOG_BASE + 0x008u)
#define WDOG_INTCLR REG32(WDOG_BASE + 0x00Cu)
#define WDOG_LOCK REG32(WDOG_BASE + 0xC00u)
#define WDOG_PERIPHID0 REG32(WDOG_BASE + 0xFE0u)
#define WDOG_CTRL_INTEN 1u
#define WDOG_CTRL_RESEN 2u
#define WDOG_UNLOCK_KEY 0x1ACCE551u
#define WDOG_PERIPHID0_VALUE 0x24u

void uart0_rx_handler(void);
void timer0_handler(void);

#endif
