/*
 * fx_div_s08.c - fx_div_frac_q20 for the S08/HC08 (the port's division).
 *
 * Same contract and the same result bits as the portable fx_div_frac_q20 in
 * firmware/src/fx_math.c (fx_math.h): round(num * 2^20 / den), half up, for
 * num < den; 2^20 when num >= den; 0 when den == 0.  The C takes 20
 * restoring shift-and-subtract steps and rounds on the remainder (about
 * 4 000 bus cycles in SDCC's code).  Here, with den and num shifted left
 * together until den >= 2^31 (the same ratio), Q24 = floor(num 2^24 / den)
 * comes as three base-256 digits, each estimated with the S08's 16 / 8 DIV
 * from the top bytes and corrected (at most twice; Knuth, TAOCP vol. 2,
 * 4.3.1, algorithm D), about 600 cycles in all.  The result is the same
 * exact rounding: round half up of num 2^20 / den = floor((floor(num 2^21 /
 * den) + 1) / 2) = (Q24 + 8) >> 4.
 *
 * Built only by SDCC for hc08/s08 with --stack-auto, the core compiled with
 * -DFX_PORT_DIV (host/inclino/s08/toolchain.py).  Reentrant calling convention: num at
 * 3..6,s and den at 7..10,s on entry (big-endian); the result in
 * ___SDCC_hc08_ret3, ___SDCC_hc08_ret2, X, A (most to least significant
 * byte).  It keeps its work in nineteen direct-page bytes of this module,
 * so it must not be called from an interrupt handler while the main program
 * may be in it.
 */
#include <stdint.h>

#include "inclino/fx_math.h"

#if defined(__SDCC_s08) || defined(__SDCC_hc08)

#ifndef __SDCC_STACK_AUTO
#error "the S08 port's assembly expects the reentrant (--stack-auto) calling convention"
#endif

/* direct-page work: D (den normalised), the partial remainder / dividend
 * window (5 bytes), a product (5 bytes), the three quotient digits and the
 * current digit estimate, the digit count */
static __data uint8_t fx_dv_d[4];
static __data uint8_t fx_dv_w[5];
static __data uint8_t fx_dv_p[5];
static __data uint8_t fx_dv_q[3];
static __data uint8_t fx_dv_e;
static __data uint8_t fx_dv_k;

#pragma save
#pragma less_pedantic
uint32_t fx_div_frac_q20(uint32_t num, uint32_t den) __naked
{
    num, den; /* referenced in the assembly */
    /* clang-format off */
    __asm
    clra
    sta     *___SDCC_hc08_ret3
    tsx                         ; num at 2..5,x, den at 6..9,x
    lda     6,x                 ; den == 0: 0
    ora     7,x
    ora     8,x
    ora     9,x
    bne     1$
    clrx
    sta     *___SDCC_hc08_ret2
    rts
1$:
    lda     5,x                 ; num >= den: 2^20
    sub     9,x
    lda     4,x
    sbc     8,x
    lda     3,x
    sbc     7,x
    lda     2,x
    sbc     6,x
    bcs     2$
    lda     #0x10
    sta     *___SDCC_hc08_ret2
    clra
    clrx
    rts
2$:
    ; ---- D = den, w = num, shifted left together until D >= 2^31 (the
    ; ratio is unchanged; num < den keeps w < D)
    lda     6,x
    sta     *_fx_dv_d
    lda     7,x
    sta     *(_fx_dv_d + 1)
    lda     8,x
    sta     *(_fx_dv_d + 2)
    lda     9,x
    sta     *(_fx_dv_d + 3)
    lda     2,x
    sta     *_fx_dv_w
    lda     3,x
    sta     *(_fx_dv_w + 1)
    lda     4,x
    sta     *(_fx_dv_w + 2)
    lda     5,x
    sta     *(_fx_dv_w + 3)
3$:
    lda     *_fx_dv_d           ; whole bytes (den > 0: at most three)
    bne     4$
    lda     *(_fx_dv_d + 1)
    sta     *_fx_dv_d
    lda     *(_fx_dv_d + 2)
    sta     *(_fx_dv_d + 1)
    lda     *(_fx_dv_d + 3)
    sta     *(_fx_dv_d + 2)
    clr     *(_fx_dv_d + 3)
    lda     *(_fx_dv_w + 1)
    sta     *_fx_dv_w
    lda     *(_fx_dv_w + 2)
    sta     *(_fx_dv_w + 1)
    lda     *(_fx_dv_w + 3)
    sta     *(_fx_dv_w + 2)
    clr     *(_fx_dv_w + 3)
    bra     3$
4$:
    tsta                        ; then bits
    bmi     5$
    lsl     *(_fx_dv_d + 3)
    rol     *(_fx_dv_d + 2)
    rol     *(_fx_dv_d + 1)
    rol     *_fx_dv_d
    lsl     *(_fx_dv_w + 3)
    rol     *(_fx_dv_w + 2)
    rol     *(_fx_dv_w + 1)
    rol     *_fx_dv_w
    lda     *_fx_dv_d
    bra     4$
5$:
    ; ---- Q24 = floor(w * 2^24 / D): three base-256 digits.  A digit:
    ; U = 256 R (5 bytes, w), qe = min(floor((U0 * 256 + U1) / D0), 255) by
    ; DIV, U - qe D, then + D while negative: with D0 >= 128, qe - 2 <= digit
    ; <= qe (Knuth, TAOCP 4.3.1, theorem B)
    clr     *(_fx_dv_w + 4)
    clr     *_fx_dv_k
6$:
    lda     #0xff
    ldx     *_fx_dv_d
    cpx     *_fx_dv_w           ; U0 >= D0: 255 (U0 <= D0 as R < D)
    bls     7$
    lda     *_fx_dv_w
    psha
    pulh
    lda     *(_fx_dv_w + 1)
    div
7$:
    sta     *_fx_dv_e           ; qe
    ldx     *(_fx_dv_d + 3)     ; P = qe D (5 bytes)
    mul
    sta     *(_fx_dv_p + 4)
    stx     *(_fx_dv_p + 3)
    lda     *_fx_dv_e
    ldx     *(_fx_dv_d + 2)
    mul
    add     *(_fx_dv_p + 3)
    sta     *(_fx_dv_p + 3)
    txa
    adc     #0
    sta     *(_fx_dv_p + 2)
    lda     *_fx_dv_e
    ldx     *(_fx_dv_d + 1)
    mul
    add     *(_fx_dv_p + 2)
    sta     *(_fx_dv_p + 2)
    txa
    adc     #0
    sta     *(_fx_dv_p + 1)
    lda     *_fx_dv_e
    ldx     *_fx_dv_d
    mul
    add     *(_fx_dv_p + 1)
    sta     *(_fx_dv_p + 1)
    txa
    adc     #0
    sta     *_fx_dv_p
    lda     *(_fx_dv_w + 4)     ; U -= P
    sub     *(_fx_dv_p + 4)
    sta     *(_fx_dv_w + 4)
    lda     *(_fx_dv_w + 3)
    sbc     *(_fx_dv_p + 3)
    sta     *(_fx_dv_w + 3)
    lda     *(_fx_dv_w + 2)
    sbc     *(_fx_dv_p + 2)
    sta     *(_fx_dv_w + 2)
    lda     *(_fx_dv_w + 1)
    sbc     *(_fx_dv_p + 1)
    sta     *(_fx_dv_w + 1)
    lda     *_fx_dv_w
    sbc     *_fx_dv_p
    sta     *_fx_dv_w
8$:
    bpl     9$                  ; negative: U += D, qe - 1
    lda     *(_fx_dv_w + 4)
    add     *(_fx_dv_d + 3)
    sta     *(_fx_dv_w + 4)
    lda     *(_fx_dv_w + 3)
    adc     *(_fx_dv_d + 2)
    sta     *(_fx_dv_w + 3)
    lda     *(_fx_dv_w + 2)
    adc     *(_fx_dv_d + 1)
    sta     *(_fx_dv_w + 2)
    lda     *(_fx_dv_w + 1)
    adc     *_fx_dv_d
    sta     *(_fx_dv_w + 1)
    lda     *_fx_dv_w
    adc     #0
    sta     *_fx_dv_w
    dec     *_fx_dv_e
    tsta
    bra     8$
9$:
    clrh                        ; the digit; R = w1..w4 < D becomes U / 256
    ldx     *_fx_dv_k
    lda     *_fx_dv_e
    sta     _fx_dv_q,x
    lda     *(_fx_dv_w + 1)
    sta     *_fx_dv_w
    lda     *(_fx_dv_w + 2)
    sta     *(_fx_dv_w + 1)
    lda     *(_fx_dv_w + 3)
    sta     *(_fx_dv_w + 2)
    lda     *(_fx_dv_w + 4)
    sta     *(_fx_dv_w + 3)
    clr     *(_fx_dv_w + 4)
    inc     *_fx_dv_k
    lda     *_fx_dv_k
    cmp     #3
    beq     11$
    jmp     6$
11$:
    ; ---- q = round(num 2^20 / den) = (Q24 + 8) >> 4 (the remainder-based
    ; rounding of the C: floor((floor(Q24 / 8) + 1) / 2) is the same)
    lda     *(_fx_dv_q + 2)
    add     #8
    sta     *(_fx_dv_q + 2)
    lda     *(_fx_dv_q + 1)
    adc     #0
    sta     *(_fx_dv_q + 1)
    lda     *_fx_dv_q
    adc     #0
    sta     *_fx_dv_q
    ror     *_fx_dv_q           ; the carry out (Q24 + 8 >= 2^24) comes in
    ror     *(_fx_dv_q + 1)
    ror     *(_fx_dv_q + 2)
    ldx     #3
10$:
    lsr     *_fx_dv_q
    ror     *(_fx_dv_q + 1)
    ror     *(_fx_dv_q + 2)
    dbnzx   10$
    lda     *_fx_dv_q
    sta     *___SDCC_hc08_ret2
    lda     *(_fx_dv_q + 2)
    ldx     *(_fx_dv_q + 1)
    rts
    __endasm;
    /* clang-format on */
}
#pragma restore

#else

/* Other compilers use the portable fx_div_frac_q20 of firmware/src/fx_math.c. */
typedef int fx_div_s08_unused_t;

#endif
