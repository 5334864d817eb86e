/* SPDX-License-Identifier: Apache-2.0 */
/* Bare-metal start for the Cortex-M7 model (qemu-system-arm -M mps2-an500): vector table, FPU on,
 * .bss cleared, newlib's semihosting handles opened (librdimon), static constructors, main, exit.
 * qemu loads every section of the ELF at its address, so .data needs no copy here. Faults end the run
 * through semihosting with a message instead of hanging. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

extern uint32_t __bss_start__[], __bss_end__[], __stack_top[];
extern int main(int argc, char **argv);
extern void initialise_monitor_handles(void);
extern void __libc_init_array(void);

void tvo_mcu_reset(void);
void tvo_mcu_fault(void);
void _init(void);
void _fini(void);

/* __libc_init_array / __libc_fini_array call these (crti.o's, which -nostartfiles leaves out) */
void _init(void)
{
}

void _fini(void)
{
}

void tvo_mcu_reset(void)
{
    uint32_t *p;
    /* CPACR: full access to CP10/CP11 (the FPU) before any floating-point instruction */
    *(volatile uint32_t *)0xE000ED88u |= 0xFu << 20;
    __asm volatile("dsb\n\tisb" ::: "memory");
    for (p = __bss_start__; p < __bss_end__; ++p)
        *p = 0;
    initialise_monitor_handles();
    __libc_init_array();
    exit(main(0, NULL));
}

void tvo_mcu_fault(void)
{
    uint32_t ipsr;
    __asm volatile("mrs %0, ipsr" : "=r"(ipsr));
    printf("mcu: FAIL fault, exception %lu\n", (unsigned long)(ipsr & 0x1FFu));
    exit(3);
}

/* Initial stack pointer, reset, then NMI .. SysTick: every other exception is a failure. */
__attribute__((section(".vectors"), used)) static void (*const tvo_mcu_vectors[16])(void) = {
        (void (*)(void))(uintptr_t)__stack_top,
        tvo_mcu_reset,
        tvo_mcu_fault,
        tvo_mcu_fault,
        tvo_mcu_fault,
        tvo_mcu_fault,
        tvo_mcu_fault,
        0,
        0,
        0,
        0,
        tvo_mcu_fault,
        tvo_mcu_fault,
        0,
        tvo_mcu_fault,
        tvo_mcu_fault,
};
