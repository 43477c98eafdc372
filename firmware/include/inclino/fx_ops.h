/*
 * fx_ops.h - basic fixed-point operators of the probe firmware.
 *
 * Every saturation and every rounding in the firmware goes through one of
 * these named operators (in the spirit of ITU-T G.191's basic operators), so
 * that the NumPy golden model (host/inclino/engines/golden.py) can mirror each step.
 *
 * Portability rules kept by every operator:
 *   - nothing depends on the width of `int` (16 bits on the HCS12X and S08);
 *   - no right shift of a negative value, no left shift of a negative value,
 *     no signed overflow: all are done through unsigned arithmetic or guarded
 *     multiplications;
 *   - the only multiply primitive is fx_mul16 (16 x 16 -> 32, signed), which
 *     the HCS12X port maps to EMULS.
 *
 * Notation: Qn means "value = integer / 2^n".  "floor" rounds towards minus
 * infinity; "round" rounds half up (towards plus infinity on ties).
 */
#ifndef INCLINO_FX_OPS_H
#define INCLINO_FX_OPS_H

#include <stdint.h>

#define FX_INT32_MAX ((int32_t)0x7FFFFFFFL)
#define FX_INT32_MIN ((int32_t)(-FX_INT32_MAX - 1))

/*
 * fx_mul16 - exact signed product a * b.
 *   In: a, b int16 (any Q); out: int32, Q(qa+qb).  Exact, cannot overflow.
 *   The one multiply helper of the firmware (EMULS on the HCS12X).
 */
int32_t fx_mul16(int16_t a, int16_t b);

/*
 * fx_asr32 - arithmetic shift right, floor(x / 2^n), n in [0, 31].
 *   Exact floor; portable for negative x (no implementation-defined shift).
 */
int32_t fx_asr32(int32_t x, uint8_t n);

/*
 * fx_asr32_rnd - rounding shift right, floor(x / 2^n + 1/2), n in [0, 31].
 *   Round half up; cannot overflow (adds the bit below the cut, not 2^(n-1)).
 *   Error bound: |result - x / 2^n| <= 1/2.
 */
int32_t fx_asr32_rnd(int32_t x, uint8_t n);

/*
 * fx_shl32_sat - x * 2^n with saturation to [FX_INT32_MIN, FX_INT32_MAX],
 *   n in [0, 30].  Sets *sat to 1 when it saturates (leaves it alone
 *   otherwise).  Exact when it does not saturate.
 */
int32_t fx_shl32_sat(int32_t x, uint8_t n, uint8_t *sat);

/*
 * fx_add32_sat / fx_sub32_sat - a + b, a - b with saturation to the int32
 *   range; set *sat to 1 when they saturate.  Exact otherwise.
 */
int32_t fx_add32_sat(int32_t a, int32_t b, uint8_t *sat);
int32_t fx_sub32_sat(int32_t a, int32_t b, uint8_t *sat);

/*
 * fx_mul32_q31 - approximate a * b / 2^31 from three fx_mul16 products
 *   (the "double precision" product of ITU-T G.729's oper_32b, Mpy_32).
 *   In: a, b int32 in any Q; out: Q(qa + qb - 31).
 *   Method: a = ah*2^16 + 2*al + a0 with ah = floor(a / 2^16) (int16) and
 *   al in [0, 32767]; likewise b.  result = 2*(ah*bh + floor(ah*bl / 2^15)
 *   + floor(al*bh / 2^15)); the al*bl and a0/b0 terms are dropped.
 *   Rounding: truncation of the partial products (towards minus infinity).
 *   Saturation: only a, b both in [-2^31, -2^31 + 65535] overflow; the result
 *   then saturates to FX_INT32_MAX and *sat is set to 1.
 *   Error bound: -8 < result - a*b/2^31 < 2 (LSB of the result), checked
 *   against exact products in tests/test_fx_ops.py.
 */
int32_t fx_mul32_q31(int32_t a, int32_t b, uint8_t *sat);

/*
 * fx_dot3_q31 - a[0]*b[0] + a[1]*b[1] + a[2]*b[2], scaled by 2^-31.
 *   In: a[3], b[3] int32 in any Q; out: Q(qa + qb - 31).
 *   Method: sat(sat(p0 + p1) + p2), p_i = fx_mul32_q31(a[i], b[i]), the sums
 *   by fx_add32_sat (so, where no sum can overflow, it is the plain sum of
 *   the three products).
 *   Saturation: sets *sat to 1 when a product or a sum saturates.
 *   Error bound: -24 < result - sum(a_i*b_i)/2^31 < 6 (LSB) when nothing
 *   saturates (three products, see fx_mul32_q31).
 */
int32_t fx_dot3_q31(const int32_t a[3], const int32_t b[3], uint8_t *sat);

#endif /* INCLINO_FX_OPS_H */
