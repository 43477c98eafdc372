/* acquire.c - acquisition and averaging; contracts in acquire.h. */
#include "inclino/acquire.h"
#include "inclino/adis16210.h"
#include "inclino/ads1256.h"
#include "inclino/hal.h"

int32_t acq_avg(int32_t sum, uint8_t n)
{
    uint32_t a;
    uint32_t d = 2UL * (uint32_t)n;
    if (sum >= 0) {
        a = (uint32_t)sum;
        return (int32_t)((2UL * a + (uint32_t)n) / d);
    }
    /* floor(-a/n + 1/2) = -ceil((2a - n) / 2n) = -floor((2a + n - 1) / 2n) */
    a = (uint32_t)(-(sum + 1)) + 1UL;
    return -(int32_t)((2UL * a + (uint32_t)n - 1UL) / d);
}

int32_t acq_avg_q6(int32_t sum, uint8_t n)
{
    uint32_t a;
    uint32_t q;
    uint32_t r;
    uint32_t d = 2UL * (uint32_t)n;
    if (sum >= 0) {
        a = (uint32_t)sum;
        q = a / (uint32_t)n;
        r = a - q * (uint32_t)n;
        /* 64 q + floor(64 r / n + 1/2) */
        return (int32_t)((q << ACQ_FRAC_BITS) + (r * 128UL + (uint32_t)n) / d);
    }
    /* -(64 q + ceil(64 r / n - 1/2)); ceil((128 r - n) / 2n) = floor((128 r + n - 1) / 2n) */
    a = (uint32_t)(-(sum + 1)) + 1UL;
    q = a / (uint32_t)n;
    r = a - q * (uint32_t)n;
    return -(int32_t)((q << ACQ_FRAC_BITS) + (r * 128UL + (uint32_t)n - 1UL) / d);
}

static void wait_gap(uint32_t since)
{
    uint8_t i;
    for (i = 0u; i < ACQ_GAP_POLLS; i++) {
        if ((uint32_t)(hal_millis() - since) >= ACQ_ADIS_GAP_MS) {
            return;
        }
        hal_delay_us(ACQ_GAP_POLL_US);
    }
}

uint8_t acq_run(uint8_t n, acq_result_t *out)
{
    static const uint8_t mux[3] = {ADS_MUX_X, ADS_MUX_Y, ADS_MUX_Z};
    int32_t acc[3] = {0, 0, 0};
    int32_t mag[3] = {0, 0, 0};
    int32_t temp = 0;
    uint32_t t_last = 0u;
    adis_sample_t a;
    int32_t code;
    uint8_t i;
    uint8_t k;

    if (n == 0u || n > ACQ_N_MAX) {
        return ACQ_E_ARG;
    }
    for (i = 0u; i < n; i++) {
        if (i != 0u) {
            wait_gap(t_last);
        }
        uint8_t st;
        t_last = hal_millis();
        st = adis_read(&a);
        if (st != ADIS_OK) {
            return st;
        }
        for (k = 0u; k < 3u; k++) {
            acc[k] += a.acc[k];
            st = ads_read_channel(mux[k], &code);
            if (st != ADS_OK) {
                return st;
            }
            mag[k] += code;
        }
        temp += (int32_t)a.temp_raw;
    }
    for (k = 0u; k < 3u; k++) {
        out->acc[k] = acq_avg_q6(acc[k], n);
        out->mag[k] = acq_avg_q6(mag[k], n);
    }
    out->temp_raw = (uint16_t)acq_avg(temp, n);
    out->temp_q6 = acq_avg_q6(temp, n);
    out->temp_cc = adis_temp_centi_c(out->temp_raw);
    out->n = n;
    return ACQ_OK;
}
