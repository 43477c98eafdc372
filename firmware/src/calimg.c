/* calimg.c - calibration image check and encoding; contract in calimg.h. */
#include "inclino/calimg.h"
#include "inclino/crc16.h"

#define OFF_COEF 20u
#define BIAS_LIMIT ((int32_t)0x40000000L) /* 2^30 */
#define DIAG_MIN ((int32_t)0x08000000L)   /* 1/4 in Q29 */

static uint32_t get_u32(const uint8_t *p)
{
    return ((uint32_t)p[0] << 24) | ((uint32_t)p[1] << 16) | ((uint32_t)p[2] << 8) |
           (uint32_t)p[3];
}

static int32_t get_i32(const uint8_t *p)
{
    uint32_t u = get_u32(p);
    /* two's complement without an implementation-defined conversion */
    return (u & 0x80000000UL) ? -(int32_t)(~u) - 1 : (int32_t)u;
}

static uint16_t get_u16(const uint8_t *p)
{
    return (uint16_t)(((uint16_t)p[0] << 8) | (uint16_t)p[1]);
}

static void put_u32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)(v >> 24);
    p[1] = (uint8_t)(v >> 16);
    p[2] = (uint8_t)(v >> 8);
    p[3] = (uint8_t)v;
}

static void put_u16(uint8_t *p, uint16_t v)
{
    p[0] = (uint8_t)(v >> 8);
    p[1] = (uint8_t)v;
}

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
        t->m[i] = get_i32(p + 4u * i);
    }
    for (i = 0u; i < 3u; i++) {
        t->bias[i] = get_i32(p + 36u + 4u * i);
    }
}

uint8_t calimg_parse(const uint8_t *buf, uint16_t len, corr_cal_t *cal, calimg_info_t *info)
{
    corr_cal_t c;
    if (len < CALIMG_SIZE || get_u16(buf + 6) != CALIMG_SIZE) {
        return CALIMG_E_LENGTH;
    }
    if (get_u32(buf) != CALIMG_MAGIC) {
        return CALIMG_E_MAGIC;
    }
    if (get_u16(buf + 4) != CALIMG_VERSION) {
        return CALIMG_E_VERSION;
    }
    if (crc16_update(CRC16_INIT, buf, CALIMG_CRC_OFFSET) != get_u16(buf + CALIMG_CRC_OFFSET)) {
        return CALIMG_E_CRC;
    }
    decode_triad(buf + OFF_COEF, &c.acc);
    decode_triad(buf + OFF_COEF + 48u, &c.mag);
    if (!triad_ok(&c.acc) || !triad_ok(&c.mag)) {
        return CALIMG_E_RANGE;
    }
    *cal = c;
    info->serial = get_u32(buf + 8);
    info->time = get_u32(buf + 12);
    info->method = buf[16];
    return CALIMG_OK;
}

static void encode_triad(uint8_t *p, const corr_triad_t *t)
{
    uint8_t i;
    for (i = 0u; i < 9u; i++) {
        put_u32(p + 4u * i, (uint32_t)t->m[i]);
    }
    for (i = 0u; i < 3u; i++) {
        put_u32(p + 36u + 4u * i, (uint32_t)t->bias[i]);
    }
}

void calimg_build(const corr_cal_t *cal, const calimg_info_t *info, uint8_t buf[CALIMG_SIZE])
{
    uint8_t i;
    for (i = 0u; i < CALIMG_SIZE; i++) {
        buf[i] = 0u;
    }
    put_u32(buf, CALIMG_MAGIC);
    put_u16(buf + 4, CALIMG_VERSION);
    put_u16(buf + 6, CALIMG_SIZE);
    put_u32(buf + 8, info->serial);
    put_u32(buf + 12, info->time);
    buf[16] = info->method;
    encode_triad(buf + OFF_COEF, &cal->acc);
    encode_triad(buf + OFF_COEF + 48u, &cal->mag);
    put_u16(buf + CALIMG_CRC_OFFSET, crc16_update(CRC16_INIT, buf, CALIMG_CRC_OFFSET));
    buf[118] = 0xFFu;
    buf[119] = 0xFFu;
}
