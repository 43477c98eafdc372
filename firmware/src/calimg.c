/* calimg.c - calibration image check and encoding; contract in calimg.h. */
#include "inclino/calimg.h"
#include "inclino/be_bytes.h"
#include "inclino/crc16.h"

#define OFF_COEF 20u
#define OFF_TC 116u
#define TC_TRIAD 36u
#define BIAS_LIMIT ((int32_t)0x40000000L) /* 2^30 */
#define DIAG_MIN ((int32_t)0x08000000L)   /* 1/4 in Q29 */

static uint8_t triad_ok(const corr_triad_t *t)
{
    uint8_t i;
    for (i = 0u; i < 3u; i++) {
        if (t->bias[i] >= BIAS_LIMIT || t->bias[i] <= -BIAS_LIMIT || t->m[4u * i] < DIAG_MIN) {
            return 0u;
        }
    }
    return 1u;
}

static void decode_triad(const uint8_t *p, corr_triad_t *t)
{
    uint8_t i;
    for (i = 0u; i < 9u; i++) {
        t->m[i] = be_get_i32(p + 4u * i);
    }
    for (i = 0u; i < 3u; i++) {
        t->bias[i] = be_get_i32(p + 36u + 4u * i);
    }
}

static void decode_tc(const uint8_t *p, corr_tc_t *t)
{
    uint8_t i;
    for (i = 0u; i < 3u; i++) {
        t->c1[i] = be_get_i32(p + 4u * i);
        t->c2[i] = (int16_t)be_get_u16(p + 12u + 2u * i);
        t->r1[i] = be_get_i32(p + 18u + 4u * i);
        t->r2[i] = (int16_t)be_get_u16(p + 30u + 2u * i);
    }
}

/* calimg.c links without correct.c (the image checker's fuzz target) */
static void tc_clear(corr_tc_t *t)
{
    uint8_t i;
    for (i = 0u; i < 3u; i++) {
        t->c1[i] = 0;
        t->c2[i] = 0;
        t->r1[i] = 0;
        t->r2[i] = 0;
    }
}

/* |c1|, |r1| <= 2^30 (corr_temp_eval's plain sums), c2, r2 not INT16_MIN; 2nd order 0 below order 2, all 0 at 0 */
static uint8_t tc_ok(const corr_tc_t *t, uint8_t order)
{
    uint8_t i;
    for (i = 0u; i < 3u; i++) {
        if (t->c1[i] > CORR_TC_LIMIT || t->c1[i] < -CORR_TC_LIMIT || t->r1[i] > CORR_TC_LIMIT ||
            t->r1[i] < -CORR_TC_LIMIT || t->c2[i] == INT16_MIN || t->r2[i] == INT16_MIN) {
            return 0u;
        }
        if ((order < 2u && (t->c2[i] != 0 || t->r2[i] != 0)) ||
            (order == 0u && (t->c1[i] != 0 || t->r1[i] != 0))) {
            return 0u;
        }
    }
    return 1u;
}

uint16_t calimg_length(const uint8_t *buf)
{
    uint16_t n = be_get_u16(buf + 6);
    return (n == CALIMG_SIZE || n == CALIMG_SIZE_V1) ? n : 0u;
}

uint8_t calimg_parse(const uint8_t *buf, uint16_t len, corr_cal_t *cal, calimg_info_t *info)
{
    corr_cal_t c;
    uint16_t n;
    uint16_t crc_off;
    if (len < 8u) {
        return CALIMG_E_LENGTH;
    }
    n = calimg_length(buf);
    if (n == 0u || len < n) {
        return CALIMG_E_LENGTH;
    }
    if (be_get_u32(buf) != CALIMG_MAGIC) {
        return CALIMG_E_MAGIC;
    }
    if (be_get_u16(buf + 4) != ((n == CALIMG_SIZE) ? CALIMG_VERSION : CALIMG_VERSION_1)) {
        return CALIMG_E_VERSION;
    }
    crc_off = (n == CALIMG_SIZE) ? CALIMG_CRC_OFFSET : CALIMG_CRC_OFFSET_V1;
    if (crc16_update(CRC16_INIT, buf, crc_off) != be_get_u16(buf + crc_off)) {
        return CALIMG_E_CRC;
    }
    decode_triad(buf + OFF_COEF, &c.acc);
    decode_triad(buf + OFF_COEF + 48u, &c.mag);
    if (!triad_ok(&c.acc) || !triad_ok(&c.mag)) {
        return CALIMG_E_RANGE;
    }
    if (n == CALIMG_SIZE) {
        c.t_order = buf[17];
        c.t_ref = (int16_t)be_get_u16(buf + 18);
        decode_tc(buf + OFF_TC, &c.acc_tc);
        decode_tc(buf + OFF_TC + TC_TRIAD, &c.mag_tc);
        if (c.t_order > 2u || c.t_ref < CALIMG_T_REF_MIN || c.t_ref > CALIMG_T_REF_MAX ||
            !tc_ok(&c.acc_tc, c.t_order) || !tc_ok(&c.mag_tc, c.t_order)) {
            return CALIMG_E_RANGE;
        }
    } else {
        c.t_order = 0u;
        c.t_ref = 0;
        tc_clear(&c.acc_tc);
        tc_clear(&c.mag_tc);
    }
    *cal = c;
    info->serial = be_get_u32(buf + 8);
    info->time = be_get_u32(buf + 12);
    info->method = buf[16];
    return CALIMG_OK;
}

static void encode_triad(uint8_t *p, const corr_triad_t *t)
{
    uint8_t i;
    for (i = 0u; i < 9u; i++) {
        be_put_u32(p + 4u * i, (uint32_t)t->m[i]);
    }
    for (i = 0u; i < 3u; i++) {
        be_put_u32(p + 36u + 4u * i, (uint32_t)t->bias[i]);
    }
}

static void encode_tc(uint8_t *p, const corr_tc_t *t)
{
    uint8_t i;
    for (i = 0u; i < 3u; i++) {
        be_put_u32(p + 4u * i, (uint32_t)t->c1[i]);
        be_put_u16(p + 12u + 2u * i, (uint16_t)t->c2[i]);
        be_put_u32(p + 18u + 4u * i, (uint32_t)t->r1[i]);
        be_put_u16(p + 30u + 2u * i, (uint16_t)t->r2[i]);
    }
}

uint16_t calimg_build(const corr_cal_t *cal, const calimg_info_t *info, uint8_t buf[CALIMG_SIZE])
{
    uint8_t i;
    uint8_t v2 = (uint8_t)(cal->t_order != 0u);
    uint16_t n = v2 ? CALIMG_SIZE : CALIMG_SIZE_V1;
    uint16_t crc_off = v2 ? CALIMG_CRC_OFFSET : CALIMG_CRC_OFFSET_V1;
    for (i = 0u; i < CALIMG_SIZE; i++) {
        buf[i] = (i < crc_off) ? 0u : 0xFFu;
    }
    be_put_u32(buf, CALIMG_MAGIC);
    be_put_u16(buf + 4, v2 ? CALIMG_VERSION : CALIMG_VERSION_1);
    be_put_u16(buf + 6, n);
    be_put_u32(buf + 8, info->serial);
    be_put_u32(buf + 12, info->time);
    buf[16] = info->method;
    encode_triad(buf + OFF_COEF, &cal->acc);
    encode_triad(buf + OFF_COEF + 48u, &cal->mag);
    if (v2) {
        buf[17] = cal->t_order;
        be_put_u16(buf + 18, (uint16_t)cal->t_ref);
        encode_tc(buf + OFF_TC, &cal->acc_tc);
        encode_tc(buf + OFF_TC + TC_TRIAD, &cal->mag_tc);
    }
    be_put_u16(buf + crc_off, crc16_update(CRC16_INIT, buf, crc_off));
    return n;
}
