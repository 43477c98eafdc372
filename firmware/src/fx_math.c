/* fx_math.c - division, square root, arctangent; contracts in fx_math.h. */
#include "inclino/fx_math.h"
#include "inclino/fx_ops.h"

#define FX_DIV_BITS 20u
#define FX_ATAN_FRAC_BITS 12u /* FX_DIV_BITS - log2(FX_ATAN_N) */

/* A port may supply fx_div_frac_q20 (same result bits) and build this file
 * with -DFX_PORT_DIV: the S08 port has it in assembly (firmware/port/s08). */
#ifndef FX_PORT_DIV
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
#endif /* FX_PORT_DIV */

/* A port may supply fx_isqrt_u32 and fx_sqrt_u32_q8 (same result bits) and
 * build this file with -DFX_PORT_SQRT: the S08 port has them in assembly
 * (firmware/port/s08). */
#ifndef FX_PORT_SQRT
/* floor(sqrt(x)) by the bitwise method (16 fixed steps); *rem receives
 * x - floor(sqrt(x))^2, what is left of x. */
static uint16_t isqrt_rem(uint32_t x, uint32_t *rem)
{
    uint32_t res = 0u;
    uint32_t bit = (uint32_t)1u << 30;
    uint8_t i;

    for (i = 0u; i < 16u; i++) {
        uint32_t t = res + bit;
        res >>= 1;
        if (x >= t) {
            x -= t;
            res += bit;
        }
        bit >>= 2;
    }
    *rem = x;
    return (uint16_t)res;
}

uint16_t fx_isqrt_u32(uint32_t x)
{
    uint32_t r;
    return isqrt_rem(x, &r);
}

uint32_t fx_sqrt_u32_q8(uint32_t x)
{
    uint32_t y, r, s, num, den;
    uint16_t q = 0u;
    uint16_t bit = 0x100u;
    uint8_t k = 0u;

    if (x == 0u) {
        return 0u;
    }
    /* normalise by 4^k into [2^30, 2^32) so that y >= 2^15 (whole bytes
     * first: the same k in fewer steps) */
    while (x < ((uint32_t)1u << 22)) {
        x <<= 8;
        k = (uint8_t)(k + 4u);
    }
    while (x < ((uint32_t)1u << 30)) {
        x <<= 2;
        k++;
    }
    y = isqrt_rem(x, &r); /* r = x - y^2, 0 <= r <= 2y <= 131070 */
    /* floor((256 r + y) / (2y + 1)) <= 256 (r <= 2y gives 256 r + y <=
     * 513 y): 9 steps of restoring division, exact, no library divide */
    num = (r << 8) + y;
    den = (2u * y + 1u) << 8;
    while (bit != 0u) {
        if (num >= den) {
            num -= den;
            q |= bit;
        }
        den >>= 1;
        bit >>= 1;
    }
    s = (y << 8) + q;
    if (k == 0u) {
        return s;
    }
    return (s + ((uint32_t)1u << (k - 1u))) >> k; /* round half up; s <= 2^24 */
}
#endif /* FX_PORT_SQRT */

/* A port may supply fx_atan2_q16 (same result bits) and build this file
 * with -DFX_PORT_ATAN2: the S08 port has it in assembly (firmware/port/s08). */
#ifndef FX_PORT_ATAN2
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
        /* d > 0 (the table increases) and frac > 0: the product p is in
         * (0, 2^26), and fx_asr32_rnd(p, 12) = floor((p + 2^11) / 2^12) */
        uint32_t p = (uint32_t)fx_mul16(d, (int16_t)frac);
        a += (int32_t)((p + ((uint32_t)1u << (FX_ATAN_FRAC_BITS - 1u))) >> FX_ATAN_FRAC_BITS);
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
#endif /* FX_PORT_ATAN2 */
