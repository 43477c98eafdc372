/*
 * fx_div_s08.c - fx_div_frac_q20 for the S08/HC08 (the port's division).
 *
 * Same contract and the same result bits as the portable fx_div_frac_q20 in
 * firmware/src/fx_math.c (fx_math.h): round(num * 2^20 / den), half up, for
 * num < den; 2^20 when num >= den; 0 when den == 0.  The same 20 restoring
 * shift-and-subtract steps and the same rounding test (2 rem >= den), on
 * the operands in place on the stack: about 75 bus cycles a step instead of
 * about 200 in SDCC's code.  A step compares the remainder with den from the
 * top byte down (usually decided there) and subtracts only when it fits.
 *
 * Built only by SDCC for hc08/s08 with --stack-auto, the core compiled with
 * -DFX_PORT_DIV (host/inclino/mcu.py).  Reentrant calling convention: num at
 * 3..6,s and den at 7..10,s on entry (big-endian); the result in
 * ___SDCC_hc08_ret3, ___SDCC_hc08_ret2, X, A (most to least significant
 * byte).  No direct-page scratch: the remainder is num's own stack slot.
 */
#include <stdint.h>

#include "inclino/fx_math.h"

#if defined(__SDCC_s08) || defined(__SDCC_hc08)

#ifndef __SDCC_STACK_AUTO
#error "the S08 port's assembly expects the reentrant (--stack-auto) calling convention"
#endif

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
    clra                        ; q (3 bytes) and the step count
    psha                        ; q0 (bits 16..23)
    psha                        ; q1
    psha                        ; q2 (bits 0..7)
    lda     #20
    psha
    tsx                         ; 0,x count, 1,x q2, 2,x q1, 3,x q0,
                                ; rem (num) at 6..9,x, den at 10..13,x
3$:
    lsl     9,x                 ; rem <<= 1, the bit shifted out in C
    rol     8,x
    rol     7,x
    rol     6,x
    bcs     5$                  ; 33-bit remainder >= 2^32 > den
    lda     6,x                 ; rem >= den ?  (from the top byte)
    cmp     10,x
    bhi     5$
    blo     4$
    lda     7,x
    cmp     11,x
    bhi     5$
    blo     4$
    lda     8,x
    cmp     12,x
    bhi     5$
    blo     4$
    lda     9,x
    cmp     13,x
    bhs     5$
4$:
    clc                         ; quotient bit 0
    bra     6$
5$:
    lda     9,x                 ; rem -= den (modulo 2^32), quotient bit 1
    sub     13,x
    sta     9,x
    lda     8,x
    sbc     12,x
    sta     8,x
    lda     7,x
    sbc     11,x
    sta     7,x
    lda     6,x
    sbc     10,x
    sta     6,x
    sec
6$:
    rol     1,x                 ; q = 2 q + bit
    rol     2,x
    rol     3,x
    dbnz    0,x,3$
    ; round half up: q + 1 when 2 rem >= den
    lsl     9,x
    rol     8,x
    rol     7,x
    rol     6,x
    bcs     8$
    lda     6,x
    cmp     10,x
    bhi     8$
    blo     9$
    lda     7,x
    cmp     11,x
    bhi     8$
    blo     9$
    lda     8,x
    cmp     12,x
    bhi     8$
    blo     9$
    lda     9,x
    cmp     13,x
    blo     9$
8$:
    inc     1,x
    bne     9$
    inc     2,x
    bne     9$
    inc     3,x
9$:
    lda     3,x
    sta     *___SDCC_hc08_ret2
    lda     1,x
    ldx     2,x
    ais     #4
    rts
    __endasm;
    /* clang-format on */
}
#pragma restore

#else

/* Other compilers use the portable fx_div_frac_q20 of firmware/src/fx_math.c. */
typedef int fx_div_s08_unused_t;

#endif
