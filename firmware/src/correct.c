/* correct.c - triad correction; contracts in correct.h. */
#include "inclino/correct.h"
#include "inclino/fx_ops.h"

uint8_t corr_triad(const int32_t x[3], const corr_triad_t *c, int32_t out[3])
{
    int32_t d[3];
    uint8_t sat = 0u;

    d[0] = fx_sub32_sat(x[0], c->bias[0], &sat);
    d[1] = fx_sub32_sat(x[1], c->bias[1], &sat);
    d[2] = fx_sub32_sat(x[2], c->bias[2], &sat);
    out[0] = fx_dot3_q31(&c->m[0], d, &sat);
    out[1] = fx_dot3_q31(&c->m[3], d, &sat);
    out[2] = fx_dot3_q31(&c->m[6], d, &sat);
    return sat;
}

int16_t corr_temp_dt(int32_t temp_q6, int16_t t_ref, uint8_t *sat)
{
    const int32_t z = CORR_TEMP_RAW_ZERO * CORR_IN_ONE; /* 0 degC in Q6 counts */
    int32_t u;
    int32_t t;
    /* u = z - temp_q6 clamped to +-32767, compared before subtracting: no
     * overflow for any int32 temp_q6 */
    if (temp_q6 < z - 32767L) {
        u = 32767L;
        *sat = 1u;
    } else if (temp_q6 > z + 32767L) {
        u = -32767L;
        *sat = 1u;
    } else {
        u = z - temp_q6;
    }
    /* |u| <= 32767, 30802 < 2^15: |u * 30802| < 2^30; t in Q7, |t| <= 30802 */
    t = fx_asr32_rnd(fx_mul16((int16_t)u, (int16_t)CORR_TEMP_K), 15u);
    /* |t - t_ref| <= 30802 + 32768 < 2^16: plain int32 difference */
    t -= (int32_t)t_ref;
    if (t > 32767L) {
        t = 32767L;
        *sat = 1u;
    } else if (t < -32767L) {
        t = -32767L;
        *sat = 1u;
    }
    return (int16_t)t;
}

/* A port may supply corr_temp_eval and corr_triad_temp (same result bits)
 * and build this file with -DCORR_PORT_TEMP: the S08 port has them in
 * assembly (firmware/port/s08/corr_temp_s08.c). */
#ifndef CORR_PORT_TEMP
void corr_temp_eval(int16_t dt, const corr_triad_t *c, const corr_tc_t *tc, corr_tt_t *tt,
                    uint8_t *sat)
{
    /* dT 2^15: Q22, |dts| < 2^30 (a constant power-of-two product: a shift) */
    int32_t dts = (int32_t)dt * 32768L;
    uint8_t i;
    for (i = 0u; i < 3u; i++) {
        /* c2 dT: 16 x 16, |c2 dT| < 2^30, in c1's format (Q31 + Q7 = Q38, Q12 + Q7
         * = Q19); |c1| <= 2^30 (calimg_parse): |inner| < 2^31, a plain int32 sum */
        int32_t in = tc->c1[i] + fx_mul16(tc->c2[i], dt);
        int32_t e;
        /* Q38 x Q22 / 2^31 = Q29 g; Q19 x Q22 / 2^31 = Q10 nT; |bias| < 2^30; the
         * product cannot saturate (|dts| < 2^30) */
        tt->beff[i] = fx_add32_sat(c->bias[i], fx_mul32_q31(in, dts, sat), sat);
        /* r2 dT: Q31 + Q7 = r1's Q38; |r1| <= 2^30 */
        in = tc->r1[i] + fx_mul16(tc->r2[i], dt);
        /* Q38 x Q22 / 2^31 = Q29; kept within CORR_E_MAX so that corr_triad_temp's
         * 4 p cannot overflow */
        e = fx_mul32_q31(in, dts, sat);
        if (e > CORR_E_MAX) {
            e = CORR_E_MAX;
            *sat = 1u;
        } else if (e < -CORR_E_MAX) {
            e = -CORR_E_MAX;
            *sat = 1u;
        }
        tt->e[i] = e;
    }
}

uint8_t corr_triad_temp(const int32_t x[3], const corr_triad_t *c, const corr_tt_t *tt,
                        int32_t out[3])
{
    int32_t d[3];
    uint8_t sat = 0u;
    uint8_t i;

    for (i = 0u; i < 3u; i++) {
        int32_t v = fx_sub32_sat(x[i], tt->beff[i], &sat);
        /* v e: Q29 (Q10) x Q29 / 2^31 = Q27 (Q8); |e| < 1 so |p| < 2^29 and
         * 4 p (back to v's format) is exact */
        int32_t p = fx_mul32_q31(v, tt->e[i], &sat);
        d[i] = fx_add32_sat(v, p * 4, &sat);
    }
    out[0] = fx_dot3_q31(&c->m[0], d, &sat);
    out[1] = fx_dot3_q31(&c->m[3], d, &sat);
    out[2] = fx_dot3_q31(&c->m[6], d, &sat);
    return sat;
}
#endif /* CORR_PORT_TEMP */

int32_t corr_in_acc(int32_t raw_q6)
{
    return raw_q6 * (int32_t)((uint32_t)1u << CORR_ACC_IN_SHIFT);
}

int32_t corr_in_mag(int32_t raw_q6)
{
    return raw_q6 * (int32_t)((uint32_t)1u << CORR_MAG_IN_SHIFT);
}

void corr_tc_clear(corr_tc_t *tc)
{
    uint8_t i;
    for (i = 0u; i < 3u; i++) {
        tc->c1[i] = 0;
        tc->c2[i] = 0;
        tc->r1[i] = 0;
        tc->r2[i] = 0;
    }
}

void corr_identity(corr_triad_t *c)
{
    uint8_t i;
    for (i = 0u; i < 9u; i++) {
        c->m[i] = (i % 4u == 0u) ? CORR_M_ONE : 0;
    }
    for (i = 0u; i < 3u; i++) {
        c->bias[i] = 0;
    }
}
