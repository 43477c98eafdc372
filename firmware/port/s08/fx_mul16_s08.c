/*
 * fx_mul16_s08.c - fx_mul16 for the S08/HC08 (the port's multiply helper).
 *
 * Same contract as the portable fx_mul16 in firmware/src/fx_ops.c (fx_ops.h):
 * the exact signed product a * b of two int16, as an int32.  The S08 has
 * only an 8 x 8 -> 16 unsigned MUL, and SDCC compiles the portable
 * `(int32_t)a * (int32_t)b` into a call of its 32 x 32 helper __mullong
 * (about 600 bus cycles); this is four MULs and the two sign corrections,
 * about 90 cycles with the call.  The HCS12X port maps fx_mul16 to EMULS.
 *
 * Built only by SDCC for hc08/s08 with --stack-auto, the core compiled with
 * -DFX_PORT_MUL16 (host/inclino/s08/toolchain.py).  SDCC's reentrant calling
 * convention: a in X (high byte) and A (low byte), b on the stack at 3..4,s
 * on entry, 7..8,s after the four bytes this function pushes (big-endian);
 * the result in ___SDCC_hc08_ret3, ___SDCC_hc08_ret2, X, A (most to least
 * significant byte).
 *
 * Method: with a = ah*256 + al and b = bh*256 + bl read as unsigned,
 *   p = al*bl + (ah*bl + al*bh)*256 + ah*bh*65536  (mod 2^32)
 * then subtract b*65536 if a < 0 and a*65536 if b < 0 (two's complement).
 */
#include <stdint.h>

#include "inclino/fx_ops.h"

#if defined(__SDCC_s08) || defined(__SDCC_hc08)

#ifndef __SDCC_STACK_AUTO
#error "the S08 port's assembly expects the reentrant (--stack-auto) calling convention"
#endif

#pragma save
#pragma less_pedantic
int32_t fx_mul16(int16_t a, int16_t b) __naked
{
    a, b; /* referenced in the assembly */
    /* clang-format off */
    __asm
    psha                        ; 4,s = al (after the next three pushes)
    pshx                        ; 3,s = ah
    ais     #-2                 ; 1,s = p1, 2,s = p0
    ldx     8,s
    lda     4,s
    mul                         ; al*bl
    sta     2,s
    stx     1,s
    ldx     7,s
    lda     3,s
    mul                         ; ah*bh
    sta     *___SDCC_hc08_ret2
    stx     *___SDCC_hc08_ret3
    ldx     8,s
    lda     3,s
    mul                         ; ah*bl, at byte 1
    add     1,s
    sta     1,s
    txa
    adc     *___SDCC_hc08_ret2
    sta     *___SDCC_hc08_ret2
    bcc     1$
    inc     *___SDCC_hc08_ret3
1$:
    ldx     7,s
    lda     4,s
    mul                         ; al*bh, at byte 1
    add     1,s
    sta     1,s
    txa
    adc     *___SDCC_hc08_ret2
    sta     *___SDCC_hc08_ret2
    bcc     2$
    inc     *___SDCC_hc08_ret3
2$:
    tst     3,s                 ; a < 0: subtract b * 65536
    bpl     3$
    lda     *___SDCC_hc08_ret2
    sub     8,s
    sta     *___SDCC_hc08_ret2
    lda     *___SDCC_hc08_ret3
    sbc     7,s
    sta     *___SDCC_hc08_ret3
3$:
    lda     7,s                 ; b < 0: subtract a * 65536
    bpl     4$
    lda     *___SDCC_hc08_ret2
    sub     4,s
    sta     *___SDCC_hc08_ret2
    lda     *___SDCC_hc08_ret3
    sbc     3,s
    sta     *___SDCC_hc08_ret3
4$:
    pulx                        ; p1
    pula                        ; p0
    ais     #2
    rts
    __endasm;
    /* clang-format on */
}
#pragma restore

#else

/* Other compilers use the portable fx_mul16 of firmware/src/fx_ops.c. */
typedef int fx_mul16_s08_unused_t;

#endif
