/*
 * fx_atan2_s08.c - fx_atan2_q16 for the S08/HC08 (the port's arctangent).
 *
 * Same contract and the same result bits as the portable fx_atan2_q16 in
 * firmware/src/fx_math.c (fx_math.h), step for step: 0 for x = y = 0; the
 * octant reduction to q = fx_div_frac_q20(min(|x|, |y|), max(|x|, |y|))
 * (the port's division, called); a = t[q >> 12] + ((d * f + 2^11) >> 12)
 * with f = q mod 2^12 and d = t[i + 1] - t[i] (< 2^14) when f != 0, the
 * product on unsigned bytes; then a = 90 deg - a if |y| > |x|, 180 deg - a
 * if x < 0, 360 deg - a if y < 0 (0 stays 0).  SDCC's code for the steps
 * around the division takes about 850 bus cycles a call, this about 250.
 *
 * Built only by SDCC for hc08/s08 with --stack-auto, the core compiled with
 * -DFX_PORT_ATAN2 (host/inclino/s08/toolchain.py).  Reentrant calling convention: y at
 * 3..6,s and x at 7..10,s on entry (big-endian); the result in
 * ___SDCC_hc08_ret3, ___SDCC_hc08_ret2, X, A (most to least significant
 * byte).  It keeps its work in eleven direct-page bytes of this module, so
 * it must not be called from an interrupt handler while the main program
 * may be in it.
 */
#include <stdint.h>

#include "inclino/fx_math.h"

#if defined(__SDCC_s08) || defined(__SDCC_hc08)

#ifndef __SDCC_STACK_AUTO
#error "the S08 port's assembly expects the reentrant (--stack-auto) calling convention"
#endif

/* direct-page work: |y| then the angle a, |x| then the product d * f (most
 * significant byte first), f (2 bytes), |y| > |x| */
static __data uint8_t fx_at_a[4];
static __data uint8_t fx_at_p[4];
static __data uint8_t fx_at_f[2];
static __data uint8_t fx_at_sw;

#pragma save
#pragma less_pedantic
int32_t fx_atan2_q16(int32_t y, int32_t x) __naked
{
    y, x; /* referenced in the assembly */
    /* clang-format off */
    __asm
    tsx                         ; y at 2..5,x, x at 6..9,x
    lda     2,x                 ; x == y == 0: 0
    ora     3,x
    ora     4,x
    ora     5,x
    ora     6,x
    ora     7,x
    ora     8,x
    ora     9,x
    bne     1$
    sta     *___SDCC_hc08_ret3
    sta     *___SDCC_hc08_ret2
    clrx
    rts
1$:
    ; ---- |y| into fx_at_a, |x| into fx_at_p
    lda     2,x
    bpl     2$
    clra
    sub     5,x
    sta     *(_fx_at_a + 3)
    clra
    sbc     4,x
    sta     *(_fx_at_a + 2)
    clra
    sbc     3,x
    sta     *(_fx_at_a + 1)
    clra
    sbc     2,x
    sta     *_fx_at_a
    bra     3$
2$:
    sta     *_fx_at_a
    lda     3,x
    sta     *(_fx_at_a + 1)
    lda     4,x
    sta     *(_fx_at_a + 2)
    lda     5,x
    sta     *(_fx_at_a + 3)
3$:
    lda     6,x
    bpl     4$
    clra
    sub     9,x
    sta     *(_fx_at_p + 3)
    clra
    sbc     8,x
    sta     *(_fx_at_p + 2)
    clra
    sbc     7,x
    sta     *(_fx_at_p + 1)
    clra
    sbc     6,x
    sta     *_fx_at_p
    bra     5$
4$:
    sta     *_fx_at_p
    lda     7,x
    sta     *(_fx_at_p + 1)
    lda     8,x
    sta     *(_fx_at_p + 2)
    lda     9,x
    sta     *(_fx_at_p + 3)
5$:
    ; ---- swap = |y| > |x|; push den = max, then num = min, and divide
    clr     *_fx_at_sw
    lda     *(_fx_at_p + 3)     ; |x| - |y|: a borrow when |y| > |x|
    sub     *(_fx_at_a + 3)
    lda     *(_fx_at_p + 2)
    sbc     *(_fx_at_a + 2)
    lda     *(_fx_at_p + 1)
    sbc     *(_fx_at_a + 1)
    lda     *_fx_at_p
    sbc     *_fx_at_a
    bcc     6$
    inc     *_fx_at_sw
    lda     *(_fx_at_a + 3)     ; den = |y|, num = |x|
    psha
    lda     *(_fx_at_a + 2)
    psha
    lda     *(_fx_at_a + 1)
    psha
    lda     *_fx_at_a
    psha
    lda     *(_fx_at_p + 3)
    psha
    lda     *(_fx_at_p + 2)
    psha
    lda     *(_fx_at_p + 1)
    psha
    lda     *_fx_at_p
    psha
    bra     7$
6$:
    lda     *(_fx_at_p + 3)     ; den = |x|, num = |y|
    psha
    lda     *(_fx_at_p + 2)
    psha
    lda     *(_fx_at_p + 1)
    psha
    lda     *_fx_at_p
    psha
    lda     *(_fx_at_a + 3)
    psha
    lda     *(_fx_at_a + 2)
    psha
    lda     *(_fx_at_a + 1)
    psha
    lda     *_fx_at_a
    psha
7$:
    jsr     _fx_div_frac_q20    ; q in ret2 (bits 16..23), X, A; <= 2^20
    ais     #8
    ; ---- f = q mod 2^12; H:X = 4 * (q >> 12), the table offset
    sta     *(_fx_at_f + 1)
    txa
    and     #0x0f
    sta     *_fx_at_f
    txa
    lsr     *___SDCC_hc08_ret2
    rora
    lsr     *___SDCC_hc08_ret2
    rora
    and     #0xfc
    tax
    lda     *___SDCC_hc08_ret2
    psha
    pulh
    lda     _fx_atan_table,x    ; a = t[i]
    sta     *_fx_at_a
    lda     (_fx_atan_table + 1),x
    sta     *(_fx_at_a + 1)
    lda     (_fx_atan_table + 2),x
    sta     *(_fx_at_a + 2)
    lda     (_fx_atan_table + 3),x
    sta     *(_fx_at_a + 3)
    lda     *_fx_at_f           ; f == 0: t[i] alone
    ora     *(_fx_at_f + 1)
    beq     8$
    ; ---- d = t[i + 1] - t[i] (its low 16 bits: 0 < d < 2^14) into ret2:ret3
    lda     (_fx_atan_table + 7),x
    sub     (_fx_atan_table + 3),x
    sta     *___SDCC_hc08_ret2  ; d low
    lda     (_fx_atan_table + 6),x
    sbc     (_fx_atan_table + 2),x
    sta     *___SDCC_hc08_ret3  ; d high
    ; ---- p = d * f (< 2^26) in fx_at_p
    lda     *___SDCC_hc08_ret2  ; dl * fl
    ldx     *(_fx_at_f + 1)
    mul
    sta     *(_fx_at_p + 3)
    stx     *(_fx_at_p + 2)
    lda     *___SDCC_hc08_ret3  ; dh * fh
    ldx     *_fx_at_f
    mul
    sta     *(_fx_at_p + 1)
    stx     *_fx_at_p
    lda     *___SDCC_hc08_ret3  ; dh * fl, at byte 2
    ldx     *(_fx_at_f + 1)
    mul
    add     *(_fx_at_p + 2)
    sta     *(_fx_at_p + 2)
    txa
    adc     *(_fx_at_p + 1)
    sta     *(_fx_at_p + 1)
    bcc     9$
    inc     *_fx_at_p
9$:
    lda     *___SDCC_hc08_ret2  ; dl * fh, at byte 2
    ldx     *_fx_at_f
    mul
    add     *(_fx_at_p + 2)
    sta     *(_fx_at_p + 2)
    txa
    adc     *(_fx_at_p + 1)
    sta     *(_fx_at_p + 1)
    bcc     10$
    inc     *_fx_at_p
10$:
    ; ---- a += (p + 2^11) >> 12 (< 2^14): bits 12..27 of p + 2^11
    lda     *(_fx_at_p + 2)
    add     #0x08
    sta     *(_fx_at_p + 2)
    lda     *(_fx_at_p + 1)
    adc     #0
    sta     *(_fx_at_p + 1)
    lda     *_fx_at_p
    adc     #0
    ldx     #4
11$:
    lsra
    ror     *(_fx_at_p + 1)
    ror     *(_fx_at_p + 2)
    dbnzx   11$
    lda     *(_fx_at_a + 3)
    add     *(_fx_at_p + 2)
    sta     *(_fx_at_a + 3)
    lda     *(_fx_at_a + 2)
    adc     *(_fx_at_p + 1)
    sta     *(_fx_at_a + 2)
    bcc     8$
    inc     *(_fx_at_a + 1)
    bne     8$
    inc     *_fx_at_a
8$:
    ; ---- unfold the octant
    tst     *_fx_at_sw          ; |y| > |x|: a = 90 deg - a
    beq     12$
    clra
    sub     *(_fx_at_a + 3)
    sta     *(_fx_at_a + 3)
    clra
    sbc     *(_fx_at_a + 2)
    sta     *(_fx_at_a + 2)
    lda     #0x5a
    sbc     *(_fx_at_a + 1)
    sta     *(_fx_at_a + 1)
    clra
    sbc     *_fx_at_a
    sta     *_fx_at_a
12$:
    lda     7,s                 ; x < 0: a = 180 deg - a
    bpl     13$
    clra
    sub     *(_fx_at_a + 3)
    sta     *(_fx_at_a + 3)
    clra
    sbc     *(_fx_at_a + 2)
    sta     *(_fx_at_a + 2)
    lda     #0xb4
    sbc     *(_fx_at_a + 1)
    sta     *(_fx_at_a + 1)
    clra
    sbc     *_fx_at_a
    sta     *_fx_at_a
13$:
    lda     3,s                 ; y < 0: a = 360 deg - a, 0 stays 0
    bpl     14$
    lda     *_fx_at_a
    ora     *(_fx_at_a + 1)
    ora     *(_fx_at_a + 2)
    ora     *(_fx_at_a + 3)
    beq     14$
    clra
    sub     *(_fx_at_a + 3)
    sta     *(_fx_at_a + 3)
    clra
    sbc     *(_fx_at_a + 2)
    sta     *(_fx_at_a + 2)
    lda     #0x68
    sbc     *(_fx_at_a + 1)
    sta     *(_fx_at_a + 1)
    lda     #0x01
    sbc     *_fx_at_a
    sta     *_fx_at_a
14$:
    lda     *_fx_at_a
    sta     *___SDCC_hc08_ret3
    lda     *(_fx_at_a + 1)
    sta     *___SDCC_hc08_ret2
    lda     *(_fx_at_a + 3)
    ldx     *(_fx_at_a + 2)
    rts
    __endasm;
    /* clang-format on */
}
#pragma restore

#else

/* Other compilers use the portable fx_atan2_q16 of firmware/src/fx_math.c. */
typedef int fx_atan2_s08_unused_t;

#endif
