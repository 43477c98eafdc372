/* proto_cmd.c - SCI command layer; contract in proto_cmd.h. */
#include "inclino/proto_cmd.h"
#include "inclino/be_bytes.h"
#include "inclino/calimg.h"
#include "inclino/text_fmt.h"

#define TEXT_MAX 96u

void proto_init(proto_t *p, const proto_app_t *app)
{
    p->app = app;
    proto_parser_init(&p->parser);
    proto_reply_init(&p->reply);
    p->streaming = 0u;
    p->stream_left = 0u;
    p->stream_sent = 0u;
    p->stream_seq = 0u;
    p->stream_next_ms = 0u;
    p->after = 0u;
}

/* Encode an answer into the retry cache and send it. */
static void answer(proto_t *p, uint8_t seq, uint8_t cmd, const uint8_t *payload, uint16_t len)
{
    p->app->send(p->reply.buf, proto_reply_encode(&p->reply, seq, cmd, payload, len));
}

static void nak(proto_t *p, uint8_t seq, uint8_t cmd, uint8_t code, uint8_t detail)
{
    p->app->send(p->reply.buf, proto_reply_nak(&p->reply, seq, cmd, code, detail));
}

static void send_text(proto_t *p, const char *s)
{
    uint16_t n = 0u;
    while (n < TEXT_MAX && s[n] != '\0') {
        n++;
    }
    p->app->send((const uint8_t *)s, n);
    p->app->send((const uint8_t *)"\r\n", 2u);
}

static uint8_t line_is(const uint8_t *line, const char *word)
{
    uint8_t i = 0u;
    while (word[i] != '\0') {
        if (txt_upper(line[i]) != (uint8_t)word[i]) {
            return 0u;
        }
        i++;
    }
    return (uint8_t)(line[i] == 0u);
}

static void text_command(proto_t *p)
{
    char buf[TEXT_MAX];
    const uint8_t *line = p->parser.line;
    if (line_is(line, "ID")) {
        p->app->text_identity(buf);
        send_text(p, buf);
    } else if (line_is(line, "SV")) {
        if (p->streaming) {
            send_text(p, "BUSY: streaming");
            return;
        }
        p->app->text_survey(buf);
        send_text(p, buf);
    } else if (line_is(line, "HELP")) {
        send_text(p, "ID identify  SV survey  HELP this list");
    } else {
        send_text(p, "? HELP lists the commands");
    }
}

/* Execute one good frame (not a retry). */
static void execute(proto_t *p, uint8_t seq, uint8_t cmd, const uint8_t *pl, uint16_t len)
{
    uint8_t out[126];
    uint8_t rc;
    uint16_t rc16;

    out[0] = 0u; /* answers with no payload still pass a valid pointer */

    if (p->streaming && cmd != PCMD_STOP && cmd != PCMD_IDENTIFY) {
        nak(p, seq, cmd, PERR_BUSY, 0u);
        return;
    }
    switch (cmd) {
    case PCMD_IDENTIFY:
    case PCMD_SURVEY:
    case PCMD_RAW:
    case PCMD_QCREF_READ:
    case PCMD_SURVEY_RAW:
        if (len != 0u) {
            nak(p, seq, cmd, PERR_LENGTH, 0u);
            return;
        }
        if (cmd == PCMD_IDENTIFY) {
            rc = p->app->identity(out);
            len = PROTO_IDENTITY_LEN;
        } else if (cmd == PCMD_SURVEY) {
            rc = p->app->survey(out);
            len = PROTO_SURVEY_LEN;
        } else if (cmd == PCMD_SURVEY_RAW) {
            rc = p->app->survey_raw(out);
            len = PROTO_SURVEY_RAW_LEN;
        } else if (cmd == PCMD_RAW) {
            rc = p->app->raw(out);
            len = PROTO_RAW_LEN;
        } else {
            rc = p->app->qcref_read(out);
            len = PROTO_QCREF_LEN;
        }
        if (rc != 0u) {
            nak(p, seq, cmd, rc, 0u);
        } else {
            answer(p, seq, (uint8_t)(cmd | 0x80u), out, len);
        }
        return;
    case PCMD_QCREF_WRITE:
        if (len != PROTO_QCREF_LEN) {
            nak(p, seq, cmd, PERR_LENGTH, 0u);
            return;
        }
        rc = p->app->qcref_write(pl);
        if (rc != 0u) {
            nak(p, seq, cmd, rc, 0u);
        } else {
            answer(p, seq, (uint8_t)(cmd | 0x80u), out, 0u);
        }
        return;
    case PCMD_SET_AVERAGE:
        if (len != 1u) {
            nak(p, seq, cmd, PERR_LENGTH, 0u);
            return;
        }
        rc = p->app->set_average(pl[0]);
        if (rc != 0u) {
            nak(p, seq, cmd, rc, 0u);
        } else {
            out[0] = pl[0];
            answer(p, seq, (uint8_t)(cmd | 0x80u), out, 1u);
        }
        return;
    case PCMD_STREAM:
        if (len != 4u) {
            nak(p, seq, cmd, PERR_LENGTH, 0u);
            return;
        }
        if (be_get_u16(pl) == 0u) {
            nak(p, seq, cmd, PERR_ARGUMENT, 0u);
            return;
        }
        answer(p, seq, (uint8_t)(cmd | 0x80u), out, 0u);
        p->stream_period_ms = be_get_u16(pl);
        p->stream_left = be_get_u16(pl + 2);
        p->stream_sent = 0u;
        p->streaming = 1u;
        p->stream_next_ms = 0u; /* first frame at the next tick */
        return;
    case PCMD_STOP:
        if (len != 0u) {
            nak(p, seq, cmd, PERR_LENGTH, 0u);
            return;
        }
        p->streaming = 0u;
        out[0] = (uint8_t)(p->stream_sent >> 8);
        out[1] = (uint8_t)p->stream_sent;
        answer(p, seq, (uint8_t)(cmd | 0x80u), out, 2u);
        return;
    case PCMD_CAL_READ:
        if (len != 1u) {
            nak(p, seq, cmd, PERR_LENGTH, 0u);
            return;
        }
        if (pl[0] > 1u) {
            nak(p, seq, cmd, PERR_ARGUMENT, 0u);
            return;
        }
        rc = p->app->cal_read(pl[0], out);
        if (rc != 0u) {
            nak(p, seq, cmd, rc, 0u);
        } else {
            answer(p, seq, (uint8_t)(cmd | 0x80u), out, (uint16_t)(6u + CALIMG_SIZE));
        }
        return;
    case PCMD_CAL_WRITE:
        if (len != 1u + CALIMG_SIZE) {
            nak(p, seq, cmd, PERR_LENGTH, 0u);
            return;
        }
        rc16 = p->app->cal_write(pl + 1, pl[0], out);
        if (rc16 != 0u) {
            nak(p, seq, cmd, (uint8_t)rc16, (uint8_t)(rc16 >> 8));
        } else {
            answer(p, seq, (uint8_t)(cmd | 0x80u), out, 7u);
        }
        return;
    case PCMD_CAL_ACTIVATE:
        if (len != 5u) {
            nak(p, seq, cmd, PERR_LENGTH, 0u);
            return;
        }
        rc = p->app->cal_activate(pl[0], be_get_u32(pl + 1), out);
        if (rc != 0u) {
            nak(p, seq, cmd, rc, 0u);
        } else {
            answer(p, seq, (uint8_t)(cmd | 0x80u), out, 5u);
        }
        return;
    case PCMD_RESET:
        if (len != 0u) {
            nak(p, seq, cmd, PERR_LENGTH, 0u);
            return;
        }
        answer(p, seq, (uint8_t)(cmd | 0x80u), out, 0u);
        p->after = PCMD_RESET;
        return;
    case PCMD_BOOTLOADER:
        if (len != 4u) {
            nak(p, seq, cmd, PERR_LENGTH, 0u);
            return;
        }
        if (be_get_u32(pl) != PROTO_BOOT_KEY) {
            nak(p, seq, cmd, PERR_ARGUMENT, 0u);
            return;
        }
        answer(p, seq, (uint8_t)(cmd | 0x80u), out, 0u);
        p->after = PCMD_BOOTLOADER;
        return;
    default:
        nak(p, seq, cmd, PERR_COMMAND, 0u);
        return;
    }
}

static void on_frame(proto_t *p)
{
    proto_parser_t *f = &p->parser;
    if (proto_reply_is_retry(&p->reply, f)) {
        p->app->send(p->reply.buf, p->reply.len); /* a retry: answer again, run nothing */
        return;
    }
    if (f->ver != PROTO_VERSION) {
        nak(p, f->seq, f->cmd, PERR_VERSION, 0u);
    } else {
        execute(p, f->seq, f->cmd, f->payload, f->len);
    }
    proto_reply_remember(&p->reply, f);
}

void proto_rx(proto_t *p, const uint8_t *data, uint16_t n)
{
    uint16_t i;
    for (i = 0u; i < n; i++) {
        uint8_t r = proto_frame_feed(&p->parser, data[i]);
        if (r == PF_FRAME) {
            on_frame(p);
        } else if (r == PF_BAD_CRC) {
            uint8_t b[2];
            b[0] = p->parser.cmd;
            b[1] = PERR_CRC;
            /* not cached: a corrupt request never replaces the last answer */
            {
                uint8_t tmp[PROTO_OVERHEAD + 2u];
                uint16_t m = proto_frame_encode(p->parser.seq, PCMD_NAK, b, 2u, tmp,
                                                (uint16_t)sizeof tmp);
                p->app->send(tmp, m);
            }
        } else if (r == PF_LINE) {
            text_command(p);
        }
        if (p->after != 0u) {
            uint8_t what = p->after;
            p->after = 0u;
            if (what == PCMD_RESET) {
                p->app->reset();
            } else {
                p->app->bootloader();
            }
            return;
        }
    }
}

void proto_idle(proto_t *p)
{
    (void)proto_parser_idle(&p->parser);
}

void proto_tick(proto_t *p, uint32_t now_ms)
{
    uint8_t rec[PROTO_SURVEY_LEN];
    uint8_t frame[PROTO_SURVEY_LEN + PROTO_OVERHEAD];
    uint16_t n;
    /* not due while now_ms is before stream_next_ms (modulo 2^32) */
    if (!p->streaming || (uint32_t)(now_ms - p->stream_next_ms) >= 0x80000000UL) {
        return;
    }
    if (p->app->survey(rec) != 0u) {
        p->streaming = 0u; /* a sensor failed: the host sees the stream stop */
        return;
    }
    n = proto_frame_encode(p->stream_seq, PCMD_STREAM_FRAME, rec, PROTO_SURVEY_LEN, frame,
                           (uint16_t)sizeof frame);
    p->app->send(frame, n);
    p->stream_seq++;
    p->stream_sent++;
    p->stream_next_ms = now_ms + p->stream_period_ms;
    if (p->stream_left != 0u) {
        p->stream_left--;
        if (p->stream_left == 0u) {
            p->streaming = 0u;
        }
    }
}
