/*
 * adis16210.h - driver of the ADIS16210 triaxial inclinometer over the HAL
 * (hal_spi_* with HAL_DEV_ADIS: SPI mode 3, 16-bit frames, CS high between
 * frames).
 *
 * Protocol (data sheet; model in emulator/adis16210.py, docs/sensors.md):
 * a read frame carries (address & 0x7F) << 8 and the register comes back
 * during the next frame, which may carry the next read (pipelining); a write
 * frame carries ((address | 0x80) << 8) | byte, even address = low byte.
 * Frames start at least ADIS_STALL_US apart (the driver waits after each).
 *
 * Errors are statuses, never hangs: a missing part (MISO pulled up: every
 * frame 0xFFFF), a wrong PROD_ID, a part that never answers and a failed
 * self-test each have a code, and every wait has a fixed iteration bound.
 * Status codes 0x10..0x1F (0 = ADIS_OK).
 */
#ifndef INCLINO_ADIS16210_H
#define INCLINO_ADIS16210_H

#include <stdint.h>

/* Registers (even address = low byte).  Addresses, scales and reset values
 * as in Analog Devices' register map for this part (iSensor-FX3-Eval,
 * RegMaps/ADIS16210_RegMap.csv; docs/sensors.md). */
#define ADIS_REG_FLASH_CNT 0x00u
#define ADIS_REG_SUPPLY_OUT 0x02u /* unsigned, 152.6 uV/LSB */
#define ADIS_REG_XACCL_OUT 0x04u
#define ADIS_REG_YACCL_OUT 0x06u
#define ADIS_REG_ZACCL_OUT 0x08u
#define ADIS_REG_TEMP_OUT 0x0Au
#define ADIS_REG_X_ALIGN_REF 0x18u /* read-only, 2^-14 g/LSB; Y, Z at +2, +4 */
#define ADIS_REG_MSC_CTRL 0x34u    /* resets to 0x0002 */
#define ADIS_REG_DIO_CTRL 0x36u    /* resets to 0x0007 */
#define ADIS_REG_AVG_CNT 0x38u     /* resets to 0x0009; adis_init writes ADIS_AVG_CNT */
#define ADIS_REG_DIAG_STAT 0x3Cu
#define ADIS_REG_GLOB_CMD 0x3Eu
#define ADIS_REG_PROD_ID 0x56u
#define ADIS_REG_SERIAL_NUM 0x58u
#define ADIS_REG_X_NULL_BIAS 0x70u /* R/W, 2^-14 g/LSB; Y, Z at +2, +4 (not used) */

#define ADIS_PROD_ID 0x3F52u            /* 16210 */
#define ADIS_MSC_SELF_TEST_AUTO 0x0400u /* MSC_CTRL[10] */
#define ADIS_DIAG_SELF_TEST_FAIL 0x0020u
#define ADIS_DIAG_SPI_FAIL 0x0008u

/* Timing (microseconds / milliseconds) */
#define ADIS_STALL_US 40u /* CS high between frames: data sheet stall time */
/* power-on to first valid answer: not found for this part; the Linux drivers
 * of the ADIS16201/16203/16209 wait 220 ms, the conservative choice */
#define ADIS_STARTUP_MS 220u
#define ADIS_SELF_TEST_MS 40u /* automatic self-test */
/* AVG_CNT = 4: 2^4 internal samples averaged, 4250 / 16 = 265.6 SPS, one
 * output period is 3765 us. */
#define ADIS_AVG_CNT 4u
#define ADIS_PERIOD_US 3765u

/* Status codes */
#define ADIS_OK 0x00u
#define ADIS_E_ABSENT 0x11u      /* every frame read 0xFFFF: no part on the bus */
#define ADIS_E_PROD_ID 0x12u     /* PROD_ID read back is not 0x3F52 (another part) */
#define ADIS_E_NO_RESPONSE 0x13u /* PROD_ID still 0x0000 after the start-up time */
#define ADIS_E_SELF_TEST 0x14u   /* DIAG_STAT[5]: the automatic self-test failed */
#define ADIS_E_BUSY 0x15u        /* self-test bit still set after 5 x ADIS_SELF_TEST_MS */
#define ADIS_E_CONFIG 0x16u      /* AVG_CNT read back differs from the value written */

/* One burst: raw register contents. */
typedef struct {
    int16_t acc[3];    /* X/Y/ZACCL_OUT, two's complement, 1 LSB = 2^-14 g */
    uint16_t temp_raw; /* TEMP_OUT[11:0], T = (raw - 1331) * -0.47 degC */
} adis_sample_t;

/*
 * adis_frame - one 16-bit frame: select, transfer, deselect, then wait
 *   ADIS_STALL_US.  In: out (DIN).  Returns DOUT (the answer to the
 *   previous read frame).  Takes frame time + 40 us.
 */
uint16_t adis_frame(uint16_t out);

/*
 * adis_read_reg - read one 16-bit register (two frames).  addr: even
 *   register address 0x00..0x7E.  Returns its value (0xFFFF from a
 *   missing part).
 */
uint16_t adis_read_reg(uint8_t addr);

/*
 * adis_write_reg - write a 16-bit register as two byte frames (low byte to
 *   addr, high byte to addr + 1).  addr: even address.
 */
void adis_write_reg(uint8_t addr, uint16_t value);

/*
 * adis_init - start-up check after power-on.  Polls PROD_ID every 10 ms,
 *   at most 40 times (400 ms > ADIS_STARTUP_MS): 0x3F52 -> writes AVG_CNT =
 *   ADIS_AVG_CNT and checks it; three 0xFFFF in a row -> ADIS_E_ABSENT; the
 *   same other non-zero value twice in a row -> ADIS_E_PROD_ID; still
 *   0x0000 at the end -> ADIS_E_NO_RESPONSE.
 *   Out: *prod_id, the last PROD_ID read (may be NULL).
 *   Returns ADIS_OK or an ADIS_E_* status.  Takes 2 frames + 10 ms per poll.
 */
uint8_t adis_init(uint16_t *prod_id);

/*
 * adis_self_test - the automatic self-test: clears DIAG_STAT (read), sets
 *   MSC_CTRL[10], polls MSC_CTRL every 10 ms until the bit clears (at most
 *   20 polls), then reads DIAG_STAT.  Returns ADIS_OK, ADIS_E_SELF_TEST
 *   (DIAG_STAT[5]), ADIS_E_BUSY (bit never cleared) or ADIS_E_ABSENT (reads
 *   0xFFFF).  The outputs carry the self-test force while it runs; wait one
 *   output period (ADIS_PERIOD_US) before trusting samples again.
 */
uint8_t adis_self_test(void);

/*
 * adis_read - one pipelined burst of six frames: XACCL, YACCL, ZACCL,
 *   TEMP, PROD_ID, then FLASH_CNT (a dummy read that clocks PROD_ID out).
 *   The PROD_ID read with the data proves the part answered during the
 *   burst.  Out: *s (written only on ADIS_OK).  Returns ADIS_OK,
 *   ADIS_E_ABSENT (PROD_ID 0xFFFF), ADIS_E_NO_RESPONSE (0x0000: the part
 *   restarted) or ADIS_E_PROD_ID.  Takes 6 frames (about 0.37 ms).
 */
uint8_t adis_read(adis_sample_t *s);

/*
 * adis_temp_centi_c - TEMP_OUT to hundredths of a degree C:
 *   (1331 - raw) * 47 (exact; raw 0..4095 gives -129 908..62 557).
 */
int32_t adis_temp_centi_c(uint16_t raw);

#endif /* INCLINO_ADIS16210_H */
