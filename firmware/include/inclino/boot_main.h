/*
 * boot_main.h - the bootloader's main loop: SCI bytes in through the HAL,
 * the bootloader's command layer (boot.h) on them, answers out through a
 * transmit queue.  The same shape as app_main.h.
 *
 * On the probe the reset vector leads to the bootloader (protected area),
 * which calls boot_select(): BOOT_SEL_APP jumps to the application,
 * BOOT_SEL_LOADER runs boot_main_init() once and boot_main_poll() forever.
 * The emulator (emulator/inclino_emu/probe.py) makes the same choice at every boot and
 * calls boot_main_poll() from its step loop while the bootloader runs.
 */
#ifndef INCLINO_BOOT_MAIN_H
#define INCLINO_BOOT_MAIN_H

#include <stdint.h>

/* Transmit queue: the largest answer (208 bytes) twice, and a text line. */
#define BOOT_TX_QUEUE 512u

/*
 * boot_main_init - hal_init(), then the command layer (boot_init: identity
 *   record, descriptor).  Returns boot_app_check()'s status of the flash as
 *   it is (BOOT_OK: a valid application is present).
 */
uint8_t boot_main_init(void);

/*
 * boot_main_poll - one pass of the loop: move received bytes into the
 *   command layer, drop a partial frame after PROTO_IDLE_MS of silence,
 *   hand queued bytes to the SCI transmitter.  Never blocks; a command
 *   takes its flash operations' time (an erase 20 ms, a CRC of the whole
 *   P-Flash a few hundred ms on the probe).
 */
void boot_main_poll(void);

/* boot_main_tx_dropped - bytes lost because the transmit queue was full. */
uint32_t boot_main_tx_dropped(void);

/*
 * boot_main_restart_requested - BOOT_AFTER_RESET after a RESET, or
 *   BOOT_AFTER_RUN after a RUN, once the answer has left the transmit
 *   queue; else 0.  The probe then resets (RESET) or jumps to the
 *   application's entry (RUN); the emulator boots again through
 *   boot_select(0).  Cleared by boot_main_init().
 */
uint8_t boot_main_restart_requested(void);

#endif /* INCLINO_BOOT_MAIN_H */
