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

void corr_temp_eval(int16_t dt, const corr_tc_t *tc, uint8_t sh, corr_tt_t *tt, uint8_t *sat)
{
    /* |dt| <= 32767: dt * 2^sh (sh <= 16) within +-(2^31 - 2^16), no overflow */
    int32_t db = (int32_t)dt * (int32_t)((uint32_t)1u << sh);
    int32_t ds = (int32_t)dt * (int32_t)((uint32_t)1u << CORR_SCALE_TC_SHIFT);
    uint8_t i;
    for (i = 0u; i < 3u; i++) {
        /* c2 dT: int16 x int16, |c2 dT| <= 2^30, in c1's format (Q39 / Q24) */
        int32_t in = fx_add32_sat(tc->c1[i], fx_mul16(tc->c2[i], dt), sat);
        /* Q39 x Q21 / 2^31 = Q29 g; Q24 x Q17 / 2^31 = Q10 nT */
        tt->bias[i] = fx_mul32_q31(in, db, sat);
        in = fx_add32_sat(tc->r1[i], fx_mul16(tc->r2[i], dt), sat);
        /* Q39 x Q23 / 2^31 = Q31 */
        tt->e[i] = fx_mul32_q31(in, ds, sat);
    }
}

uint8_t corr_triad_temp(const int32_t x[3], const corr_triad_t *c, const corr_tt_t *tt,
                        int32_t out[3])
{
    int32_t d[3];
    uint8_t sat = 0u;
    uint8_t i;

    for (i = 0u; i < 3u; i++) {
        int32_t v = fx_sub32_sat(x[i], c->bias[i], &sat);
        v = fx_sub32_sat(v, tt->bias[i], &sat);
        /* d (1 + e): Q29 (Q10) x Q31 / 2^31 = Q29 (Q10) */
        d[i] = fx_add32_sat(v, fx_mul32_q31(v, tt->e[i], &sat), &sat);
    }
    out[0] = fx_dot3_q31(&c->m[0], d, &sat);
    out[1] = fx_dot3_q31(&c->m[3], d, &sat);
    out[2] = fx_dot3_q31(&c->m[6], d, &sat);
    return sat;
}

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
