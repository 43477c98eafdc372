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
 * (r <= 2y < 2^17 and T < 2^18 fit three bytes), about 95 bus cycles a step
 * instead of about 240 in SDCC's code for the 32-bit bitwise method.
 * fx_sqrt_u32_q8 then follows the C step for step: the same normalisation
 * x' = x * 4^k (whole bytes first), q = floor((256 r + y) / (2y + 1)) by the
 * same 9 restoring steps (the numerator shifted left instead of the divisor
 * right: the same quotient), s = 256 y + q and round(s / 2^k) half up,
 * computed as ((s >> (k - 1)) + 1) >> 1.
 *
 * Built only by SDCC for hc08/s08 with --stack-auto, the core compiled with
 * -DFX_PORT_SQRT (host/inclino/mcu.py).  Reentrant calling convention: x at
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
    lda     *_fx_sq_x
    bsr     fx_sq_byte
    lda     *(_fx_sq_x + 1)
    bsr     fx_sq_byte
    lda     *(_fx_sq_x + 2)
    bsr     fx_sq_byte
    lda     *(_fx_sq_x + 3)
    ; four steps on the bits of A, then return
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
    ; ---- numerator 256 r + y into fx_sq_x (4 bytes, < 2^25)
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
    ; ---- q = floor(num / (2y + 1)) <= 256: 9 restoring steps, the
    ; numerator shifted left a step (remainder < 2 divisor < 2^26)
    clr     *_fx_sq_t           ; q (9 bits) in fx_sq_t (high), fx_sq_n (low)
    clr     *_fx_sq_n
    ldx     #9
5$:
    lda     *_fx_sq_x           ; num >= divisor * 256 ?  (the low byte of
    cmp     *_fx_sq_r           ; the divisor is 0: three bytes decide)
    bhi     6$
    blo     7$
    lda     *(_fx_sq_x + 1)
    cmp     *(_fx_sq_r + 1)
    bhi     6$
    blo     7$
    lda     *(_fx_sq_x + 2)
    cmp     *(_fx_sq_r + 2)
    blo     7$
6$:
    lda     *(_fx_sq_x + 2)
    sub     *(_fx_sq_r + 2)
    sta     *(_fx_sq_x + 2)
    lda     *(_fx_sq_x + 1)
    sbc     *(_fx_sq_r + 1)
    sta     *(_fx_sq_x + 1)
    lda     *_fx_sq_x
    sbc     *_fx_sq_r
    sta     *_fx_sq_x
    sec
    bra     8$
7$:
    clc
8$:
    rol     *_fx_sq_n           ; q = 2 q + bit
    rol     *_fx_sq_t
    decx
    beq     9$
    lsl     *(_fx_sq_x + 3)     ; num <<= 1
    rol     *(_fx_sq_x + 2)
    rol     *(_fx_sq_x + 1)
    rol     *_fx_sq_x
    bra     5$
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
