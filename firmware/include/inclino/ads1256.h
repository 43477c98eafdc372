/*
 * ads1256.h - driver of the TI ADS1256 24-bit delta-sigma ADC that
 * digitises the three fluxgate channels, over the HAL (hal_spi_* with
 * HAL_DEV_ADC: SPI mode 1, bytes, CS low for a whole command; DRDY on
 * hal_adc_drdy).
 *
 * Wiring (docs/sensors.md): fluxgate X, Y, Z on AIN0, AIN1, AIN2 against
 * AINCOM, MUX = 0x08, 0x18, 0x28; one count = 1 nT at PGA 1.
 * Configuration: data rate 1000 SPS (settling t18 = 1.18 ms), PGA 1, input
 * buffer off, auto-calibration off, clock output off, self-calibration at
 * start-up.  One conversion per channel: WREG MUX, SYNC, WAKEUP, wait DRDY,
 * RDATA (a fully settled conversion of the new channel, data sheet 9.4.4).
 *
 * Every wait is bounded (DRDY polled at fixed steps up to a timeout); a
 * missing part (MISO pulled up: 0xFF, DRDY never low) is a status.  Status
 * codes 0x20..0x2F (0 = ADS_OK).
 */
#ifndef INCLINO_ADS1256_H
#define INCLINO_ADS1256_H

#include <stdint.h>

/* Commands */
#define ADS_CMD_WAKEUP 0x00u
#define ADS_CMD_RDATA 0x01u
#define ADS_CMD_SDATAC 0x0Fu
#define ADS_CMD_RREG 0x10u
#define ADS_CMD_WREG 0x50u
#define ADS_CMD_SELFCAL 0xF0u
#define ADS_CMD_SYNC 0xFCu
#define ADS_CMD_RESET 0xFEu

/* Registers */
#define ADS_REG_STATUS 0x00u
#define ADS_REG_MUX 0x01u
#define ADS_REG_ADCON 0x02u
#define ADS_REG_DRATE 0x03u

#define ADS_STATUS_ID 0x3u /* STATUS[7:4] of an ADS1256 */
#define ADS_MUX_X 0x08u    /* AIN0 - AINCOM */
#define ADS_MUX_Y 0x18u    /* AIN1 - AINCOM */
#define ADS_MUX_Z 0x28u    /* AIN2 - AINCOM */
#define ADS_DRATE_1000 0xA1u

/* Timing, microseconds */
#define ADS_T6_US 7u        /* command to data: 50 tCLKIN = 6.5 us */
#define ADS_T11_US 4u       /* SYNC to WAKEUP: 24 tCLKIN = 3.1 us */
#define ADS_SETTLE_US 1180u /* t18 at 1000 SPS */
#define ADS_POLL_US 20u     /* DRDY poll step */
#define ADS_CONV_TIMEOUT_US 5000u
#define ADS_CAL_TIMEOUT_US 20000u /* reset / self-calibration (3 x t18 = 3.5 ms) */

/* Status codes */
#define ADS_OK 0x00u
#define ADS_E_ABSENT 0x21u  /* STATUS read 0xFF: no part on the bus */
#define ADS_E_ID 0x22u      /* STATUS[7:4] is not 3: another part */
#define ADS_E_TIMEOUT 0x23u /* DRDY did not fall within the timeout */
#define ADS_E_CONFIG 0x24u  /* registers read back differ from those written */
#define ADS_E_ARG 0x25u     /* invalid argument (register count) */

/*
 * ads_wait_drdy - poll DRDY every ADS_POLL_US until it is low.  timeout_us:
 *   0..65535.  Returns ADS_OK (low), ADS_E_TIMEOUT.  At most
 *   timeout_us / ADS_POLL_US + 1 polls.
 */
uint8_t ads_wait_drdy(uint16_t timeout_us);

/*
 * ads_read_regs - RREG: n (1..11) registers from reg into out[n].  Waits
 *   ADS_T6_US before the data.  Returns ADS_OK or ADS_E_ARG.
 */
uint8_t ads_read_regs(uint8_t reg, uint8_t n, uint8_t *out);

/*
 * ads_write_regs - WREG: n (1..11) registers from in[n] starting at reg.
 *   Returns ADS_OK or ADS_E_ARG.
 */
uint8_t ads_write_regs(uint8_t reg, uint8_t n, const uint8_t *in);

/*
 * ads_command - one single-byte command (SYNC, WAKEUP, SELFCAL, RESET...)
 *   under its own chip select.
 */
void ads_command(uint8_t cmd);

/*
 * ads_init - wait for a running (power-on) calibration to end, RESET,
 *   wait for the reset calibration, check the ID (STATUS
 *   0xFF -> ADS_E_ABSENT, ID != 3 -> ADS_E_ID), write STATUS/MUX/ADCON/DRATE
 *   (0x00, ADS_MUX_X, 0x00, ADS_DRATE_1000) and check them by RREG, run
 *   SELFCAL and wait for it.  Returns ADS_OK or an ADS_E_* status.  Takes
 *   about 5 ms (45 ms for a missing part: two bounded DRDY waits).
 */
uint8_t ads_init(void);

/*
 * ads_read_channel - one settled conversion of input `mux` (ADS_MUX_*):
 *   WREG MUX, SYNC, WAKEUP, wait DRDY (ADS_CONV_TIMEOUT_US), RDATA.
 *   Out: *code, signed 24-bit result (-2^23..2^23-1), written only on
 *   ADS_OK.  Returns ADS_OK or ADS_E_TIMEOUT.  Takes about 1.25 ms.
 */
uint8_t ads_read_channel(uint8_t mux, int32_t *code);

/*
 * ads_sign_extend24 - the 24-bit two's complement code in raw[23:0] as an
 *   int32 (bits 31:24 of raw are ignored).  Exact, no shift of a negative.
 */
int32_t ads_sign_extend24(uint32_t raw);

#endif /* INCLINO_ADS1256_H */
