/*
 * hal.h - the hardware abstraction layer of the probe firmware.  Everything
 * above it (drivers, acquisition, calibration storage, the application and
 * the SCI protocol) is the same C on the probe and in the emulator; only the
 * implementation of these functions differs:
 *
 *   firmware/port/s12x/hal_s12x.c  MC9S12XEP100: SPI0, SCI0, PIT, the flash
 *                                  command interface (FCCOB/FSTAT)
 *   emulator/inclino_emu/hal.py                cffi callbacks into the register models
 *                                  (inclino_emu._fw, emulator/inclino_emu/_build_fw.py)
 *
 * Conventions: every function returns; none blocks without a bound.  Times
 * are integers (milliseconds, microseconds); nothing depends on the width of
 * `int` (16 bits on the probe).  Board wiring: docs/firmware-app.md.
 */
#ifndef INCLINO_HAL_H
#define INCLINO_HAL_H

#include <stdint.h>

/*
 * hal_init - set up the peripherals (SPI, SCI, tick timer, flash clock,
 *   chip-select and DRDY pins).  Called once after reset, before anything
 *   else here.  The emulator's version does nothing.
 */
void hal_init(void);

/* ---- SPI ---------------------------------------------------------------
 * One SPI master, one chip select per device.  The HAL selects the clock
 * mode of the device on hal_spi_select: the ADIS16210 runs in SPI mode 3
 * with 16-bit frames, the ADS1256 in mode 1 with bytes.  Bit rate 833 kHz
 * on the probe (40 MHz bus / 48); the emulator charges 16 / 8 bit times of
 * 1.28 us (781.25 kHz) per frame to its clock. */
#define HAL_DEV_ADIS 0u /* ADIS16210 accelerometer, 16-bit frames */
#define HAL_DEV_ADC 1u  /* ADS1256 fluxgate ADC, byte frames */

/*
 * hal_spi_select - take the chip select of `dev` low (and every other one
 *   high) after setting the device's SPI mode.  dev: HAL_DEV_*; any other
 *   value deselects everything.
 */
void hal_spi_select(uint8_t dev);

/*
 * hal_spi_deselect - take every chip select high.  For the ADS1256 this
 *   ends a command (a partly sent command is dropped by the part).
 */
void hal_spi_deselect(void);

/*
 * hal_spi_xfer16 - one 16-bit frame, MSB first, on the selected device.
 *   In: out, the word sent on MOSI.  Returns the word read on MISO (0xFFFF
 *   when nothing drives MISO: pulled up).  The caller frames each word with
 *   hal_spi_select(HAL_DEV_ADIS) / hal_spi_deselect() (the ADIS16210 needs
 *   CS high between frames) and keeps the part's stall time itself.
 */
uint16_t hal_spi_xfer16(uint16_t out);

/*
 * hal_spi_xfer8 - one byte, MSB first, on the selected device.  Returns
 *   the byte read (0xFF when MISO is not driven).
 */
uint8_t hal_spi_xfer8(uint8_t out);

/*
 * hal_adc_drdy - level of the ADS1256 DRDY pin: 0 = low (a conversion is
 *   waiting to be read), 1 = high.  Reads the pin; never waits.
 */
uint8_t hal_adc_drdy(void);

/* ---- time --------------------------------------------------------------- */

/*
 * hal_millis - free-running millisecond tick, wraps modulo 2^32 (49.7
 *   days).  Compare with unsigned subtraction: (uint32_t)(now - then).
 */
uint32_t hal_millis(void);

/*
 * hal_delay_us - wait at least `us` microseconds (0..65535).  Busy-waits
 *   on the probe; advances the emulator's clock.
 */
void hal_delay_us(uint16_t us);

/* ---- SCI (the serial link to the PC) -------------------------------------
 * Byte queues: received bytes wait in a receive buffer (interrupt-filled on
 * the probe, HAL_SCI_RX_BUF bytes; bytes arriving on a full buffer are
 * lost and counted by the HAL); transmitted bytes wait in a transmit buffer
 * of HAL_SCI_TX_BUF bytes that the transmit interrupt empties at the line
 * rate, so the line stays busy while the firmware acquires.  Line settings
 * (baud, 8N1) belong to the HAL (hal_init). */
#define HAL_SCI_RX_BUF 64u
#define HAL_SCI_TX_BUF 128u

/*
 * hal_sci_getc - next received byte, 0..255, or -1 when none is waiting.
 *   Never waits.
 */
int16_t hal_sci_getc(void);

/*
 * hal_sci_putc - hand one byte to the transmitter.  Returns 1 when taken,
 *   0 when the transmitter is full (nothing taken: try again later).  Never
 *   waits.
 */
uint8_t hal_sci_putc(uint8_t byte);

/* ---- flash ---------------------------------------------------------------
 * Addresses are MC9S12XEP100 global addresses (23 bit, P-Flash
 * 0x700000..0x7FFFFF).  Program in aligned 8-byte phrases into erased
 * (0xFF) cells; erase in HAL_FLASH_SECTOR-byte sectors.  docs/flash.md. */
#define HAL_FLASH_PHRASE 8u
#define HAL_FLASH_SECTOR 1024u

/* hal_flash_* results */
#define HAL_FLASH_OK 0u
#define HAL_FLASH_E_ACCESS 1u  /* ACCERR: misaligned or invalid address, bad command */
#define HAL_FLASH_E_PROTECT 2u /* FPVIOL: protected area, nothing changed */
#define HAL_FLASH_E_VERIFY 3u  /* MGSTAT1/0: program or erase verify failed */
#define HAL_FLASH_E_TIMEOUT 4u /* the command never completed (CCIF stayed clear) */

/*
 * hal_flash_read - copy n bytes (0..65535) from global address addr.
 *   Returns HAL_FLASH_OK, or HAL_FLASH_E_ACCESS when the range leaves the
 *   P-Flash (dst untouched then).
 */
uint8_t hal_flash_read(uint32_t addr, uint8_t *dst, uint16_t n);

/*
 * hal_flash_program - program one phrase: data[0..7] at addr, which must
 *   be a multiple of HAL_FLASH_PHRASE and erased.  Returns HAL_FLASH_*.
 *   A non-erased target is the caller's error; the part then reports
 *   HAL_FLASH_E_VERIFY and the cells hold old AND new (docs/flash.md).
 */
uint8_t hal_flash_program(uint32_t addr, const uint8_t *data);

/*
 * hal_flash_erase - erase the sector holding addr (all bytes 0xFF).
 *   Returns HAL_FLASH_*.
 */
uint8_t hal_flash_erase(uint32_t addr);

#endif /* INCLINO_HAL_H */
