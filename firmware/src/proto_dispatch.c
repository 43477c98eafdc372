/* proto_dispatch.c - table-driven command dispatch; contract in proto_dispatch.h. */
#include "inclino/proto_dispatch.h"
#include "inclino/proto_cmd.h"

uint8_t proto_dispatch(const proto_command_t *table, uint8_t n, void *ctx, proto_reply_t *reply,
                       void (*send)(const uint8_t *data, uint16_t n), uint8_t seq, uint8_t cmd,
                       const uint8_t *pl, uint16_t len)
{
    uint8_t out[PROTO_MAX_PAYLOAD];
    uint16_t out_len = 0u;
    uint16_t rc;
    uint8_t i = 0u;

    while (i < n && table[i].cmd != cmd) {
        i++;
    }
    if (i == n) {
        return 0u;
    }
    if (table[i].len_a != PROTO_LEN_ANY && len != table[i].len_a && len != table[i].len_b) {
        send(reply->buf, proto_reply_nak(reply, seq, cmd, PERR_LENGTH, 0u));
        return 1u;
    }
    out[0] = 0u; /* answers with no payload still pass a valid pointer */
    rc = table[i].run(ctx, cmd, pl, len, out, &out_len);
    if (rc != 0u) {
        send(reply->buf, proto_reply_nak(reply, seq, cmd, (uint8_t)rc, (uint8_t)(rc >> 8)));
    } else {
        send(reply->buf, proto_reply_encode(reply, seq, (uint8_t)(cmd | 0x80u), out, out_len));
    }
    return 1u;
}

void proto_nak_bad_crc(const proto_parser_t *parser, void (*send)(const uint8_t *data, uint16_t n))
{
    uint8_t b[2];
    uint8_t tmp[PROTO_OVERHEAD + 2u];
    uint16_t m;
    b[0] = parser->cmd;
    b[1] = PERR_CRC;
    m = proto_frame_encode(parser->seq, PCMD_NAK, b, 2u, tmp, (uint16_t)sizeof tmp);
    send(tmp, m);
}
