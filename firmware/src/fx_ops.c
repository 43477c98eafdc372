/* fx_ops.c - basic fixed-point operators; contracts in fx_ops.h. */
#include "inclino/fx_ops.h"

int32_t fx_mul16(int16_t a, int16_t b)
{
    return (int32_t)a * (int32_t)b;
}

int32_t fx_asr32(int32_t x, uint8_t n)
{
    if (x >= 0) {
        return (int32_t)((uint32_t)x >> n);
    }
    /* ~x = -x - 1 >= 0; floor(x / 2^n) = -(floor((-x - 1) / 2^n)) - 1 */
    return -(int32_t)((~(uint32_t)x) >> n) - 1;
}

int32_t fx_asr32_rnd(int32_t x, uint8_t n)
{
    int32_t q;
    if (n == 0u) {
        return x;
    }
    q = fx_asr32(x, n);
    /* add the bit just below the cut: round half up, never overflows since
     * q <= FX_INT32_MAX / 2 for n >= 1 */
    return q + (int32_t)(((uint32_t)x >> (n - 1u)) & 1u);
}

int32_t fx_shl32_sat(int32_t x, uint8_t n, uint8_t *sat)
{
    int32_t lim = (int32_t)(FX_INT32_MAX >> n); /* positive: defined */
    if (x > lim) {
        *sat = 1u;
        return FX_INT32_MAX;
    }
    if (x < -lim - 1) {
        *sat = 1u;
        return FX_INT32_MIN;
    }
    return x * (int32_t)((uint32_t)1u << n);
}

int32_t fx_add32_sat(int32_t a, int32_t b, uint8_t *sat)
{
    if (b > 0 && a > FX_INT32_MAX - b) {
        *sat = 1u;
        return FX_INT32_MAX;
    }
    if (b < 0 && a < FX_INT32_MIN - b) {
        *sat = 1u;
        return FX_INT32_MIN;
    }
    return a + b;
}

int32_t fx_sub32_sat(int32_t a, int32_t b, uint8_t *sat)
{
    if (b < 0 && a > FX_INT32_MAX + b) {
        *sat = 1u;
        return FX_INT32_MAX;
    }
    if (b > 0 && a < FX_INT32_MIN + b) {
        *sat = 1u;
        return FX_INT32_MIN;
    }
    return a - b;
}

int32_t fx_mul32_q31(int32_t a, int32_t b, uint8_t *sat)
{
    int16_t ah = (int16_t)fx_asr32(a, 16u);
    int16_t bh = (int16_t)fx_asr32(b, 16u);
    int16_t al = (int16_t)(((uint32_t)a & 0xFFFFu) >> 1);
    int16_t bl = (int16_t)(((uint32_t)b & 0xFFFFu) >> 1);
    int32_t s;

    /* |ah*bh| <= 2^30, each cross term in [-2^15, 2^15): no overflow */
    s = fx_mul16(ah, bh) + fx_asr32(fx_mul16(ah, bl), 15u) +
        fx_asr32(fx_mul16(al, bh), 15u);
    if (s > (int32_t)0x3FFFFFFFL) {
        *sat = 1u;
        return FX_INT32_MAX;
    }
    if (s < -(int32_t)0x40000000L) {
        *sat = 1u;
        return FX_INT32_MIN;
    }
    return s * 2;
}
