/* calimg.c - calibration image check and encoding; contract in calimg.h. */
#include "inclino/calimg.h"
#include "inclino/be_bytes.h"
#include "inclino/crc16.h"

#define OFF_COEF 20u
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

uint8_t calimg_parse(const uint8_t *buf, uint16_t len, corr_cal_t *cal, calimg_info_t *info)
{
    corr_cal_t c;
    if (len < CALIMG_SIZE || be_get_u16(buf + 6) != CALIMG_SIZE) {
        return CALIMG_E_LENGTH;
    }
    if (be_get_u32(buf) != CALIMG_MAGIC) {
        return CALIMG_E_MAGIC;
    }
    if (be_get_u16(buf + 4) != CALIMG_VERSION) {
        return CALIMG_E_VERSION;
    }
    if (crc16_update(CRC16_INIT, buf, CALIMG_CRC_OFFSET) != be_get_u16(buf + CALIMG_CRC_OFFSET)) {
        return CALIMG_E_CRC;
    }
    decode_triad(buf + OFF_COEF, &c.acc);
    decode_triad(buf + OFF_COEF + 48u, &c.mag);
    if (!triad_ok(&c.acc) || !triad_ok(&c.mag)) {
        return CALIMG_E_RANGE;
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

void calimg_build(const corr_cal_t *cal, const calimg_info_t *info, uint8_t buf[CALIMG_SIZE])
{
    uint8_t i;
    for (i = 0u; i < CALIMG_SIZE; i++) {
        buf[i] = 0u;
    }
    be_put_u32(buf, CALIMG_MAGIC);
    be_put_u16(buf + 4, CALIMG_VERSION);
    be_put_u16(buf + 6, CALIMG_SIZE);
    be_put_u32(buf + 8, info->serial);
    be_put_u32(buf + 12, info->time);
    buf[16] = info->method;
    encode_triad(buf + OFF_COEF, &cal->acc);
    encode_triad(buf + OFF_COEF + 48u, &cal->mag);
    be_put_u16(buf + CALIMG_CRC_OFFSET, crc16_update(CRC16_INIT, buf, CALIMG_CRC_OFFSET));
    buf[118] = 0xFFu;
    buf[119] = 0xFFu;
}
