/*
 * fx_mul32_s08.c - fx_mul32_q31 for the S08/HC08 (the port's 32-bit product).
 *
 * Same contract and the same result bits as the portable fx_mul32_q31 in
 * firmware/src/fx_ops.c (fx_ops.h): with ah = floor(a / 2^16),
 * al = (a mod 2^16) >> 1 and likewise bh, bl,
 *   s = ah*bh + floor(ah*bl / 2^15) + floor(al*bh / 2^15),
 * the result is 2*s, or FX_INT32_MAX / FX_INT32_MIN with *sat = 1 when s is
 * outside [-2^30, 2^30 - 1].  The portable C makes three fx_mul16 calls and
 * splits and floors 32-bit values in SDCC's code (about 1 300 bus cycles on
 * the S08); this is twelve 8 x 8 MULs on unsigned bytes, about 450 cycles.
 *
 * Method (all unsigned, modulo 2^32; s fits 32 bits, so its bits are exact):
 * with ah_u, bh_u the unsigned readings of ah, bh (ah = ah_u - 2^16 [a < 0]),
 *   floor(ah*bl / 2^15) = floor(ah_u * (b mod 2^16 & ~1) / 2^16) - 2 bl [a < 0]
 *   (the subtracted 2^16 bl is a whole multiple of 2^15), likewise for al*bh,
 *   ah*bh = ah_u*bh_u - 2^16 (bh_u [a < 0] + ah_u [b < 0])  (mod 2^32), so
 *   s = ah_u*bh_u + FX + FY - [a < 0] (b & ~1) - [b < 0] (a & ~1)  (mod 2^32)
 * with FX = floor(ah_u * (b mod 2^16 & ~1) / 2^16) and FY likewise (each
 * < 2^16).  s saturates when its bits 31 and 30 differ.
 *
 * Built only by SDCC for hc08/s08 with --stack-auto, the core compiled with
 * -DFX_PORT_MUL32 (host/inclino/mcu.py).  Reentrant calling convention: a at
 * 3..6,s, b at 7..10,s (big-endian), sat at 11..12,s; the result in
 * ___SDCC_hc08_ret3, ___SDCC_hc08_ret2, X, A (most to least significant
 * byte).  It keeps its partial sums in three direct-page bytes of its own
 * and in the return registers, so, like those, it must not be called from
 * an interrupt handler while the main program may be in it.
 */
#include <stdint.h>

#include "inclino/fx_ops.h"

#if defined(__SDCC_s08) || defined(__SDCC_hc08)

#ifndef __SDCC_STACK_AUTO
#error "the S08 port's assembly expects the reentrant (--stack-auto) calling convention"
#endif

/* direct-page scratch: w[0] the fraction byte, w[1..2] FX, later FY */
static __data uint8_t fx_mul32_w[4];

#pragma save
#pragma less_pedantic
int32_t fx_mul32_q31(int32_t a, int32_t b, uint8_t *sat) __naked
{
    a, b, sat; /* referenced in the assembly */
    /* clang-format off */
    __asm
    ; ---- s = ah_u * bh_u into ret3 ret2 w+2 w+3 (s0 s1 s2 s3)
    lda     4,s                 ; A1
    ldx     8,s                 ; B1
    mul
    sta     *(_fx_mul32_w + 3)
    stx     *(_fx_mul32_w + 2)
    lda     3,s                 ; A0
    ldx     7,s                 ; B0
    mul
    sta     *___SDCC_hc08_ret2
    stx     *___SDCC_hc08_ret3
    lda     3,s                 ; A0 * B1, at byte 2
    ldx     8,s
    mul
    add     *(_fx_mul32_w + 2)
    sta     *(_fx_mul32_w + 2)
    txa
    adc     *___SDCC_hc08_ret2
    sta     *___SDCC_hc08_ret2
    bcc     1$
    inc     *___SDCC_hc08_ret3
1$:
    lda     4,s                 ; A1 * B0, at byte 2
    ldx     7,s
    mul
    add     *(_fx_mul32_w + 2)
    sta     *(_fx_mul32_w + 2)
    txa
    adc     *___SDCC_hc08_ret2
    sta     *___SDCC_hc08_ret2
    bcc     2$
    inc     *___SDCC_hc08_ret3
2$:
    ; ---- FX = floor((A0:A1) * (B2:B3e) / 2^16), B3e = B3 & 0xfe; f = w+0
    lda     10,s
    and     #0xfe
    ldx     4,s                 ; A1 * B3e: only its high byte counts
    mul
    stx     *_fx_mul32_w
    lda     10,s
    and     #0xfe
    ldx     3,s                 ; A0 * B3e, at the fraction byte
    mul
    add     *_fx_mul32_w
    sta     *_fx_mul32_w
    txa
    adc     #0                  ; a high byte is at most 0xfe: no carry out
    psha                        ; FX low byte, 1,s (the offsets above shift by 1)
    lda     5,s                 ; A1 * B2, at the fraction byte
    ldx     10,s
    mul
    add     *_fx_mul32_w        ; only the carry counts now
    txa
    adc     1,s
    sta     1,s
    clra
    rola
    psha                        ; FX high byte, 1,s; FX low 2,s (offsets +2)
    lda     5,s                 ; A0 * B2, whole
    ldx     11,s
    mul
    add     2,s
    sta     2,s
    txa
    adc     1,s
    sta     1,s                 ; FX < 2^16: no carry out
    ; ---- s += FX
    lda     *(_fx_mul32_w + 3)
    add     2,s
    sta     *(_fx_mul32_w + 3)
    lda     *(_fx_mul32_w + 2)
    adc     1,s
    sta     *(_fx_mul32_w + 2)
    bcc     3$
    inc     *___SDCC_hc08_ret2
    bne     3$
    inc     *___SDCC_hc08_ret3
3$:
    ; ---- FY = floor((A2:A3e) * (B0:B1) / 2^16), A3e = A3 & 0xfe (offsets +2)
    lda     8,s
    and     #0xfe
    ldx     10,s                ; A3e * B1: only its high byte counts
    mul
    stx     *_fx_mul32_w
    lda     8,s
    and     #0xfe
    ldx     9,s                 ; A3e * B0, at the fraction byte
    mul
    add     *_fx_mul32_w
    sta     *_fx_mul32_w
    txa
    adc     #0
    sta     2,s                 ; FY low byte
    lda     7,s                 ; A2 * B1, at the fraction byte
    ldx     10,s
    mul
    add     *_fx_mul32_w
    txa
    adc     2,s
    sta     2,s
    clra
    rola
    sta     1,s                 ; FY high byte
    lda     7,s                 ; A2 * B0, whole
    ldx     9,s
    mul
    add     2,s
    sta     2,s
    txa
    adc     1,s
    sta     1,s
    ; ---- s += FY
    lda     *(_fx_mul32_w + 3)
    add     2,s
    sta     *(_fx_mul32_w + 3)
    lda     *(_fx_mul32_w + 2)
    adc     1,s
    sta     *(_fx_mul32_w + 2)
    bcc     4$
    inc     *___SDCC_hc08_ret2
    bne     4$
    inc     *___SDCC_hc08_ret3
4$:
    ais     #2                  ; offsets back to those of the entry
    ; ---- a < 0: s -= b & ~1
    lda     3,s
    bpl     5$
    lda     10,s
    and     #0xfe
    psha
    lda     *(_fx_mul32_w + 3)
    sub     1,s
    sta     *(_fx_mul32_w + 3)
    pula
    lda     *(_fx_mul32_w + 2)
    sbc     9,s
    sta     *(_fx_mul32_w + 2)
    lda     *___SDCC_hc08_ret2
    sbc     8,s
    sta     *___SDCC_hc08_ret2
    lda     *___SDCC_hc08_ret3
    sbc     7,s
    sta     *___SDCC_hc08_ret3
5$:
    ; ---- b < 0: s -= a & ~1
    lda     7,s
    bpl     6$
    lda     6,s
    and     #0xfe
    psha
    lda     *(_fx_mul32_w + 3)
    sub     1,s
    sta     *(_fx_mul32_w + 3)
    pula
    lda     *(_fx_mul32_w + 2)
    sbc     5,s
    sta     *(_fx_mul32_w + 2)
    lda     *___SDCC_hc08_ret2
    sbc     4,s
    sta     *___SDCC_hc08_ret2
    lda     *___SDCC_hc08_ret3
    sbc     3,s
    sta     *___SDCC_hc08_ret3
6$:
    ; ---- s outside [-2^30, 2^30): bits 31 and 30 differ, that is
    ; bit 7 of (top byte + 0x40) is set
    lda     *___SDCC_hc08_ret3
    add     #0x40
    bmi     7$
    lsl     *(_fx_mul32_w + 3)  ; result 2*s
    rol     *(_fx_mul32_w + 2)
    rol     *___SDCC_hc08_ret2
    rol     *___SDCC_hc08_ret3
    lda     *(_fx_mul32_w + 3)
    ldx     *(_fx_mul32_w + 2)
    rts
7$:
    ldhx    11,s                ; *sat = 1
    lda     #1
    sta     ,x
    lda     *___SDCC_hc08_ret3
    bmi     8$
    lda     #0x7f               ; FX_INT32_MAX
    sta     *___SDCC_hc08_ret3
    lda     #0xff
    sta     *___SDCC_hc08_ret2
    tax
    rts
8$:
    lda     #0x80               ; FX_INT32_MIN
    sta     *___SDCC_hc08_ret3
    clra
    sta     *___SDCC_hc08_ret2
    tax
    rts
    __endasm;
    /* clang-format on */
}
#pragma restore

#else

/* Other compilers use the portable fx_mul32_q31 of firmware/src/fx_ops.c. */
typedef int fx_mul32_s08_unused_t;

#endif
