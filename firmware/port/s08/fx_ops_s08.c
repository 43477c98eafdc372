/*
 * fx_ops_s08.c - fx_asr32, fx_asr32_rnd, fx_add32_sat and fx_sub32_sat for
 * the S08/HC08 (the port's shifts and saturating sums).
 *
 * Same contracts and the same result bits as the portable functions in
 * firmware/src/fx_ops.c (fx_ops.h):
 *   fx_asr32      floor(x / 2^n): an arithmetic shift, whole bytes first;
 *   fx_asr32_rnd  x for n = 0, else floor(x / 2^(n-1)) shifted once more,
 *                 plus the bit shifted out (round half up);
 *   fx_add32_sat, fx_sub32_sat  the two's complement sum or difference;
 *                 on signed overflow *sat = 1 and the limit on the side of
 *                 b (add) or of -b (sub), as the C's range tests give.
 * SDCC's code for these takes 150 to 400 bus cycles a call (a variable
 * 32-bit shift is a loop of 1-bit shifts); these take 40 to 120.
 *
 * Built only by SDCC for hc08/s08 with --stack-auto, the core compiled with
 * -DFX_PORT_OPS (host/inclino/s08/toolchain.py).  Reentrant calling convention: x or
 * a at 3..6,s, n at 7,s or b at 7..10,s and sat at 11..12,s on entry
 * (big-endian); the result in ___SDCC_hc08_ret3, ___SDCC_hc08_ret2, X, A
 * (most to least significant byte).  They work on their own argument slots
 * on the stack and use no other memory.
 */
#include <stdint.h>

#include "inclino/fx_ops.h"

#if defined(__SDCC_s08) || defined(__SDCC_hc08)

#ifndef __SDCC_STACK_AUTO
#error "the S08 port's assembly expects the reentrant (--stack-auto) calling convention"
#endif

#pragma save
#pragma less_pedantic
int32_t fx_asr32(int32_t x, uint8_t n) __naked
{
    x, n; /* referenced in the assembly */
    /* clang-format off */
    __asm
    tsx                         ; x at 2..5,x, n at 6,x
    lda     6,x
    bsr     fx_o_asr
fx_o_ret:
    lda     2,x                 ; return the int32 at 2..5,x
    sta     *___SDCC_hc08_ret3
    lda     3,x
    sta     *___SDCC_hc08_ret2
    lda     5,x
    ldx     4,x
    rts

    ; ---- shift the int32 at 2..5,x right by A bits, arithmetic; keeps H:X
fx_o_asr:
    cmp     #8
    blo     2$
1$:
    psha                        ; a whole byte: sign fill
    lda     4,x
    sta     5,x
    lda     3,x
    sta     4,x
    lda     2,x
    sta     3,x
    lsla                        ; C = the sign
    clra
    sbc     #0                  ; 0x00 or 0xff
    sta     2,x
    pula
    sub     #8
    cmp     #8
    bhs     1$
2$:
    tsta
    beq     4$
3$:
    asr     2,x
    ror     3,x
    ror     4,x
    ror     5,x
    dbnza   3$
4$:
    rts
    __endasm;
    /* clang-format on */
}

int32_t fx_asr32_rnd(int32_t x, uint8_t n) __naked
{
    x, n; /* referenced in the assembly */
    /* clang-format off */
    __asm
    tsx                         ; x at 2..5,x, n at 6,x
    lda     6,x
    beq     1$                  ; n == 0: x
    deca
    jsr     fx_o_asr            ; floor(x / 2^(n-1))
    asr     2,x                 ; once more: C = bit n-1 of x
    ror     3,x
    ror     4,x
    ror     5,x
    lda     5,x                 ; + that bit (q <= FX_INT32_MAX / 2: no overflow)
    adc     #0
    sta     5,x
    lda     4,x
    adc     #0
    sta     4,x
    lda     3,x
    adc     #0
    sta     3,x
    lda     2,x
    adc     #0
    sta     2,x
1$:
    jmp     fx_o_ret
    __endasm;
    /* clang-format on */
}

int32_t fx_add32_sat(int32_t a, int32_t b, uint8_t *sat) __naked
{
    a, b, sat; /* referenced in the assembly */
    /* clang-format off */
    __asm
    tsx                         ; a at 2..5,x, b at 6..9,x, sat at 10..11,x
    lda     5,x
    add     9,x
    sta     5,x
    lda     4,x
    adc     8,x
    sta     4,x
    lda     3,x
    adc     7,x
    sta     3,x
    lda     2,x
    adc     6,x
    psha
    tpa                         ; V (bit 7 of the CCR): signed overflow
    sta     *___SDCC_hc08_ret2
    pula
    sta     2,x
    lda     *___SDCC_hc08_ret2
    bmi     1$
    jmp     fx_o_ret
1$:
    lda     6,x                 ; b >= 0: FX_INT32_MAX, else FX_INT32_MIN
    jmp     fx_o_sat
    __endasm;
    /* clang-format on */
}

int32_t fx_sub32_sat(int32_t a, int32_t b, uint8_t *sat) __naked
{
    a, b, sat; /* referenced in the assembly */
    /* clang-format off */
    __asm
    tsx                         ; a at 2..5,x, b at 6..9,x, sat at 10..11,x
    lda     5,x
    sub     9,x
    sta     5,x
    lda     4,x
    sbc     8,x
    sta     4,x
    lda     3,x
    sbc     7,x
    sta     3,x
    lda     2,x
    sbc     6,x
    psha
    tpa                         ; V (bit 7 of the CCR): signed overflow
    sta     *___SDCC_hc08_ret2
    pula
    sta     2,x
    lda     *___SDCC_hc08_ret2
    bmi     2$
    jmp     fx_o_ret
2$:
    lda     6,x                 ; b < 0: FX_INT32_MAX, else FX_INT32_MIN
    coma
    ; ---- saturate: *sat = 1; FX_INT32_MAX when A >= 0, else FX_INT32_MIN
fx_o_sat:
    psha
    ldhx    12,s                ; sat (11..12,s on entry)
    lda     #1
    sta     ,x
    pula
    tsta
    bmi     1$
    lda     #0x7f
    sta     *___SDCC_hc08_ret3
    lda     #0xff
    sta     *___SDCC_hc08_ret2
    tax
    rts
1$:
    lda     #0x80
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

/* Other compilers use the portable functions of firmware/src/fx_ops.c. */
typedef int fx_ops_s08_unused_t;

#endif
