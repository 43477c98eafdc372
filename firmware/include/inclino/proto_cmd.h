/*
 * proto_cmd.h - the SCI command layer (docs/protocol.md): turns parsed frames
 * and text lines into calls of the application and encodes the answers;
 * keeps the last answer for retries; runs the survey stream.
 *
 * The application is reached only through proto_app_t, so the protocol can be
 * tested and fuzzed alone.  Record layouts (identity, survey, raw, QC
 * reference) are built by the application in the documented byte order.
 */
#ifndef INCLINO_PROTO_CMD_H
#define INCLINO_PROTO_CMD_H

#include <stdint.h>

#include "inclino/proto_frame.h"

#define PCMD_IDENTIFY 0x01u
#define PCMD_SURVEY 0x02u
#define PCMD_STREAM 0x03u
#define PCMD_STOP 0x04u
#define PCMD_RAW 0x05u
#define PCMD_QCREF_READ 0x06u
#define PCMD_QCREF_WRITE 0x07u
#define PCMD_SURVEY_RAW 0x08u
#define PCMD_SET_AVERAGE 0x09u
#define PCMD_CAL_READ 0x10u
#define PCMD_CAL_WRITE 0x11u
#define PCMD_CAL_ACTIVATE 0x12u
#define PCMD_RESET 0x20u
#define PCMD_BOOTLOADER 0x21u
#define PCMD_NAK PROTO_NAK
#define PCMD_STREAM_FRAME 0x70u /* not a request (those are < 0x70) nor an answer (>= 0x80) */

#define PERR_CRC 1u
#define PERR_LENGTH 2u
#define PERR_VERSION 3u
#define PERR_COMMAND 4u
#define PERR_ARGUMENT 5u
#define PERR_BUSY 6u
#define PERR_SENSOR 7u
#define PERR_FLASH 8u
#define PERR_IMAGE 9u
#define PERR_SERIAL 10u
#define PERR_STATE 11u

#define PROTO_IDENTITY_LEN 34u
#define PROTO_SURVEY_LEN 36u
#define PROTO_RAW_LEN 31u /* i32 acc[3], mag[3] (Q6 counts), i16 temp, u8 n, i32 temp_q6 */
#define PROTO_QCREF_LEN 24u
#define PROTO_SURVEY_RAW_LEN (PROTO_SURVEY_LEN + PROTO_RAW_LEN)
#define PROTO_BOOT_KEY 0x424F4F54UL

/*
 * The application's side.  Each function returns 0 on success or a PERR_*
 * code (for cal_write, the PERR code in the low byte and a detail byte,
 * e.g. the CALIMG_E_* code, in the high byte).  Output buffers are sized by
 * the PROTO_*_LEN constants above.
 */
typedef struct {
    uint8_t (*identity)(uint8_t out[PROTO_IDENTITY_LEN]);
    uint8_t (*survey)(uint8_t out[PROTO_SURVEY_LEN]);
    /* a survey record followed by the raw record of the same acquisition */
    uint8_t (*survey_raw)(uint8_t out[PROTO_SURVEY_RAW_LEN]);
    uint8_t (*raw)(uint8_t out[PROTO_RAW_LEN]);
    uint8_t (*qcref_read)(uint8_t out[PROTO_QCREF_LEN]);
    uint8_t (*qcref_write)(const uint8_t in[PROTO_QCREF_LEN]);
    /* samples averaged per survey and raw reading, 1..64 */
    uint8_t (*set_average)(uint8_t n);
    /* out: u8 slot, u8 valid, u32 sequence, then the image (CALIMG_SIZE
     * bytes as stored; the answer is cut to the image's length field) */
    uint8_t (*cal_read)(uint8_t slot, uint8_t *out);
    /* image: its length field's bytes (120 or 192, checked against the
     * frame by the command layer); out: u8 slot, u32 sequence, u16 CRC */
    uint16_t (*cal_write)(const uint8_t *image, uint8_t force, uint8_t out[7]);
    /* out: u8 slot, u32 sequence */
    uint8_t (*cal_activate)(uint8_t slot, uint32_t sequence, uint8_t out[5]);
    void (*reset)(void);      /* called after the answer went out */
    void (*bootloader)(void); /* called after the answer went out */
    /* text console: fills a NUL-terminated line (at most 95 characters) */
    void (*text_identity)(char *out);
    void (*text_survey)(char *out);
    void (*send)(const uint8_t *data, uint16_t n);
} proto_app_t;

typedef struct {
    const proto_app_t *app;
    proto_parser_t parser;
    proto_reply_t reply; /* the last answer, for retries */
    uint8_t streaming;
    uint16_t stream_period_ms;
    uint16_t stream_left; /* 0 with streaming = until STOP */
    uint16_t stream_sent;
    uint8_t stream_seq;
    uint32_t stream_next_ms;
    uint8_t after; /* PCMD_RESET / PCMD_BOOTLOADER to run after the answer */
} proto_t;

/* proto_init - bind the application and reset the parser and the stream. */
void proto_init(proto_t *p, const proto_app_t *app);

/*
 * proto_rx - feed received bytes; answers are sent through app->send before
 *   it returns.  A request equal (same SEQ, same CRC) to the last executed
 *   one is answered from the cached answer without running again.
 */
void proto_rx(proto_t *p, const uint8_t *data, uint16_t n);

/* proto_idle - the line was silent for PROTO_IDLE_MS: drop a partial frame. */
void proto_idle(proto_t *p);

/*
 * proto_tick - run the survey stream: when now_ms has reached the next due
 *   time, send one 0x70 frame.  Call it from the main loop.
 */
void proto_tick(proto_t *p, uint32_t now_ms);

#endif /* INCLINO_PROTO_CMD_H */
