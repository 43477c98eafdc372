/*
 * proto_dispatch.h - the table-driven command dispatch shared by the
 * application's command layer (proto_cmd.c) and the bootloader's (boot.c):
 * find the request's command in a const table, check the payload length the
 * table allows (else NAK PERR_LENGTH), run the handler, and send its answer
 * (CMD | 0x80) or its NAK {CMD, code[, detail]} through the retry cache.
 * What differs between the two layers -- their commands, the application's
 * BUSY gate while streaming, the bootloader's code for an unknown command --
 * stays with them.
 */
#ifndef INCLINO_PROTO_DISPATCH_H
#define INCLINO_PROTO_DISPATCH_H

#include <stdint.h>

#include "inclino/proto_frame.h"

/* len_a / len_b: the handler checks the length itself */
#define PROTO_LEN_ANY 0xFFFFu

/*
 * A command's handler.  ctx is the layer's state (proto_t, boot_t); pl and
 * len the request's payload, its length already allowed by the table; out
 * has room for PROTO_MAX_PAYLOAD bytes and out[0] is 0 on entry.  Returns 0
 * with the answer's payload in out[0 .. *out_len) (*out_len is 0 on entry),
 * or a refusal: the PERR_* code in the low byte and the NAK's detail byte
 * (0: none) in the high byte.
 */
typedef uint16_t (*proto_handler_t)(void *ctx, uint8_t cmd, const uint8_t *pl, uint16_t len,
                                    uint8_t *out, uint16_t *out_len);

typedef struct {
    uint8_t cmd;    /* request code */
    uint16_t len_a; /* an allowed payload length, or PROTO_LEN_ANY */
    uint16_t len_b; /* another (len_a again when there is one) */
    proto_handler_t run;
} proto_command_t;

/*
 * proto_dispatch - run request (seq, cmd, pl[0..len)) through table[0..n):
 *   returns 0 when cmd is not in the table (nothing sent: the caller NAKs),
 *   else 1 after the answer or the NAK went out through send (encoded into
 *   reply, the retry cache).
 */
uint8_t proto_dispatch(const proto_command_t *table, uint8_t n, void *ctx, proto_reply_t *reply,
                       void (*send)(const uint8_t *data, uint16_t n), uint8_t seq, uint8_t cmd,
                       const uint8_t *pl, uint16_t len);

/*
 * proto_nak_bad_crc - NAK {CMD, PERR_CRC} for the frame the parser just
 *   failed (its SEQ and CMD as received), not through the retry cache: a
 *   corrupt request never replaces the last answer.
 */
void proto_nak_bad_crc(const proto_parser_t *parser,
                       void (*send)(const uint8_t *data, uint16_t n));

#endif /* INCLINO_PROTO_DISPATCH_H */
