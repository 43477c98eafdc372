/*
 * fx_sqrt_s08.c - fx_isqrt_u32 and fx_sqrt_u32_q8 for the S08/HC08 (the
 * port's square roots).
 *
 * Same contracts and the same result bits as the portable functions in
 * firmware/src/fx_math.c (fx_math.h).  Both rest on y = floor(sqrt(x)) and
 * r = x - y^2, which do not depend on the method: here the digit-by-digit
 * method, two bits of x a step, on a 3-byte remainder and T = 4 * (the root
 * so far):
 *   rem = 4 rem + (next two bits of x); if rem > T: rem -= T + 1, bit = 1;
 *   T = 2 T + 4 bit                              (16 steps, y = T / 4)
 * (r <= 2y < 2^17 and T < 2^18 fit three bytes; the first 4 steps need one
 * byte, the next 8 two), 40 to 95 bus cycles a step instead of about 240
 * in SDCC's code for the 32-bit bitwise method.  fx_sqrt_u32_q8 then
 * follows the C: the same normalisation x' = x * 4^k (whole bytes first),
 * the same exact q = floor((256 r + y) / (2y + 1)) (an estimate from the
 * S08's 16 / 8 DIV, corrected by at most a few steps, instead of 9
 * restoring steps), s = 256 y + q and round(s / 2^k) half up, computed as
 * ((s >> (k - 1)) + 1) >> 1.
 *
 * Built only by SDCC for hc08/s08 with --stack-auto, the core compiled with
 * -DFX_PORT_SQRT (host/inclino/s08/toolchain.py).  Reentrant calling convention: x at
 * 3..6,s on entry (big-endian); results in ___SDCC_hc08_ret3,
 * ___SDCC_hc08_ret2, X, A (most to least significant byte; X, A for the
 * uint16).  Both keep their work in eleven direct-page bytes of this module,
 * so they must not be called from an interrupt handler while the main
 * program may be in one of them.
 */
#include <stdint.h>

#include "inclino/fx_math.h"

#if defined(__SDCC_s08) || defined(__SDCC_hc08)

#ifndef __SDCC_STACK_AUTO
#error "the S08 port's assembly expects the reentrant (--stack-auto) calling convention"
#endif

/* direct-page work: x (4 bytes, most significant first), rem (3), T (3), a
 * step count; fx_sqrt_u32_q8 reuses them for its division */
static __data uint8_t fx_sq_x[4];
static __data uint8_t fx_sq_r[3];
static __data uint8_t fx_sq_t[3];
static __data uint8_t fx_sq_n;

#pragma save
#pragma less_pedantic
uint16_t fx_isqrt_u32(uint32_t x) __naked
{
    x; /* referenced in the assembly */
    /* clang-format off */
    __asm
    lda     3,s
    sta     *_fx_sq_x
    lda     4,s
    sta     *(_fx_sq_x + 1)
    lda     5,s
    sta     *(_fx_sq_x + 2)
    lda     6,s
    sta     *(_fx_sq_x + 3)
    jsr     fx_sq_core
    lda     *(_fx_sq_t + 2)     ; y = T / 4
    ldx     *(_fx_sq_t + 1)
    lsr     *_fx_sq_t
    rorx
    rora
    lsr     *_fx_sq_t
    rorx
    rora
    rts

    ; ---- y = floor(sqrt(x)) as T = 4 y, rem = x - y^2, for x in fx_sq_x
fx_sq_core:
    clra
    sta     *_fx_sq_r
    sta     *(_fx_sq_r + 1)
    sta     *(_fx_sq_r + 2)
    sta     *_fx_sq_t
    sta     *(_fx_sq_t + 1)
    sta     *(_fx_sq_t + 2)
    ; steps 1 to 4 (the bits of x0) on one byte: rem < 2^6, T < 2^7
    ldx     #4
    stx     *_fx_sq_n
    lda     *_fx_sq_x
1$:
    lsla
    rol     *(_fx_sq_r + 2)
    lsla
    rol     *(_fx_sq_r + 2)
    tax                         ; the bits still to come
    sec
    lda     *(_fx_sq_r + 2)
    sbc     *(_fx_sq_t + 2)
    bcs     2$
    sta     *(_fx_sq_r + 2)
    lsl     *(_fx_sq_t + 2)
    bset    #2,*(_fx_sq_t + 2)
    txa
    dbnz    *_fx_sq_n,1$
    bra     3$
2$:
    lsl     *(_fx_sq_t + 2)
    txa
    dbnz    *_fx_sq_n,1$
3$:
    ; steps 5 to 12 (the bits of x1, x2) on two bytes: rem < 2^14, T < 2^13
    lda     *(_fx_sq_x + 1)
    bsr     fx_sq_two
    lda     *(_fx_sq_x + 2)
    bsr     fx_sq_two
    ; steps 13 to 16 (the bits of x3) on three bytes
    lda     *(_fx_sq_x + 3)
    bra     fx_sq_byte
    ; four steps on the bits of A, two bytes
fx_sq_two:
    ldx     #4
    stx     *_fx_sq_n
4$:
    lsla
    rol     *(_fx_sq_r + 2)
    rol     *(_fx_sq_r + 1)
    lsla
    rol     *(_fx_sq_r + 2)
    rol     *(_fx_sq_r + 1)
    psha
    sec
    lda     *(_fx_sq_r + 2)
    sbc     *(_fx_sq_t + 2)
    tax
    lda     *(_fx_sq_r + 1)
    sbc     *(_fx_sq_t + 1)
    bcs     5$
    sta     *(_fx_sq_r + 1)
    stx     *(_fx_sq_r + 2)
    lsl     *(_fx_sq_t + 2)
    rol     *(_fx_sq_t + 1)
    bset    #2,*(_fx_sq_t + 2)
    pula
    dbnz    *_fx_sq_n,4$
    rts
5$:
    lsl     *(_fx_sq_t + 2)
    rol     *(_fx_sq_t + 1)
    pula
    dbnz    *_fx_sq_n,4$
    rts
    ; four steps on the bits of A, three bytes, then return
fx_sq_byte:
    ldx     #4
    stx     *_fx_sq_n
1$:
    lsla                        ; rem = 4 rem + the top two bits of A
    rol     *(_fx_sq_r + 2)
    rol     *(_fx_sq_r + 1)
    rol     *_fx_sq_r
    lsla
    rol     *(_fx_sq_r + 2)
    rol     *(_fx_sq_r + 1)
    rol     *_fx_sq_r
    psha                        ; the bits still to come
    sec                         ; rem - T - 1 >= 0 ?
    lda     *(_fx_sq_r + 2)
    sbc     *(_fx_sq_t + 2)
    tax
    lda     *(_fx_sq_r + 1)
    sbc     *(_fx_sq_t + 1)
    psha
    lda     *_fx_sq_r
    sbc     *_fx_sq_t
    bcs     2$
    sta     *_fx_sq_r           ; rem -= T + 1; T = 2 T + 4
    pula
    sta     *(_fx_sq_r + 1)
    stx     *(_fx_sq_r + 2)
    lsl     *(_fx_sq_t + 2)
    rol     *(_fx_sq_t + 1)
    rol     *_fx_sq_t
    bset    #2,*(_fx_sq_t + 2)  ; bit 2 of 2 T is 0
    pula
    dbnz    *_fx_sq_n,1$
    rts
2$:
    ais     #1                  ; T = 2 T
    lsl     *(_fx_sq_t + 2)
    rol     *(_fx_sq_t + 1)
    rol     *_fx_sq_t
    pula
    dbnz    *_fx_sq_n,1$
    rts
    __endasm;
    /* clang-format on */
}

uint32_t fx_sqrt_u32_q8(uint32_t x) __naked
{
    x; /* referenced in the assembly */
    /* clang-format off */
    __asm
    clra
    sta     *___SDCC_hc08_ret3
    lda     3,s                 ; x == 0: 0
    ora     4,s
    ora     5,s
    ora     6,s
    bne     1$
    sta     *___SDCC_hc08_ret2
    clrx
    rts
1$:
    lda     3,s
    sta     *_fx_sq_x
    lda     4,s
    sta     *(_fx_sq_x + 1)
    lda     5,s
    sta     *(_fx_sq_x + 2)
    lda     6,s
    sta     *(_fx_sq_x + 3)
    clr     *___SDCC_hc08_ret2  ; k, until the end
    ; ---- normalise: x < 2^22: x <<= 8, k += 4; then x < 2^30: x <<= 2, k++
2$:
    lda     *_fx_sq_x
    bne     3$
    lda     *(_fx_sq_x + 1)
    cmp     #0x40
    bhs     3$
    sta     *_fx_sq_x
    lda     *(_fx_sq_x + 2)
    sta     *(_fx_sq_x + 1)
    lda     *(_fx_sq_x + 3)
    sta     *(_fx_sq_x + 2)
    clr     *(_fx_sq_x + 3)
    lda     *___SDCC_hc08_ret2
    add     #4
    sta     *___SDCC_hc08_ret2
    bra     2$
3$:
    lda     *_fx_sq_x
    cmp     #0x40
    bhs     4$
    lsl     *(_fx_sq_x + 3)
    rol     *(_fx_sq_x + 2)
    rol     *(_fx_sq_x + 1)
    rol     *_fx_sq_x
    lsl     *(_fx_sq_x + 3)
    rol     *(_fx_sq_x + 2)
    rol     *(_fx_sq_x + 1)
    rol     *_fx_sq_x
    inc     *___SDCC_hc08_ret2
    bra     3$
4$:
    jsr     fx_sq_core          ; T = 4 y, rem = r (< 2^17)
    ; y = T / 4 into fx_sq_t + 1 (high), + 2 (low)
    lsr     *_fx_sq_t
    ror     *(_fx_sq_t + 1)
    ror     *(_fx_sq_t + 2)
    lsr     *_fx_sq_t
    ror     *(_fx_sq_t + 1)
    ror     *(_fx_sq_t + 2)
    ; ---- numerator 256 r + y into fx_sq_x (4 bytes, <= 513 y < 2^26)
    lda     *(_fx_sq_t + 2)
    sta     *(_fx_sq_x + 3)
    lda     *(_fx_sq_r + 2)
    add     *(_fx_sq_t + 1)
    sta     *(_fx_sq_x + 2)
    lda     *(_fx_sq_r + 1)
    adc     #0
    sta     *(_fx_sq_x + 1)
    lda     *_fx_sq_r
    adc     #0
    sta     *_fx_sq_x
    ; ---- divisor (2 y + 1) * 256 in fx_sq_r (its top three bytes; the
    ; fourth is 0): 1, then 2y + 1 over the three bytes
    lda     *(_fx_sq_t + 2)
    lsla
    ora     #1
    sta     *(_fx_sq_r + 2)
    lda     *(_fx_sq_t + 1)
    rola
    sta     *(_fx_sq_r + 1)
    clra
    rola
    sta     *_fx_sq_r
    ; ---- q = floor(num / (2y + 1)) <= 256 (exact): the estimate
    ; qe = floor((num >> 9) / ((2y + 1) >> 9)) by DIV lies in [q - 1, q + 3]
    ; (the top byte of the divisor is in [128, 255]; qe = 255 when DIV
    ; overflows or num >= 2^25, q <= 256); then num - qe (2y + 1) is brought
    ; into [0, 2y + 1) a divisor at a time
    lda     #0xff               ; num >= 2^25 (up to 513 y): q = 256, qe = 255
    ldx     *_fx_sq_x
    cpx     #2
    bhs     5$
    lda     *(_fx_sq_r + 1)     ; (2y + 1) >> 9 = 0x80 | (byte 1 >> 1)
    lsra
    ora     #0x80
    tax
    lda     *_fx_sq_x           ; num >> 9 (< 2^16) into H:A
    lsra
    lda     *(_fx_sq_x + 1)
    rora
    psha
    pulh
    lda     *(_fx_sq_x + 1)
    lsra
    lda     *(_fx_sq_x + 2)
    rora
    div
    bcc     5$
    lda     #0xff
5$:
    sta     *_fx_sq_n           ; q (9 bits) in fx_sq_t (high), fx_sq_n (low)
    clr     *_fx_sq_t
    ais     #-4                 ; qe (2y + 1) at 1..4,s
    ldx     *(_fx_sq_r + 2)
    mul
    sta     4,s
    stx     3,s
    lda     *_fx_sq_n
    ldx     *(_fx_sq_r + 1)
    mul
    add     3,s
    sta     3,s
    txa
    adc     *_fx_sq_n           ; + qe * 2^16 (bit 16 of the divisor)
    sta     2,s
    clra
    rola
    sta     1,s
    lda     *(_fx_sq_x + 3)     ; num -= qe (2y + 1): the remainder, signed
    sub     4,s
    sta     *(_fx_sq_x + 3)
    lda     *(_fx_sq_x + 2)
    sbc     3,s
    sta     *(_fx_sq_x + 2)
    lda     *(_fx_sq_x + 1)
    sbc     2,s
    sta     *(_fx_sq_x + 1)
    lda     *_fx_sq_x
    sbc     1,s
    sta     *_fx_sq_x
    ais     #4
6$:
    lda     *_fx_sq_x           ; remainder < 0: + divisor, q - 1
    bpl     7$
    lda     *(_fx_sq_x + 3)
    add     *(_fx_sq_r + 2)
    sta     *(_fx_sq_x + 3)
    lda     *(_fx_sq_x + 2)
    adc     *(_fx_sq_r + 1)
    sta     *(_fx_sq_x + 2)
    lda     *(_fx_sq_x + 1)
    adc     *_fx_sq_r
    sta     *(_fx_sq_x + 1)
    lda     *_fx_sq_x
    adc     #0
    sta     *_fx_sq_x
    lda     *_fx_sq_n
    sub     #1
    sta     *_fx_sq_n
    lda     *_fx_sq_t
    sbc     #0
    sta     *_fx_sq_t
    bra     6$
7$:
    lda     *(_fx_sq_x + 3)     ; remainder >= divisor: - divisor, q + 1
    sub     *(_fx_sq_r + 2)
    psha
    lda     *(_fx_sq_x + 2)
    sbc     *(_fx_sq_r + 1)
    psha
    lda     *(_fx_sq_x + 1)
    sbc     *_fx_sq_r
    psha
    lda     *_fx_sq_x
    sbc     #0
    bcs     8$
    sta     *_fx_sq_x
    pula
    sta     *(_fx_sq_x + 1)
    pula
    sta     *(_fx_sq_x + 2)
    pula
    sta     *(_fx_sq_x + 3)
    inc     *_fx_sq_n
    bne     7$
    inc     *_fx_sq_t
    bra     7$
8$:
    ais     #3
9$:
    ; ---- s = 256 y + q (<= 2^24: 2^24 for x near 2^32) in fx_sq_x
    lda     *_fx_sq_n
    sta     *(_fx_sq_x + 3)
    lda     *(_fx_sq_t + 2)
    add     *_fx_sq_t           ; q bit 8
    sta     *(_fx_sq_x + 2)
    lda     *(_fx_sq_t + 1)
    adc     #0
    sta     *(_fx_sq_x + 1)
    clra
    rola
    sta     *_fx_sq_x
    ; ---- k == 0: s; else ((s >> (k - 1)) + 1) >> 1
    lda     *___SDCC_hc08_ret2
    beq     13$
    deca
    cmp     #8
    blo     10$
    sub     #8                  ; a whole byte
    psha
    lda     *(_fx_sq_x + 2)
    sta     *(_fx_sq_x + 3)
    lda     *(_fx_sq_x + 1)
    sta     *(_fx_sq_x + 2)
    lda     *_fx_sq_x
    sta     *(_fx_sq_x + 1)
    clr     *_fx_sq_x
    pula
10$:
    tsta
    beq     12$
11$:
    lsr     *_fx_sq_x
    ror     *(_fx_sq_x + 1)
    ror     *(_fx_sq_x + 2)
    ror     *(_fx_sq_x + 3)
    dbnza   11$
12$:
    inc     *(_fx_sq_x + 3)     ; + 1
    bne     14$
    inc     *(_fx_sq_x + 2)
    bne     14$
    inc     *(_fx_sq_x + 1)
    bne     14$
    inc     *_fx_sq_x
14$:
    lsr     *_fx_sq_x           ; >> 1
    ror     *(_fx_sq_x + 1)
    ror     *(_fx_sq_x + 2)
    ror     *(_fx_sq_x + 3)
13$:
    lda     *_fx_sq_x
    sta     *___SDCC_hc08_ret3
    lda     *(_fx_sq_x + 1)
    sta     *___SDCC_hc08_ret2
    lda     *(_fx_sq_x + 3)
    ldx     *(_fx_sq_x + 2)
    rts
    __endasm;
    /* clang-format on */
}
#pragma restore

#else

/* Other compilers use the portable functions of firmware/src/fx_math.c. */
typedef int fx_sqrt_s08_unused_t;

#endif
