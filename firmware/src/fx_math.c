/* fx_math.c - division, square root, arctangent; contracts in fx_math.h. */
#include "inclino/fx_math.h"
#include "inclino/fx_ops.h"

#define FX_DIV_BITS 20u
#define FX_ATAN_FRAC_BITS 12u /* FX_DIV_BITS - log2(FX_ATAN_N) */

uint32_t fx_div_frac_q20(uint32_t num, uint32_t den)
{
    uint32_t rem = num;
    uint32_t q = 0u;
    uint8_t i;

    if (den == 0u) {
        return 0u;
    }
    if (num >= den) {
        return (uint32_t)1u << FX_DIV_BITS;
    }
    /* invariant rem < den <= 2^32 - 1; rem < 2^31 keeps 2*rem exact */
    for (i = 0u; i < FX_DIV_BITS; i++) {
        uint32_t top = rem & 0x80000000UL;
        rem <<= 1;
        q <<= 1;
        if (top != 0u || rem >= den) {
            rem -= den;
            q |= 1u;
        }
    }
    /* round half up: 2*rem >= den (rem < den, test without overflow) */
    if (rem >= den - rem) {
        q += 1u;
    }
    return q;
}

uint16_t fx_isqrt_u32(uint32_t x)
{
    uint32_t res = 0u;
    uint32_t bit = (uint32_t)1u << 30;
    uint8_t i;

    for (i = 0u; i < 16u; i++) {
        if (x >= res + bit) {
            x -= res + bit;
            res = (res >> 1) + bit;
        } else {
            res >>= 1;
        }
        bit >>= 2;
    }
    return (uint16_t)res;
}

uint32_t fx_sqrt_u32_q8(uint32_t x)
{
    uint32_t y, r, s;
    uint8_t k = 0u;

    if (x == 0u) {
        return 0u;
    }
    /* normalise by 4^k into [2^30, 2^32) so that y >= 2^15 */
    while (x < ((uint32_t)1u << 30)) {
        x <<= 2;
        k++;
    }
    y = fx_isqrt_u32(x);
    r = x - y * y; /* 0 <= r <= 2y <= 131070 */
    s = (y << 8) + ((r << 8) + y) / (2u * y + 1u);
    if (k == 0u) {
        return s;
    }
    return (s + ((uint32_t)1u << (k - 1u))) >> k; /* round half up; s < 2^24 */
}

int32_t fx_atan2_q16(int32_t y, int32_t x)
{
    uint32_t ux, uy, num, den, q;
    uint16_t idx, frac;
    int32_t a;
    uint8_t swap;

    if (x == 0 && y == 0) {
        return 0;
    }
    ux = (x < 0) ? (0u - (uint32_t)x) : (uint32_t)x;
    uy = (y < 0) ? (0u - (uint32_t)y) : (uint32_t)y;
    swap = (uint8_t)(uy > ux);
    num = swap ? ux : uy;
    den = swap ? uy : ux;

    q = fx_div_frac_q20(num, den); /* [0, 2^20] */
    idx = (uint16_t)(q >> FX_ATAN_FRAC_BITS);
    frac = (uint16_t)(q & ((1u << FX_ATAN_FRAC_BITS) - 1u));
    a = fx_atan_table[idx];
    if (frac != 0u) {
        int16_t d = (int16_t)(fx_atan_table[idx + 1u] - fx_atan_table[idx]);
        a += fx_asr32_rnd(fx_mul16(d, (int16_t)frac), FX_ATAN_FRAC_BITS);
    }
    if (swap) {
        a = FX_DEG(90) - a;
    }
    if (x < 0) {
        a = FX_DEG(180) - a;
    }
    if (y < 0) {
        a = FX_DEG(360) - a;
        if (a == FX_DEG(360)) {
            a = 0;
        }
    }
    return a;
}
