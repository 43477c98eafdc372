/*
 * fx_mul32_s08.c - fx_mul32_q31 and fx_dot3_q31 for the S08/HC08 (the port's
 * 32-bit products).
 *
 * Same contracts and the same result bits as the portable functions in
 * firmware/src/fx_ops.c (fx_ops.h).  fx_mul32_q31: with ah = floor(a / 2^16),
 * al = (a mod 2^16) >> 1 and likewise bh, bl,
 *   s = ah*bh + floor(ah*bl / 2^15) + floor(al*bh / 2^15),
 * the result is 2*s, or FX_INT32_MAX / FX_INT32_MIN with *sat = 1 when s is
 * outside [-2^30, 2^30 - 1].  The portable C makes three fx_mul16 calls and
 * splits and floors 32-bit values in SDCC's code (about 1 300 bus cycles on
 * the S08); the core here is twelve 8 x 8 MULs on unsigned bytes, about 400.
 * fx_dot3_q31 runs the same core on a[i], b[i] read through the pointers and
 * sums with the saturating addition of fx_add32_sat, without the argument
 * passing of three calls (a zero a[i] contributes an exact 0 and is skipped;
 * for b == a, the squares, the core's terms that are equal are computed
 * once: 7 MULs instead of 12).
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
 * -DFX_PORT_MUL32 (host/inclino/s08/toolchain.py).  Reentrant calling convention:
 * fx_mul32_q31: a at 3..6,s, b at 7..10,s (big-endian), sat at 11..12,s;
 * fx_dot3_q31: a in X (high byte) and A, b at 3..4,s, sat at 5..6,s; the
 * results in ___SDCC_hc08_ret3, ___SDCC_hc08_ret2, X, A (most to least
 * significant byte).  The operands, partial sums and the dot product's sum
 * live in direct-page bytes of this module and in the return registers, so,
 * like those, these must not be called from an interrupt handler while the
 * main program may be in one of them.
 */
#include <stdint.h>

#include "inclino/fx_ops.h"

#if defined(__SDCC_s08) || defined(__SDCC_hc08)

#include "fx_mul32_s08.h"

#ifndef __SDCC_STACK_AUTO
#error "the S08 port's assembly expects the reentrant (--stack-auto) calling convention"
#endif

/* direct-page work of the core: the operands a, b (most significant byte
 * first), the low half of s (its high half is ___SDCC_hc08_ret3, ret2), FX or
 * FY (2 bytes), the fraction byte; and fx_dot3_q31's sum and step count.
 * fx_m_a, fx_m_b, fx_m_s and the core (fx_m_core) are shared with the
 * temperature terms' assembly (fx_mul32_s08.h, corr_temp_s08.c). */
__data uint8_t fx_m_a[4];
__data uint8_t fx_m_b[4];
__data uint8_t fx_m_s[2];
static __data uint8_t fx_m_t[2];
static __data uint8_t fx_m_f;
static __data uint8_t fx_m_acc[4];
static __data uint8_t fx_m_n;
static __data uint8_t fx_m_sq;

#pragma save
#pragma less_pedantic
int32_t fx_mul32_q31(int32_t a, int32_t b, uint8_t *sat) __naked
{
    a, b, sat; /* referenced in the assembly */
    /* clang-format off */
    __asm
    lda     3,s
    sta     *_fx_m_a
    lda     4,s
    sta     *(_fx_m_a + 1)
    lda     5,s
    sta     *(_fx_m_a + 2)
    lda     6,s
    sta     *(_fx_m_a + 3)
    lda     7,s
    sta     *_fx_m_b
    lda     8,s
    sta     *(_fx_m_b + 1)
    lda     9,s
    sta     *(_fx_m_b + 2)
    lda     10,s
    sta     *(_fx_m_b + 3)
    jsr     fx_m_core
    bcc     1$
    ldhx    11,s                ; *sat = 1
    lda     #1
    sta     ,x
1$:
    lda     *(_fx_m_s + 1)
    ldx     *_fx_m_s
    rts

    ; ---- the core: s = fx_mul32_q31(fx_m_a, fx_m_b) in ret3 ret2 fx_m_s
    ; (s0 s1 s2 s3); C set when it saturated (s is then the limit).  Global:
    ; corr_temp_s08.c calls it too (it keeps fx_m_a and fx_m_b, uses X, A)
fx_m_core::
    ; s = ah_u * bh_u
    lda     *(_fx_m_a + 1)      ; A1 * B1
    ldx     *(_fx_m_b + 1)
    mul
    sta     *(_fx_m_s + 1)
    stx     *_fx_m_s
    lda     *_fx_m_a            ; A0 * B0
    ldx     *_fx_m_b
    mul
    sta     *___SDCC_hc08_ret2
    stx     *___SDCC_hc08_ret3
    lda     *_fx_m_a            ; A0 * B1, at byte 2
    ldx     *(_fx_m_b + 1)
    mul
    add     *_fx_m_s
    sta     *_fx_m_s
    txa
    adc     *___SDCC_hc08_ret2
    sta     *___SDCC_hc08_ret2
    bcc     1$
    inc     *___SDCC_hc08_ret3
1$:
    lda     *(_fx_m_a + 1)      ; A1 * B0, at byte 2
    ldx     *_fx_m_b
    mul
    add     *_fx_m_s
    sta     *_fx_m_s
    txa
    adc     *___SDCC_hc08_ret2
    sta     *___SDCC_hc08_ret2
    bcc     2$
    inc     *___SDCC_hc08_ret3
2$:
    ; FX = floor((A0:A1) * (B2:B3e) / 2^16), B3e = B3 & 0xfe
    lda     *(_fx_m_b + 3)      ; A1 * B3e: only its high byte counts
    and     #0xfe
    ldx     *(_fx_m_a + 1)
    mul
    stx     *_fx_m_f
    lda     *(_fx_m_b + 3)      ; A0 * B3e, at the fraction byte
    and     #0xfe
    ldx     *_fx_m_a
    mul
    add     *_fx_m_f
    sta     *_fx_m_f
    txa
    adc     #0                  ; a high byte is at most 0xfe: no carry out
    sta     *(_fx_m_t + 1)
    lda     *(_fx_m_a + 1)      ; A1 * B2, at the fraction byte
    ldx     *(_fx_m_b + 2)
    mul
    add     *_fx_m_f            ; only the carry counts now
    txa
    adc     *(_fx_m_t + 1)
    sta     *(_fx_m_t + 1)
    clra
    rola
    sta     *_fx_m_t
    lda     *_fx_m_a            ; A0 * B2, whole
    ldx     *(_fx_m_b + 2)
    mul
    add     *(_fx_m_t + 1)
    sta     *(_fx_m_t + 1)
    txa
    adc     *_fx_m_t
    sta     *_fx_m_t            ; FX < 2^16: no carry out
    lda     *(_fx_m_s + 1)      ; s += FX
    add     *(_fx_m_t + 1)
    sta     *(_fx_m_s + 1)
    lda     *_fx_m_s
    adc     *_fx_m_t
    sta     *_fx_m_s
    bcc     3$
    inc     *___SDCC_hc08_ret2
    bne     3$
    inc     *___SDCC_hc08_ret3
3$:
    ; FY = floor((A2:A3e) * (B0:B1) / 2^16), A3e = A3 & 0xfe
    lda     *(_fx_m_a + 3)      ; A3e * B1: only its high byte counts
    and     #0xfe
    ldx     *(_fx_m_b + 1)
    mul
    stx     *_fx_m_f
    lda     *(_fx_m_a + 3)      ; A3e * B0, at the fraction byte
    and     #0xfe
    ldx     *_fx_m_b
    mul
    add     *_fx_m_f
    sta     *_fx_m_f
    txa
    adc     #0
    sta     *(_fx_m_t + 1)
    lda     *(_fx_m_a + 2)      ; A2 * B1, at the fraction byte
    ldx     *(_fx_m_b + 1)
    mul
    add     *_fx_m_f
    txa
    adc     *(_fx_m_t + 1)
    sta     *(_fx_m_t + 1)
    clra
    rola
    sta     *_fx_m_t
    lda     *(_fx_m_a + 2)      ; A2 * B0, whole
    ldx     *_fx_m_b
    mul
    add     *(_fx_m_t + 1)
    sta     *(_fx_m_t + 1)
    txa
    adc     *_fx_m_t
    sta     *_fx_m_t
    lda     *(_fx_m_s + 1)      ; s += FY
    add     *(_fx_m_t + 1)
    sta     *(_fx_m_s + 1)
    lda     *_fx_m_s
    adc     *_fx_m_t
    sta     *_fx_m_s
    bcc     4$
    inc     *___SDCC_hc08_ret2
    bne     4$
    inc     *___SDCC_hc08_ret3
4$:
    lda     *_fx_m_a            ; a < 0: s -= b & ~1
    bpl     5$
    lda     *(_fx_m_b + 3)
    and     #0xfe
    sta     *_fx_m_f
    lda     *(_fx_m_s + 1)
    sub     *_fx_m_f
    sta     *(_fx_m_s + 1)
    lda     *_fx_m_s
    sbc     *(_fx_m_b + 2)
    sta     *_fx_m_s
    lda     *___SDCC_hc08_ret2
    sbc     *(_fx_m_b + 1)
    sta     *___SDCC_hc08_ret2
    lda     *___SDCC_hc08_ret3
    sbc     *_fx_m_b
    sta     *___SDCC_hc08_ret3
5$:
    lda     *_fx_m_b            ; b < 0: s -= a & ~1
    bpl     6$
    lda     *(_fx_m_a + 3)
    and     #0xfe
    sta     *_fx_m_f
    lda     *(_fx_m_s + 1)
    sub     *_fx_m_f
    sta     *(_fx_m_s + 1)
    lda     *_fx_m_s
    sbc     *(_fx_m_a + 2)
    sta     *_fx_m_s
    lda     *___SDCC_hc08_ret2
    sbc     *(_fx_m_a + 1)
    sta     *___SDCC_hc08_ret2
    lda     *___SDCC_hc08_ret3
    sbc     *_fx_m_a
    sta     *___SDCC_hc08_ret3
6$:
    ; s outside [-2^30, 2^30): bits 31 and 30 differ, that is bit 7 of
    ; (top byte + 0x40) is set
fx_m_tail:
    lda     *___SDCC_hc08_ret3
    add     #0x40
    bmi     7$
    lsl     *(_fx_m_s + 1)      ; result 2*s
    rol     *_fx_m_s
    rol     *___SDCC_hc08_ret2
    rol     *___SDCC_hc08_ret3
    clc
    rts
7$:
    lda     *___SDCC_hc08_ret3
    bmi     8$
    lda     #0x7f               ; FX_INT32_MAX
    sta     *___SDCC_hc08_ret3
    lda     #0xff
    sta     *___SDCC_hc08_ret2
    sta     *_fx_m_s
    sta     *(_fx_m_s + 1)
    sec
    rts
8$:
    lda     #0x80               ; FX_INT32_MIN
    sta     *___SDCC_hc08_ret3
    clra
    sta     *___SDCC_hc08_ret2
    sta     *_fx_m_s
    sta     *(_fx_m_s + 1)
    sec
    rts

    ; ---- the core for b = a: the same s with the bytes of a as those of b:
    ; A0*B1 = A1*B0, FX = FY and the two corrections are equal:
    ; s = ah_u^2 + 2 FX - 2 [a < 0] (a & ~1)  (7 MULs instead of 12)
fx_m_sq_core:
    lda     *(_fx_m_a + 1)      ; A1 * A1
    tax
    mul
    sta     *(_fx_m_s + 1)
    stx     *_fx_m_s
    lda     *_fx_m_a            ; A0 * A0
    tax
    mul
    sta     *___SDCC_hc08_ret2
    stx     *___SDCC_hc08_ret3
    lda     *_fx_m_a            ; 2 * A0 * A1, at byte 2
    ldx     *(_fx_m_a + 1)
    mul
    lsla
    rolx
    bcc     1$
    inc     *___SDCC_hc08_ret3
1$:
    add     *_fx_m_s
    sta     *_fx_m_s
    txa
    adc     *___SDCC_hc08_ret2
    sta     *___SDCC_hc08_ret2
    bcc     2$
    inc     *___SDCC_hc08_ret3
2$:
    ; FX = floor((A0:A1) * (A2:A3e) / 2^16), A3e = A3 & 0xfe
    lda     *(_fx_m_a + 3)      ; A1 * A3e: only its high byte counts
    and     #0xfe
    ldx     *(_fx_m_a + 1)
    mul
    stx     *_fx_m_f
    lda     *(_fx_m_a + 3)      ; A0 * A3e, at the fraction byte
    and     #0xfe
    ldx     *_fx_m_a
    mul
    add     *_fx_m_f
    sta     *_fx_m_f
    txa
    adc     #0
    sta     *(_fx_m_t + 1)
    lda     *(_fx_m_a + 1)      ; A1 * A2, at the fraction byte
    ldx     *(_fx_m_a + 2)
    mul
    add     *_fx_m_f
    txa
    adc     *(_fx_m_t + 1)
    sta     *(_fx_m_t + 1)
    clra
    rola
    sta     *_fx_m_t
    lda     *_fx_m_a            ; A0 * A2, whole
    ldx     *(_fx_m_a + 2)
    mul
    add     *(_fx_m_t + 1)
    sta     *(_fx_m_t + 1)
    txa
    adc     *_fx_m_t
    sta     *_fx_m_t
    lsl     *(_fx_m_t + 1)      ; s += 2 FX (2 FX < 2^17)
    rol     *_fx_m_t
    bcc     3$
    inc     *___SDCC_hc08_ret2
    bne     3$
    inc     *___SDCC_hc08_ret3
3$:
    lda     *(_fx_m_s + 1)
    add     *(_fx_m_t + 1)
    sta     *(_fx_m_s + 1)
    lda     *_fx_m_s
    adc     *_fx_m_t
    sta     *_fx_m_s
    bcc     4$
    inc     *___SDCC_hc08_ret2
    bne     4$
    inc     *___SDCC_hc08_ret3
4$:
    lda     *_fx_m_a            ; a < 0: s -= 2 (a & ~1)
    bpl     5$
    lda     *(_fx_m_a + 3)
    and     #0xfe
    lsla
    sta     *(_fx_m_t + 1)
    lda     *(_fx_m_a + 2)
    rola
    sta     *_fx_m_t
    lda     *(_fx_m_a + 1)
    rola
    sta     *_fx_m_f
    lda     *_fx_m_a
    rola                        ; 2 (a & ~1) modulo 2^32: bytes A, f, t, t+1
    psha
    lda     *(_fx_m_s + 1)
    sub     *(_fx_m_t + 1)
    sta     *(_fx_m_s + 1)
    lda     *_fx_m_s
    sbc     *_fx_m_t
    sta     *_fx_m_s
    lda     *___SDCC_hc08_ret2
    sbc     *_fx_m_f
    sta     *___SDCC_hc08_ret2
    pula
    psha
    lda     *___SDCC_hc08_ret3
    sbc     1,s
    sta     *___SDCC_hc08_ret3
    pula
5$:
    jmp     fx_m_tail
    __endasm;
    /* clang-format on */
}

int32_t fx_dot3_q31(const int32_t a[3], const int32_t b[3], uint8_t *sat) __naked
{
    a, b, sat; /* referenced in the assembly */
    /* clang-format off */
    __asm
    clr     *_fx_m_sq           ; b == a: the core of the squares
    cmp     4,s
    bne     9$
    cpx     3,s
    bne     9$
    inc     *_fx_m_sq
9$:
    psha                        ; a at 1..2,s; b at 5..6,s; sat at 7..8,s
    pshx
    clra
    sta     *_fx_m_acc
    sta     *(_fx_m_acc + 1)
    sta     *(_fx_m_acc + 2)
    sta     *(_fx_m_acc + 3)
    lda     #3
    sta     *_fx_m_n
1$:
    ldhx    1,s                 ; fx_m_a = a[i]
    lda     ,x
    sta     *_fx_m_a
    lda     1,x
    sta     *(_fx_m_a + 1)
    lda     2,x
    sta     *(_fx_m_a + 2)
    lda     3,x
    sta     *(_fx_m_a + 3)
    aix     #4
    sthx    1,s
    ora     *(_fx_m_a + 2)
    ora     *(_fx_m_a + 1)
    ora     *_fx_m_a
    bne     12$
    jmp     4$                  ; a[i] == 0: the product is an exact 0
12$:
    tst     *_fx_m_sq
    beq     10$
    jsr     fx_m_sq_core
    bra     11$
10$:
    ldhx    5,s                 ; fx_m_b = b[i]
    lda     ,x
    sta     *_fx_m_b
    lda     1,x
    sta     *(_fx_m_b + 1)
    lda     2,x
    sta     *(_fx_m_b + 2)
    lda     3,x
    sta     *(_fx_m_b + 3)
    aix     #4
    sthx    5,s
    jsr     fx_m_core
11$:
    bcc     2$
    ldhx    7,s                 ; *sat = 1
    lda     #1
    sta     ,x
2$:
    lda     *(_fx_m_acc + 3)    ; sum += s, saturating like fx_add32_sat
    add     *(_fx_m_s + 1)
    sta     *(_fx_m_acc + 3)
    lda     *(_fx_m_acc + 2)
    adc     *_fx_m_s
    sta     *(_fx_m_acc + 2)
    lda     *(_fx_m_acc + 1)
    adc     *___SDCC_hc08_ret2
    sta     *(_fx_m_acc + 1)
    lda     *_fx_m_acc
    adc     *___SDCC_hc08_ret3
    tax
    tpa                         ; V (bit 7 of the CCR): signed overflow
    stx     *_fx_m_acc
    tsta
    bpl     3$
    ldhx    7,s                 ; *sat = 1 and the limit of the sign of s
    lda     #1
    sta     ,x
    lda     *___SDCC_hc08_ret3
    bmi     5$
    lda     #0x7f
    sta     *_fx_m_acc
    lda     #0xff
    sta     *(_fx_m_acc + 1)
    sta     *(_fx_m_acc + 2)
    sta     *(_fx_m_acc + 3)
    bra     3$
5$:
    lda     #0x80
    sta     *_fx_m_acc
    clra
    sta     *(_fx_m_acc + 1)
    sta     *(_fx_m_acc + 2)
    sta     *(_fx_m_acc + 3)
3$:
    dec     *_fx_m_n            ; (the loop is too long for dbnz)
    beq     6$
    jmp     1$
6$:
    lda     *_fx_m_acc
    sta     *___SDCC_hc08_ret3
    lda     *(_fx_m_acc + 1)
    sta     *___SDCC_hc08_ret2
    lda     *(_fx_m_acc + 3)
    ldx     *(_fx_m_acc + 2)
    ais     #2
    rts
4$:
    ldhx    5,s                 ; skip b[i]
    aix     #4
    sthx    5,s
    bra     3$
    __endasm;
    /* clang-format on */
}
#pragma restore

#else

/* Other compilers use the portable functions of firmware/src/fx_ops.c. */
typedef int fx_mul32_s08_unused_t;

#endif
