/* proto_frame.c - SCI framing; contract in proto_frame.h. */
#include "inclino/proto_frame.h"
#include "inclino/crc16.h"

enum { S_IDLE = 0, S_VER, S_SEQ, S_CMD, S_LEN_H, S_LEN_L, S_PAYLOAD, S_CRC_H, S_CRC_L };

void proto_parser_init(proto_parser_t *p)
{
    p->state = S_IDLE;
    p->pos = 0u;
    p->crc = CRC16_INIT;
    p->len = 0u;
    p->line_len = 0u;
    p->line[0] = 0u;
}

static void crc_byte(proto_parser_t *p, uint8_t b)
{
    p->crc = crc16_byte(p->crc, b);
}

static uint8_t idle_byte(proto_parser_t *p, uint8_t byte)
{
    if (byte == PROTO_SOF) {
        p->state = S_VER;
        p->crc = CRC16_INIT;
        p->line_len = 0u; /* a frame ends any partial text line */
        return PF_NONE;
    }
    if (byte == 0x0Du || byte == 0x0Au) {
        if (p->line_len == 0u) {
            return PF_NONE;
        }
        p->line[p->line_len] = 0u;
        p->line_len = 0u;
        return PF_LINE;
    }
    if (byte >= 0x20u && byte <= 0x7Eu && p->line_len < PROTO_LINE_MAX) {
        p->line[p->line_len] = byte;
        p->line_len++;
    }
    return PF_NONE;
}

#ifdef PROTO_PORT_FEED
/* The S08 port's proto_frame_feed (firmware/port/s08/proto_feed_s08.c) takes
 * the header and payload bytes and hands every other state to this one. */
uint8_t proto_frame_feed_c(proto_parser_t *p, uint8_t byte);
#define proto_frame_feed proto_frame_feed_c
#endif

uint8_t proto_frame_feed(proto_parser_t *p, uint8_t byte)
{
    switch (p->state) {
    case S_VER:
        p->ver = byte;
        crc_byte(p, byte);
        p->state = S_SEQ;
        return PF_NONE;
    case S_SEQ:
        p->seq = byte;
        crc_byte(p, byte);
        p->state = S_CMD;
        return PF_NONE;
    case S_CMD:
        p->cmd = byte;
        crc_byte(p, byte);
        p->state = S_LEN_H;
        return PF_NONE;
    case S_LEN_H:
        p->len = (uint16_t)((uint16_t)byte << 8);
        crc_byte(p, byte);
        p->state = S_LEN_L;
        return PF_NONE;
    case S_LEN_L:
        p->len = (uint16_t)(p->len | byte);
        crc_byte(p, byte);
        if (p->len > PROTO_MAX_PAYLOAD) {
            p->state = S_IDLE;
            return PF_BAD_LEN;
        }
        p->pos = 0u;
        p->state = (p->len == 0u) ? S_CRC_H : S_PAYLOAD;
        return PF_NONE;
    case S_PAYLOAD:
        p->payload[p->pos] = byte;
        p->pos++;
        crc_byte(p, byte);
        if (p->pos == p->len) {
            p->state = S_CRC_H;
        }
        return PF_NONE;
    case S_CRC_H:
        p->crc_hi = byte;
        p->state = S_CRC_L;
        return PF_NONE;
    case S_CRC_L:
        p->state = S_IDLE;
        if ((uint16_t)(((uint16_t)p->crc_hi << 8) | byte) != p->crc) {
            return PF_BAD_CRC;
        }
        return PF_FRAME;
    default:
        return idle_byte(p, byte);
    }
}

#ifdef PROTO_PORT_FEED
#undef proto_frame_feed
#endif

uint8_t proto_parser_idle(proto_parser_t *p)
{
    if (p->state == S_IDLE) {
        return 0u;
    }
    p->state = S_IDLE;
    return 1u;
}

uint16_t proto_frame_encode(uint8_t seq, uint8_t cmd, const uint8_t *payload, uint16_t len,
                            uint8_t *out, uint16_t cap)
{
    uint16_t i, crc;
    if (len > PROTO_MAX_PAYLOAD || cap < (uint16_t)(len + PROTO_OVERHEAD)) {
        return 0u;
    }
    out[0] = PROTO_SOF;
    out[1] = PROTO_VERSION;
    out[2] = seq;
    out[3] = cmd;
    out[4] = (uint8_t)(len >> 8);
    out[5] = (uint8_t)len;
    for (i = 0u; i < len; i++) {
        out[6u + i] = payload[i];
    }
    crc = crc16_update(CRC16_INIT, out + 1, (uint16_t)(len + 5u));
    out[6u + len] = (uint8_t)(crc >> 8);
    out[7u + len] = (uint8_t)crc;
    return (uint16_t)(len + PROTO_OVERHEAD);
}

void proto_reply_init(proto_reply_t *r)
{
    r->have = 0u;
    r->seq = 0u;
    r->crc = 0u;
    r->len = 0u;
}

uint8_t proto_reply_is_retry(const proto_reply_t *r, const proto_parser_t *p)
{
    return (uint8_t)(r->have && p->seq == r->seq && p->crc == r->crc);
}

void proto_reply_remember(proto_reply_t *r, const proto_parser_t *p)
{
    r->have = 1u;
    r->seq = p->seq;
    r->crc = p->crc;
}

uint16_t proto_reply_encode(proto_reply_t *r, uint8_t seq, uint8_t cmd, const uint8_t *payload,
                            uint16_t len)
{
    r->len = proto_frame_encode(seq, cmd, payload, len, r->buf, (uint16_t)sizeof r->buf);
    return r->len;
}

uint16_t proto_reply_nak(proto_reply_t *r, uint8_t seq, uint8_t cmd, uint8_t code, uint8_t detail)
{
    uint8_t b[3];
    b[0] = cmd;
    b[1] = code;
    b[2] = detail;
    return proto_reply_encode(r, seq, PROTO_NAK, b, (uint16_t)((detail != 0u) ? 3u : 2u));
}
