/*
 * proto_frame.h - the SCI link's framing (docs/protocol.md): one byte-wise
 * parser for incoming frames and one encoder for outgoing frames, both
 * without dynamic memory.  The host's Python implementation
 * (host/inclino/link/protocol.py) is checked against the same byte vectors
 * (tests/vectors/frames.json).
 *
 * Frame, all multi-byte fields big-endian:
 *
 *   0xA5  VER  SEQ  CMD  LEN_H LEN_L  PAYLOAD[LEN]  CRC_H CRC_L
 *
 *   VER   protocol version, PROTO_VERSION
 *   SEQ   sequence number; an answer carries the request's SEQ
 *   CMD   command; answers set bit 7 (CMD | 0x80), a negative answer is
 *         PROTO_NAK with payload {request CMD, error code}
 *   LEN   payload length, 0..PROTO_MAX_PAYLOAD
 *   CRC   CRC-16/CCITT-FALSE over VER..PAYLOAD (not the 0xA5)
 *
 * Bytes outside a frame are either ignored (noise) or, when printable,
 * collected as a line for the text console (proto_frame_feed reports it).
 */
#ifndef INCLINO_PROTO_FRAME_H
#define INCLINO_PROTO_FRAME_H

#include <stdint.h>

#define PROTO_SOF 0xA5u
#define PROTO_VERSION 1u
#define PROTO_MAX_PAYLOAD 200u
#define PROTO_OVERHEAD 8u /* SOF, VER, SEQ, CMD, LEN (2), CRC (2) */
#define PROTO_LINE_MAX 32u

/* proto_frame_feed results */
#define PF_NONE 0u    /* byte consumed, nothing complete yet */
#define PF_FRAME 1u   /* a frame with a good CRC is in p->ver..p->payload */
#define PF_BAD_CRC 2u /* a complete frame failed its CRC (p->seq, p->cmd as received) */
#define PF_BAD_LEN 3u /* a header announced more than PROTO_MAX_PAYLOAD */
#define PF_LINE 4u    /* a text line (terminated by CR or LF) is in p->line */

typedef struct {
    uint8_t state;
    uint16_t pos; /* bytes of payload received */
    uint16_t crc; /* running CRC */
    uint8_t ver;
    uint8_t seq;
    uint8_t cmd;
    uint16_t len;
    uint8_t crc_hi;
    uint8_t payload[PROTO_MAX_PAYLOAD];
    uint8_t line[PROTO_LINE_MAX + 1u]; /* NUL-terminated text line */
    uint8_t line_len;
} proto_parser_t;

/* proto_parser_init - reset to "waiting for a frame or a text line". */
void proto_parser_init(proto_parser_t *p);

/*
 * proto_frame_feed - advance the parser by one received byte.
 *   Returns PF_*.  After PF_FRAME the fields ver, seq, cmd, len and
 *   payload[0..len) hold the frame until the next call.  A frame with a bad
 *   CRC or length is dropped whole (PF_BAD_CRC / PF_BAD_LEN) and the parser
 *   looks for the next 0xA5.  Printable bytes (0x20..0x7E) outside a frame
 *   build a text line of at most PROTO_LINE_MAX characters (longer lines are
 *   cut), returned as PF_LINE on CR or LF; other bytes outside a frame are
 *   ignored.  Constant time per byte, no allocation.
 */
uint8_t proto_frame_feed(proto_parser_t *p, uint8_t byte);

/*
 * proto_parser_idle - the line has been silent for PROTO_IDLE_MS while a
 *   frame was incomplete: drop it and wait for the next 0xA5.  This is how
 *   the parser recovers when noise contained a 0xA5 whose length field
 *   swallows the real frame that follows; the host's retry then gets through.
 *   Returns 1 when a partial frame was dropped, else 0.
 */
#define PROTO_IDLE_MS 20u
uint8_t proto_parser_idle(proto_parser_t *p);

/*
 * proto_frame_encode - write one frame into out (capacity cap bytes).
 *   Returns the frame's length (len + PROTO_OVERHEAD), or 0 when len >
 *   PROTO_MAX_PAYLOAD or the frame does not fit cap.
 */
uint16_t proto_frame_encode(uint8_t seq, uint8_t cmd, const uint8_t *payload, uint16_t len,
                            uint8_t *out, uint16_t cap);

/*
 * The answer cache both command layers (application and bootloader) keep:
 * the last answer sent, and the identity (SEQ and CRC) of the request it
 * answered, so that a retried request is answered again without running
 * twice (docs/protocol.md).
 */
#define PROTO_NAK 0x7Fu /* negative answer: payload {request CMD, error code[, detail]} */

typedef struct {
    uint8_t have; /* a request was executed since init */
    uint8_t seq;  /* its SEQ */
    uint16_t crc; /* its CRC */
    uint16_t len; /* bytes of the cached answer */
    uint8_t buf[PROTO_MAX_PAYLOAD + PROTO_OVERHEAD];
} proto_reply_t;

/* proto_reply_init - forget the last request and answer. */
void proto_reply_init(proto_reply_t *r);

/* proto_reply_is_retry - 1 when the frame the parser just completed is the
 *   last executed request again (same SEQ and CRC). */
uint8_t proto_reply_is_retry(const proto_reply_t *r, const proto_parser_t *p);

/* proto_reply_remember - the frame the parser just completed was executed. */
void proto_reply_remember(proto_reply_t *r, const proto_parser_t *p);

/* proto_reply_encode - encode an answer into the cache; returns its length
 *   (0 when the payload is too long).  The caller sends r->buf. */
uint16_t proto_reply_encode(proto_reply_t *r, uint8_t seq, uint8_t cmd, const uint8_t *payload,
                            uint16_t len);

/* proto_reply_nak - encode a negative answer {cmd, code[, detail]} (the
 *   detail byte only when non-zero) into the cache; returns its length. */
uint16_t proto_reply_nak(proto_reply_t *r, uint8_t seq, uint8_t cmd, uint8_t code, uint8_t detail);

#endif /* INCLINO_PROTO_FRAME_H */
