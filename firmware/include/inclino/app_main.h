/*
 * app_main.h - the probe's main loop: SCI bytes in through the HAL, the
 * protocol (proto_cmd) on top of the application (probe.h), answers out
 * through a transmit queue.  On the probe, main() calls app_main_init() once
 * and app_main_poll() forever; the emulator calls app_main_poll() from its
 * step loop.
 */
#ifndef INCLINO_APP_MAIN_H
#define INCLINO_APP_MAIN_H

#include <stdint.h>

/* Transmit queue: large enough for the largest answer plus a stream frame. */
#define APP_TX_QUEUE 512u

/* Product string of the identity record (16 bytes, NUL-padded). */
#define APP_PRODUCT "INCLINO-PROBE"

/*
 * app_main_init - hal_init(), probe_init(), protocol reset.  Returns the
 *   probe_init() status (the probe answers on the SCI even when a sensor
 *   failed its start-up: IDENTIFY reports which).
 */
uint8_t app_main_init(void);

/*
 * app_main_poll - one pass of the main loop: move received bytes into the
 *   protocol, drop a partial frame after PROTO_IDLE_MS of silence, run the
 *   survey stream, and hand queued bytes to the SCI transmitter while it
 *   accepts them.  Never blocks; a survey (when one is requested) takes the
 *   acquisition's time.
 */
void app_main_poll(void);

/* app_main_tx_dropped - bytes lost because the transmit queue was full. */
uint32_t app_main_tx_dropped(void);

/* app_main_restart_requested - 1 after a RESET (2 after BOOTLOADER) was
 *   answered and the answer has left the transmit queue; the probe then
 *   jumps to its reset vector, the emulator reboots the firmware.  Cleared
 *   by app_main_init(). */
uint8_t app_main_restart_requested(void);

#endif /* INCLINO_APP_MAIN_H */
