/* fx_ops.c - basic fixed-point operators; contracts in fx_ops.h. */
#include "inclino/fx_ops.h"

/* A port may supply fx_mul16 in its own file (firmware/port/<mcu>/) and
 * build this one with -DFX_PORT_MUL16: the S08 port has it in assembly, since
 * SDCC turns the product below into a 32 x 32 library call. */
#ifndef FX_PORT_MUL16
int32_t fx_mul16(int16_t a, int16_t b)
{
    return (int32_t)a * (int32_t)b;
}
#endif

/* The int32 whose two's complement bits are u (no implementation-defined
 * conversion of an out-of-range unsigned value). */
static int32_t s32_of_bits(uint32_t u)
{
    return (u <= (uint32_t)FX_INT32_MAX) ? (int32_t)u : -(int32_t)(~u) - 1;
}

/* A port may supply fx_asr32, fx_asr32_rnd, fx_add32_sat and fx_sub32_sat
 * (same result bits) and build this file with -DFX_PORT_OPS: the S08 port
 * has them in assembly (firmware/port/s08). */
#ifndef FX_PORT_OPS
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
#endif /* FX_PORT_OPS */

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
    /* in range: the bits of x * 2^n are those of x shifted left */
    return s32_of_bits((uint32_t)x << n);
}

/* A port may supply fx_mul32_q31 and fx_dot3_q31 (same result bits) and
 * build this file with -DFX_PORT_MUL32: the S08 port has them in assembly
 * (firmware/port/s08). */
#ifndef FX_PORT_MUL32

/* floor(x / 2^16) as int16, for the int32 x whose bits are u. */
static int16_t hi16_of_bits(uint32_t u)
{
    uint16_t h = (uint16_t)(u >> 16);
    return (h <= (uint16_t)INT16_MAX) ? (int16_t)h
                                      : (int16_t)((int16_t)(h & 0x7FFFu) - INT16_MAX - 1);
}

/* floor(p / 2^15) for |p| < 2^30, in 16-bit arithmetic:
 * 2 * floor(p / 2^16) + bit 15 of p. */
static int16_t floor_div_2p15(int32_t p)
{
    uint32_t u = (uint32_t)p;
    return (int16_t)(2 * hi16_of_bits(u) + (int16_t)((uint16_t)u >> 15));
}

int32_t fx_mul32_q31(int32_t a, int32_t b, uint8_t *sat)
{
    int16_t ah = hi16_of_bits((uint32_t)a); /* floor(a / 2^16) */
    int16_t bh = hi16_of_bits((uint32_t)b);
    int16_t al = (int16_t)((uint16_t)(uint32_t)a >> 1); /* ((a mod 2^16) >> 1) */
    int16_t bl = (int16_t)((uint16_t)(uint32_t)b >> 1);
    int32_t s;

    /* |ah*bh| <= 2^30, each cross term in [-2^15, 2^15): no overflow */
    s = fx_mul16(ah, bh);
    s += floor_div_2p15(fx_mul16(ah, bl));
    s += floor_div_2p15(fx_mul16(al, bh));
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

int32_t fx_dot3_q31(const int32_t a[3], const int32_t b[3], uint8_t *sat)
{
    int32_t s = fx_add32_sat(fx_mul32_q31(a[0], b[0], sat), fx_mul32_q31(a[1], b[1], sat), sat);
    return fx_add32_sat(s, fx_mul32_q31(a[2], b[2], sat), sat);
}
#endif /* FX_PORT_MUL32 */
