/* proto_cmd.c - SCI command layer; contract in proto_cmd.h. */
#include "inclino/proto_cmd.h"
#include "inclino/be_bytes.h"
#include "inclino/calimg.h"
#include "inclino/proto_dispatch.h"
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

/* ------------------------------------------------------------ commands */
/* Handlers (proto_dispatch.h): 0 and the answer in out, or a PERR_* code
 * (detail byte in the high byte). */

/* IDENTIFY, SURVEY, SURVEY_RAW, RAW, QCREF_READ: a record from the application */
static uint16_t h_record(void *ctx, uint8_t cmd, const uint8_t *pl, uint16_t len, uint8_t *out,
                         uint16_t *out_len)
{
    const proto_app_t *app = ((proto_t *)ctx)->app;
    (void)pl;
    (void)len;
    if (cmd == PCMD_IDENTIFY) {
        *out_len = PROTO_IDENTITY_LEN;
        return app->identity(out);
    }
    if (cmd == PCMD_SURVEY) {
        *out_len = PROTO_SURVEY_LEN;
        return app->survey(out);
    }
    if (cmd == PCMD_SURVEY_RAW) {
        *out_len = PROTO_SURVEY_RAW_LEN;
        return app->survey_raw(out);
    }
    if (cmd == PCMD_RAW) {
        *out_len = PROTO_RAW_LEN;
        return app->raw(out);
    }
    *out_len = PROTO_QCREF_LEN;
    return app->qcref_read(out);
}

static uint16_t h_qcref_write(void *ctx, uint8_t cmd, const uint8_t *pl, uint16_t len,
                              uint8_t *out, uint16_t *out_len)
{
    (void)cmd;
    (void)len;
    (void)out;
    (void)out_len;
    return ((proto_t *)ctx)->app->qcref_write(pl);
}

static uint16_t h_set_average(void *ctx, uint8_t cmd, const uint8_t *pl, uint16_t len,
                              uint8_t *out, uint16_t *out_len)
{
    uint8_t rc = ((proto_t *)ctx)->app->set_average(pl[0]);
    (void)cmd;
    (void)len;
    out[0] = pl[0];
    *out_len = 1u;
    return rc;
}

static uint16_t h_stream(void *ctx, uint8_t cmd, const uint8_t *pl, uint16_t len, uint8_t *out,
                         uint16_t *out_len)
{
    proto_t *p = (proto_t *)ctx;
    (void)cmd;
    (void)len;
    (void)out;
    (void)out_len;
    if (be_get_u16(pl) == 0u) {
        return PERR_ARGUMENT;
    }
    p->stream_period_ms = be_get_u16(pl);
    p->stream_left = be_get_u16(pl + 2);
    p->stream_sent = 0u;
    p->streaming = 1u;
    p->stream_next_ms = 0u; /* first frame at the next tick */
    return 0u;
}

static uint16_t h_stop(void *ctx, uint8_t cmd, const uint8_t *pl, uint16_t len, uint8_t *out,
                       uint16_t *out_len)
{
    proto_t *p = (proto_t *)ctx;
    (void)cmd;
    (void)pl;
    (void)len;
    p->streaming = 0u;
    be_put_u16(out, p->stream_sent);
    *out_len = 2u;
    return 0u;
}

static uint16_t h_cal_read(void *ctx, uint8_t cmd, const uint8_t *pl, uint16_t len, uint8_t *out,
                           uint16_t *out_len)
{
    uint8_t st;
    uint16_t n;
    (void)cmd;
    (void)len;
    if (pl[0] > 1u) {
        return PERR_ARGUMENT;
    }
    st = ((proto_t *)ctx)->app->cal_read(pl[0], out);
    /* the image's own length (120 or 192); all CALIMG_SIZE bytes when the
     * slot holds no readable length field */
    n = calimg_length(out + 6);
    *out_len = (uint16_t)(6u + ((n != 0u) ? n : CALIMG_SIZE));
    return st;
}

static uint16_t h_cal_write(void *ctx, uint8_t cmd, const uint8_t *pl, uint16_t len, uint8_t *out,
                            uint16_t *out_len)
{
    uint16_t n;
    (void)cmd;
    *out_len = 7u;
    /* an image whose length field (120 or 192) is not the frame's: refused
     * here, so that no check reads past the frame; any other length field
     * is the image check's to refuse (calimg_parse reads 8 bytes of it) */
    n = calimg_length(pl + 1);
    if (n != 0u && len != 1u + n) {
        return (uint16_t)(PERR_IMAGE | ((uint16_t)CALIMG_E_LENGTH << 8));
    }
    return ((proto_t *)ctx)->app->cal_write(pl + 1, pl[0], out);
}

static uint16_t h_cal_activate(void *ctx, uint8_t cmd, const uint8_t *pl, uint16_t len,
                               uint8_t *out, uint16_t *out_len)
{
    (void)cmd;
    (void)len;
    *out_len = 5u;
    return ((proto_t *)ctx)->app->cal_activate(pl[0], be_get_u32(pl + 1), out);
}

/* RESET, BOOTLOADER: answered, then run once the answer is queued (proto_rx) */
static uint16_t h_after(void *ctx, uint8_t cmd, const uint8_t *pl, uint16_t len, uint8_t *out,
                        uint16_t *out_len)
{
    (void)len;
    (void)out;
    (void)out_len;
    if (cmd == PCMD_BOOTLOADER && be_get_u32(pl) != PROTO_BOOT_KEY) {
        return PERR_ARGUMENT;
    }
    ((proto_t *)ctx)->after = cmd;
    return 0u;
}

static const proto_command_t commands[] = {
    {PCMD_IDENTIFY, 0u, 0u, h_record},
    {PCMD_SURVEY, 0u, 0u, h_record},
    {PCMD_RAW, 0u, 0u, h_record},
    {PCMD_QCREF_READ, 0u, 0u, h_record},
    {PCMD_SURVEY_RAW, 0u, 0u, h_record},
    {PCMD_QCREF_WRITE, PROTO_QCREF_LEN, PROTO_QCREF_LEN, h_qcref_write},
    {PCMD_SET_AVERAGE, 1u, 1u, h_set_average},
    {PCMD_STREAM, 4u, 4u, h_stream},
    {PCMD_STOP, 0u, 0u, h_stop},
    {PCMD_CAL_READ, 1u, 1u, h_cal_read},
    {PCMD_CAL_WRITE, 1u + CALIMG_SIZE_V1, 1u + CALIMG_SIZE, h_cal_write},
    {PCMD_CAL_ACTIVATE, 5u, 5u, h_cal_activate},
    {PCMD_RESET, 0u, 0u, h_after},
    {PCMD_BOOTLOADER, 4u, 4u, h_after},
};

/* Execute one good frame (not a retry). */
static void execute(proto_t *p, uint8_t seq, uint8_t cmd, const uint8_t *pl, uint16_t len)
{
    if (p->streaming && cmd != PCMD_STOP && cmd != PCMD_IDENTIFY) {
        nak(p, seq, cmd, PERR_BUSY, 0u);
        return;
    }
    if (!proto_dispatch(commands, (uint8_t)(sizeof commands / sizeof commands[0]), p, &p->reply,
                        p->app->send, seq, cmd, pl, len)) {
        nak(p, seq, cmd, PERR_COMMAND, 0u);
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
            proto_nak_bad_crc(&p->parser, p->app->send);
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
