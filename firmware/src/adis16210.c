/* adis16210.c - ADIS16210 driver over the HAL; contracts in adis16210.h. */
#include "inclino/adis16210.h"
#include "inclino/hal.h"

#define POLL_US 10000u      /* 10 ms between start-up / self-test polls */
#define STARTUP_POLLS 40u   /* 400 ms: ADIS_STARTUP_MS with a margin */
#define SELF_TEST_POLLS 20u /* 200 ms = 5 x ADIS_SELF_TEST_MS */
#define ABSENT_IN_A_ROW 3u  /* 0xFFFF reads before declaring the part missing */
#define READ_CMD(a) ((uint16_t)((uint16_t)((a)&0x7Fu) << 8))
#define WRITE_CMD(a, b) ((uint16_t)((uint16_t)(((a) | 0x80u) & 0xFFu) << 8 | ((b)&0xFFu)))

uint16_t adis_frame(uint16_t out)
{
    uint16_t in;
    hal_spi_select(HAL_DEV_ADIS);
    in = hal_spi_xfer16(out);
    hal_spi_deselect();
    hal_delay_us(ADIS_STALL_US);
    return in;
}

uint16_t adis_read_reg(uint8_t addr)
{
    (void)adis_frame(READ_CMD(addr));
    return adis_frame(READ_CMD(ADIS_REG_FLASH_CNT));
}

void adis_write_reg(uint8_t addr, uint16_t value)
{
    (void)adis_frame(WRITE_CMD(addr, value & 0xFFu));
    (void)adis_frame(WRITE_CMD((uint8_t)(addr + 1u), (value >> 8) & 0xFFu));
}

uint8_t adis_init(uint16_t *prod_id)
{
    uint8_t i;
    uint8_t absent = 0u;
    uint8_t wrong = 0u;
    uint16_t last = 0u;
    uint16_t id = 0u;

    for (i = 0u; i < STARTUP_POLLS; i++) {
        id = adis_read_reg(ADIS_REG_PROD_ID);
        if (id == ADIS_PROD_ID) {
            break;
        }
        absent = (id == 0xFFFFu) ? (uint8_t)(absent + 1u) : 0u;
        wrong = (id != 0u && id != 0xFFFFu && id == last) ? (uint8_t)(wrong + 1u) : 0u;
        last = id;
        if (absent >= ABSENT_IN_A_ROW || wrong >= 1u) {
            break;
        }
        hal_delay_us(POLL_US);
    }
    if (prod_id != 0) {
        *prod_id = id;
    }
    if (id == 0xFFFFu) {
        return ADIS_E_ABSENT;
    }
    if (id == 0u) {
        return ADIS_E_NO_RESPONSE;
    }
    if (id != ADIS_PROD_ID) {
        return ADIS_E_PROD_ID;
    }
    adis_write_reg(ADIS_REG_AVG_CNT, ADIS_AVG_CNT);
    if (adis_read_reg(ADIS_REG_AVG_CNT) != ADIS_AVG_CNT) {
        return ADIS_E_CONFIG;
    }
    return ADIS_OK;
}

uint8_t adis_self_test(void)
{
    uint8_t i;
    uint16_t v = 0xFFFFu;

    if (adis_read_reg(ADIS_REG_DIAG_STAT) == 0xFFFFu) { /* clears latched flags */
        return ADIS_E_ABSENT;
    }
    /* MSC_CTRL[10] is in the high byte: one byte frame to address 0x35. */
    (void)adis_frame(WRITE_CMD(ADIS_REG_MSC_CTRL + 1u, ADIS_MSC_SELF_TEST_AUTO >> 8));
    for (i = 0u; i < SELF_TEST_POLLS; i++) {
        hal_delay_us(POLL_US);
        v = adis_read_reg(ADIS_REG_MSC_CTRL);
        if ((v & ADIS_MSC_SELF_TEST_AUTO) == 0u) {
            break;
        }
    }
    if (v == 0xFFFFu) {
        return ADIS_E_ABSENT;
    }
    if ((v & ADIS_MSC_SELF_TEST_AUTO) != 0u) {
        return ADIS_E_BUSY;
    }
    v = adis_read_reg(ADIS_REG_DIAG_STAT);
    if ((v & ADIS_DIAG_SELF_TEST_FAIL) != 0u) {
        return ADIS_E_SELF_TEST;
    }
    return ADIS_OK;
}

static int16_t to_s16(uint16_t u)
{
    /* two's complement without an implementation-defined conversion */
    return (u & 0x8000u) ? (int16_t)(-(int16_t)(uint16_t)(~u & 0x7FFFu) - 1) : (int16_t)u;
}

uint8_t adis_read(adis_sample_t *s)
{
    uint16_t x;
    uint16_t y;
    uint16_t z;
    uint16_t t;
    uint16_t id;

    (void)adis_frame(READ_CMD(ADIS_REG_XACCL_OUT));
    x = adis_frame(READ_CMD(ADIS_REG_YACCL_OUT));
    y = adis_frame(READ_CMD(ADIS_REG_ZACCL_OUT));
    z = adis_frame(READ_CMD(ADIS_REG_TEMP_OUT));
    t = adis_frame(READ_CMD(ADIS_REG_PROD_ID));
    id = adis_frame(READ_CMD(ADIS_REG_FLASH_CNT));
    if (id == 0xFFFFu) {
        return ADIS_E_ABSENT;
    }
    if (id == 0u) {
        return ADIS_E_NO_RESPONSE;
    }
    if (id != ADIS_PROD_ID) {
        return ADIS_E_PROD_ID;
    }
    s->acc[0] = to_s16(x);
    s->acc[1] = to_s16(y);
    s->acc[2] = to_s16(z);
    s->temp_raw = (uint16_t)(t & 0x0FFFu);
    return ADIS_OK;
}

int32_t adis_temp_centi_c(uint16_t raw)
{
    return ((int32_t)1331 - (int32_t)raw) * (int32_t)47;
}
