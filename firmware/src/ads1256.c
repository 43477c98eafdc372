/* ads1256.c - ADS1256 driver over the HAL; contracts in ads1256.h. */
#include "inclino/ads1256.h"
#include "inclino/hal.h"

#define NREGS 11u

uint8_t ads_wait_drdy(uint16_t timeout_us)
{
    uint16_t polls = (uint16_t)(timeout_us / ADS_POLL_US);
    uint16_t i;
    for (i = 0u; i <= polls; i++) {
        if (hal_adc_drdy() == 0u) {
            return ADS_OK;
        }
        hal_delay_us(ADS_POLL_US);
    }
    return ADS_E_TIMEOUT;
}

uint8_t ads_read_regs(uint8_t reg, uint8_t n, uint8_t *out)
{
    uint8_t i;
    if (n == 0u || n > NREGS || reg >= NREGS) {
        return ADS_E_ARG;
    }
    hal_spi_select(HAL_DEV_ADC);
    (void)hal_spi_xfer8((uint8_t)(ADS_CMD_RREG | reg));
    (void)hal_spi_xfer8((uint8_t)(n - 1u));
    hal_delay_us(ADS_T6_US);
    for (i = 0u; i < n; i++) {
        out[i] = hal_spi_xfer8(0x00u);
    }
    hal_spi_deselect();
    return ADS_OK;
}

uint8_t ads_write_regs(uint8_t reg, uint8_t n, const uint8_t *in)
{
    uint8_t i;
    if (n == 0u || n > NREGS || reg >= NREGS) {
        return ADS_E_ARG;
    }
    hal_spi_select(HAL_DEV_ADC);
    (void)hal_spi_xfer8((uint8_t)(ADS_CMD_WREG | reg));
    (void)hal_spi_xfer8((uint8_t)(n - 1u));
    for (i = 0u; i < n; i++) {
        (void)hal_spi_xfer8(in[i]);
    }
    hal_spi_deselect();
    return ADS_OK;
}

void ads_command(uint8_t cmd)
{
    hal_spi_select(HAL_DEV_ADC);
    (void)hal_spi_xfer8(cmd);
    hal_spi_deselect();
}

uint8_t ads_init(void)
{
    static const uint8_t cfg[4] = {0x00u, ADS_MUX_X, 0x00u, ADS_DRATE_1000};
    uint8_t rb[4];
    uint8_t st;

    /* the part ignores commands while it calibrates (after power-on):
     * let a running calibration end first (bounded; a missing part is
     * found by the ID check below) */
    (void)ads_wait_drdy(ADS_CAL_TIMEOUT_US);
    ads_command(ADS_CMD_RESET);
    st = ads_wait_drdy(ADS_CAL_TIMEOUT_US);
    (void)ads_read_regs(ADS_REG_STATUS, 1u, rb);
    if (rb[0] == 0xFFu) {
        return ADS_E_ABSENT;
    }
    if ((rb[0] >> 4) != ADS_STATUS_ID) {
        return ADS_E_ID;
    }
    if (st != ADS_OK) {
        return st;
    }
    (void)ads_write_regs(ADS_REG_STATUS, 4u, cfg);
    (void)ads_read_regs(ADS_REG_STATUS, 4u, rb);
    /* STATUS: ID and DRDY bits are read-only, compare ORDER/ACAL/BUFEN */
    if ((rb[0] & 0x0Eu) != cfg[0] || rb[1] != cfg[1] || (rb[2] & 0x7Fu) != cfg[2] ||
        rb[3] != cfg[3]) {
        return ADS_E_CONFIG;
    }
    ads_command(ADS_CMD_SELFCAL);
    return ads_wait_drdy(ADS_CAL_TIMEOUT_US);
}

int32_t ads_sign_extend24(uint32_t raw)
{
    return (int32_t)(raw & 0x7FFFFFUL) - (int32_t)(raw & 0x800000UL);
}

uint8_t ads_read_channel(uint8_t mux, int32_t *code)
{
    uint8_t st;
    uint32_t raw;
    uint8_t i;

    hal_spi_select(HAL_DEV_ADC);
    (void)hal_spi_xfer8((uint8_t)(ADS_CMD_WREG | ADS_REG_MUX));
    (void)hal_spi_xfer8(0x00u);
    (void)hal_spi_xfer8(mux);
    (void)hal_spi_xfer8(ADS_CMD_SYNC);
    hal_delay_us(ADS_T11_US);
    (void)hal_spi_xfer8(ADS_CMD_WAKEUP);
    hal_spi_deselect();
    /* nothing to read before the settling time: sleep most of it, then poll */
    hal_delay_us(ADS_SETTLE_US - 4u * ADS_POLL_US);
    st = ads_wait_drdy(ADS_CONV_TIMEOUT_US);
    if (st != ADS_OK) {
        return st;
    }
    hal_spi_select(HAL_DEV_ADC);
    (void)hal_spi_xfer8(ADS_CMD_RDATA);
    hal_delay_us(ADS_T6_US);
    raw = 0u;
    for (i = 0u; i < 3u; i++) {
        raw = (raw << 8) | (uint32_t)hal_spi_xfer8(0x00u);
    }
    hal_spi_deselect();
    *code = ads_sign_extend24(raw);
    return ADS_OK;
}
