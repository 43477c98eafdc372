/*
 * proto_feed_s08.c - proto_frame_feed for the S08/HC08: the frequent states
 * (a payload byte and the first four header bytes) in assembly, the others
 * in the portable C.
 *
 * Same contract and the same events and fields as the portable
 * proto_frame_feed in firmware/src/proto_frame.c (proto_frame.h).  For the
 * states S_VER, S_SEQ, S_CMD, S_LEN_H and S_PAYLOAD it does what the C does:
 * the CRC step of crc16_byte (crc16.h: i = crc_hi ^ byte; the new register
 * is ((crc_lo ^ crc16_tab_hi[i]) << 8) | crc16_tab_lo[i]), then stores the
 * byte in its field (ver, seq, cmd, len's high byte with its low byte
 * cleared, or payload[pos] with pos + 1 and S_CRC_H once pos reaches len)
 * and moves to the next state; it returns PF_NONE, as the C does in those
 * states.  Every other state (S_IDLE, S_LEN_L, the two CRC bytes and any
 * other value) jumps to the portable function, compiled as
 * proto_frame_feed_c with -DPROTO_PORT_FEED, with the arguments untouched.
 * SDCC's code for a payload byte takes about 350 bus cycles; this takes
 * about 100 (docs/mcu.md).
 *
 * The parser's layout as SDCC lays out proto_parser_t (no padding,
 * big-endian): state 0, pos 1..2, crc 3..4, ver 5, seq 6, cmd 7, len 8..9,
 * crc_hi 10, payload 11..  The _Static_asserts below pin it.
 *
 * Built only by SDCC for hc08/s08 with --stack-auto (host/inclino/s08/toolchain.py).
 * SDCC's reentrant calling convention: p in X (high byte) and A (low byte),
 * byte at 3,s on entry; the result in A.  It works on the stack and the
 * parser structure only (no direct-page scratch), so it is reentrant for
 * different parsers; one parser must not be fed from an interrupt handler
 * and the main loop at once (as for the portable function).  Checked on the
 * simulator against the host build of the portable C
 * (tests/test_mcu_s08.py: the recorded streams and 400 random and corrupted
 * ones, every event and field).
 */
#include <stddef.h>
#include <stdint.h>

#include "inclino/crc16.h"
#include "inclino/proto_frame.h"

#if defined(__SDCC_s08) || defined(__SDCC_hc08)

#ifndef __SDCC_STACK_AUTO
#error "the S08 port's assembly expects the reentrant (--stack-auto) calling convention"
#endif

_Static_assert(offsetof(proto_parser_t, state) == 0, "state at 0");
_Static_assert(offsetof(proto_parser_t, pos) == 1, "pos at 1");
_Static_assert(offsetof(proto_parser_t, crc) == 3, "crc at 3");
_Static_assert(offsetof(proto_parser_t, ver) == 5, "ver at 5");
_Static_assert(offsetof(proto_parser_t, seq) == 6, "seq at 6");
_Static_assert(offsetof(proto_parser_t, cmd) == 7, "cmd at 7");
_Static_assert(offsetof(proto_parser_t, len) == 8, "len at 8");
_Static_assert(offsetof(proto_parser_t, payload) == 11, "payload at 11");

uint8_t proto_frame_feed_c(proto_parser_t *p, uint8_t byte);

#pragma save
#pragma less_pedantic
uint8_t proto_frame_feed(proto_parser_t *p, uint8_t byte) __naked
{
    p, byte; /* referenced in the assembly */
    /* clang-format off */
    __asm
    psha                        ; 2,s = p low byte
    pshx                        ; 1,s = p high byte; byte at 5,s
    ldhx    1,s                 ; H:X = p
    lda     ,x                  ; state: 1..4 header, 6 payload
    beq     9$                  ; S_IDLE
    cmp     #6
    beq     1$
    cmp     #5
    blo     1$
9$:                             ; S_IDLE, S_LEN_L, the CRC bytes, other values
    pulx                        ; p high byte
    pula                        ; p low byte
    jmp     _proto_frame_feed_c ; the portable C, arguments as received
1$:
    lda     4,x                 ; the CRC step: crc low byte
    psha                        ; 1,s = crc low; byte at 6,s
    lda     3,x                 ; crc high byte
    eor     6,s                 ; i = crc_hi ^ byte
    tax
    clrh
    pula                        ; crc low; byte at 5,s again
    eor     (_crc16_tab_hi),x   ; new high byte = crc_lo ^ tab_hi[i]
    psha                        ; 1,s = new high; p at 2..3,s
    lda     (_crc16_tab_lo),x   ; new low byte = tab_lo[i]
    ldhx    2,s
    sta     4,x
    pula
    sta     3,x
    lda     ,x
    cmp     #6
    beq     6$
    cmp     #2                  ; the header: 1 ver, 2 seq, 3 cmd, 4 len high
    blo     2$
    beq     3$
    cmp     #4
    blo     4$
    lda     5,s                 ; S_LEN_H: len = byte << 8
    sta     8,x
    clr     9,x
    lda     #5                  ; S_LEN_L
    bra     5$
2$:
    lda     5,s
    sta     5,x                 ; ver
    lda     #2                  ; S_SEQ
    bra     5$
3$:
    lda     5,s
    sta     6,x                 ; seq
    lda     #3                  ; S_CMD
    bra     5$
4$:
    lda     5,s
    sta     7,x                 ; cmd
    lda     #4                  ; S_LEN_H
5$:
    sta     ,x
    clra                        ; PF_NONE
    ais     #2
    rts
6$:
    lda     2,x                 ; S_PAYLOAD: payload[pos] = byte
    add     2,s                 ; p + pos, low byte
    psha
    lda     1,x
    adc     2,s                 ; p + pos, high byte (p high now at 2,s)
    psha                        ; 1..2,s = p + pos; byte at 7,s
    ldhx    1,s
    lda     7,s
    sta     11,x                ; payload is at 11
    ais     #2
    ldhx    1,s                 ; p
    inc     2,x                 ; pos + 1
    bne     7$
    inc     1,x
7$:
    lda     2,x                 ; pos == len: S_CRC_H
    cmp     9,x
    bne     8$
    lda     1,x
    cmp     8,x
    bne     8$
    lda     #7
    sta     ,x
8$:
    clra                        ; PF_NONE
    ais     #2
    rts
    __endasm;
    /* clang-format on */
}
#pragma restore

#else

/* Other compilers use the portable proto_frame_feed of firmware/src/proto_frame.c. */
typedef int proto_feed_s08_unused_t;

#endif
