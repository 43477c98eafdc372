/*
 * corr_temp_s08.c - corr_temp_eval and corr_triad_temp for the S08/HC08 (the
 * port's temperature terms, calibration image version 2).
 *
 * Same contracts and the same result bits as the portable functions in
 * firmware/src/correct.c (correct.h).  The portable C takes about 6 700 bus
 * cycles for corr_temp_eval of one triad (six fx_mul32_q31 and six fx_mul16
 * calls and SDCC's code around them) and 9 400 for corr_triad_temp; these
 * take about 3 500 and 6 700, the survey with the terms 57 500 instead of
 * 69 300 (mean bus cycles, `inclino bench mcu --json`: functions
 * corr_temp_eval, corr_triad_temp and survey_temperature; docs/mcu.md).
 *
 * corr_temp_eval.  Each of the six values of a triad, value = fx_mul32_q31(
 * inner, dT 2^15) with inner = k1 + fx_mul16(k2, dT) (k1 = c1 or r1, int32
 * Q38 / Q19 with |k1| <= 2^30; k2 = c2 or r2, int16 Q31 / Q12; dT int16 Q7
 * degC), in ct_val:
 *   inner: the four 8 x 8 MULs of the unsigned bytes of k2 and dT added to
 *     k1 (modulo 2^32), then dT 2^16 subtracted if k2 < 0 and k2 2^16 if
 *     dT < 0 (two's complement): exactly k1 + k2 dT, a plain int32 sum
 *     within the contract (|k2 dT| < 2^30).
 *   the product by dT 2^15, without its third partial product: with b =
 *     dT 2^15, fx_mul32_q31's bh = floor(b / 2^16) = h = floor(dT / 2) and
 *     bl = ((b mod 2^16) >> 1) = 2^14 (dT mod 2), so with ah = floor(inner /
 *     2^16) (int16) and L = (inner mod 2^16) with bit 0 cleared (= 2 al),
 *       s = ah h + floor(ah (dT mod 2) / 2) + floor(al h / 2^15)
 *         = floor(ah dT / 2) + floor(L h / 2^16)
 *     (ah h is whole: ah h + floor(ah (dT mod 2) / 2) = floor((2 h + dT mod
 *     2) ah / 2)).  value = 2 s = (ah dT with bit 0 cleared) + 2 F, F =
 *     floor(L h / 2^16) = floor(L hu / 2^16) - L [h < 0] (hu the unsigned
 *     reading of h).  ah dT: four MULs and the two sign corrections, as
 *     fx_mul16; F: four MULs (the lowest only for its carry, as fx_m_core's
 *     FX).  Eight MULs instead of fx_m_core's twelve, the same bits.  |ah
 *     dT / 2| <= 2^29 and |F| <= 2^14: |s| < 2^30, so fx_mul32_q31 never
 *     saturates here (neither does the C), and |value| <= 2^30 + 2^15.
 *   then, as the C: b_eff = fx_add32_sat(b, value) (on overflow the limit of
 *   the sum's true sign, *sat = 1), e = value clamped to +-CORR_E_MAX
 *   (0x1FFFFF00; *sat = 1 when clamped).
 *   Rounding, saturation and error bound: those of the portable function
 *   (correct.h: fx_mul32_q31's truncation only, -8 < value - exact < 2 LSB
 *   of the output for the terms as stored; b_eff's saturation and e's clamp
 *   set *sat).
 *
 * corr_triad_temp.  For each axis j: v = fx_sub32_sat(x_j, beff_j) straight
 * into fx_m_a and e_j into fx_m_b, p = fx_m_core (fx_mul32_s08.c, the
 * 12-MUL product of fx_mul32_q31; |v e| / 2^31 < 2^29, no saturation in
 * the contract, *sat = 1 if it ever did), d_j = sat(v + 4 p) into fx_m_b;
 * then column j of M: out_i = sat(out_i + fx_mul32_q31(m_ij, d_j)) for
 * i = 0..2 on the same core, the sums starting at 0 and saturating like
 * fx_add32_sat (the limit of the product's sign, *sat = 1).  Each out_i so
 * adds p_i0, p_i1, p_i2 in fx_dot3_q31's order, and a zero m_ij (which
 * fx_dot3_q31 skips) gives an exact 0 product: the same bits as the C's
 * three fx_dot3_q31 calls, without copying d for each row.  Rounding,
 * error bound and saturation those of correct.h (the scale product
 * truncates: -32 < d - v (1 + e) < 8 LSB of d before M, then corr_triad's
 * bound: -24 < out - exact < 6 LSB).
 *
 * Built only by SDCC for hc08/s08 with --stack-auto, the core compiled with
 * -DCORR_PORT_TEMP (host/inclino/s08/toolchain.py).  Reentrant calling
 * convention (the structure layouts are checked below):
 *   corr_temp_eval: dT in X (high byte) and A, c at 3..4,s, tc at 5..6,s,
 *     tt at 7..8,s, sat at 9..10,s on entry; nothing returned.
 *   corr_triad_temp: x in X (high byte) and A, c at 3..4,s, tt at 5..6,s,
 *     out at 7..8,s on entry; the saturation flag returned in A.
 * The evaluation works in 16 direct-page bytes of this module, the triad in
 * fx_mul32_s08.c's and 16 bytes of stack (the three sums, the flag, a
 * pointer, a count); like those these must not be called from an
 * interrupt handler while the main program may be in one of them.
 */
#include <stddef.h>
#include <stdint.h>

#include "inclino/correct.h"

#if defined(__SDCC_s08) || defined(__SDCC_hc08)

#include "fx_mul32_s08.h"

#ifndef __SDCC_STACK_AUTO
#error "the S08 port's assembly expects the reentrant (--stack-auto) calling convention"
#endif

/* the offsets the assembly uses */
_Static_assert(offsetof(corr_triad_t, bias) == 36, "corr_triad_t layout");
_Static_assert(offsetof(corr_tc_t, c1) == 0 && offsetof(corr_tc_t, c2) == 12 &&
                   offsetof(corr_tc_t, r1) == 18 && offsetof(corr_tc_t, r2) == 30,
               "corr_tc_t layout");
_Static_assert(offsetof(corr_tt_t, beff) == 0 && offsetof(corr_tt_t, e) == 12, "corr_tt_t layout");
_Static_assert(CORR_E_MAX == 0x1FFFFF00L, "the clamp below is written for this limit");

/* direct-page work of the evaluation (most significant byte first): dT, h =
 * floor(dT / 2), k2 (then the fraction byte), inner, the product, F */
static __data uint8_t ct_d[2];
static __data uint8_t ct_h[2];
static __data uint8_t ct_q[2];
static __data uint8_t ct_v[4];
static __data uint8_t ct_p[4];
static __data uint8_t ct_u[2];

#pragma save
#pragma less_pedantic
void corr_temp_eval(int16_t dt, const corr_triad_t *c, const corr_tc_t *tc, corr_tt_t *tt,
                    uint8_t *sat) __naked
{
    dt, c, tc, tt, sat; /* referenced in the assembly */
    /* clang-format off */
    __asm
    sta     *(_ct_d + 1)
    stx     *_ct_d
    asrx                        ; h = floor(dT / 2)
    stx     *_ct_h
    rora
    sta     *(_ct_h + 1)
    ldhx    5,s                 ; tc + 2 i: c2[i] at 12,x, r2[i] at 30,x
    pshx
    pshh
    lda     #3
    psha
    ; 1,s i count, 2..3,s tc + 2 i, 6..7,s c + 4 i (b[i] at 36,x),
    ; 8..9,s tc + 4 i (c1[i] at 0,x, r1[i] at 18,x), 10..11,s tt + 4 i
    ; (beff[i] at 0,x, e[i] at 12,x), 12..13,s sat
1$:
    ; ---- beff[i] = sat(b[i] + dT (c1[i] + c2[i] dT))
    ldhx    2,s
    lda     12,x
    sta     *_ct_q
    lda     13,x
    sta     *(_ct_q + 1)
    ldhx    8,s
    lda     ,x
    sta     *_ct_v
    lda     1,x
    sta     *(_ct_v + 1)
    lda     2,x
    sta     *(_ct_v + 2)
    lda     3,x
    sta     *(_ct_v + 3)
    jsr     ct_val
    ldhx    6,s
    lda     39,x
    add     *(_ct_p + 3)
    sta     *(_ct_p + 3)
    lda     38,x
    adc     *(_ct_p + 2)
    sta     *(_ct_p + 2)
    lda     37,x
    adc     *(_ct_p + 1)
    sta     *(_ct_p + 1)
    lda     36,x
    adc     *_ct_p
    tax
    tpa                         ; V (bit 7 of the CCR): signed overflow
    stx     *_ct_p
    tsta
    bpl     3$
    ldhx    12,s                ; *sat = 1 and the limit of the true sign,
    lda     #1                  ; the opposite of the wrapped sum
    sta     ,x
    lda     *_ct_p
    bmi     2$
    lda     #0x80
    sta     *_ct_p
    clra
    sta     *(_ct_p + 1)
    sta     *(_ct_p + 2)
    sta     *(_ct_p + 3)
    bra     3$
2$:
    lda     #0x7f
    sta     *_ct_p
    lda     #0xff
    sta     *(_ct_p + 1)
    sta     *(_ct_p + 2)
    sta     *(_ct_p + 3)
3$:
    ldhx    10,s
    lda     *_ct_p
    sta     ,x
    lda     *(_ct_p + 1)
    sta     1,x
    lda     *(_ct_p + 2)
    sta     2,x
    lda     *(_ct_p + 3)
    sta     3,x
    ; ---- e[i] = clamp(dT (r1[i] + r2[i] dT), +-0x1FFFFF00)
    ldhx    2,s
    lda     30,x
    sta     *_ct_q
    lda     31,x
    sta     *(_ct_q + 1)
    ldhx    8,s
    lda     18,x
    sta     *_ct_v
    lda     19,x
    sta     *(_ct_v + 1)
    lda     20,x
    sta     *(_ct_v + 2)
    lda     21,x
    sta     *(_ct_v + 3)
    jsr     ct_val
    lda     *_ct_p
    bmi     4$
    lda     #0x00               ; e >= 0: 0x1FFFFF00 - e borrows when e is above
    sub     *(_ct_p + 3)
    lda     #0xff
    sbc     *(_ct_p + 2)
    lda     #0xff
    sbc     *(_ct_p + 1)
    lda     #0x1f
    sbc     *_ct_p
    bcc     6$
    lda     #0x1f
    sta     *_ct_p
    lda     #0xff
    sta     *(_ct_p + 1)
    sta     *(_ct_p + 2)
    clra
    sta     *(_ct_p + 3)
    bra     5$
4$:
    lda     *(_ct_p + 3)        ; e < 0: e - 0xE0000100 borrows when e is below
    sub     #0x00
    lda     *(_ct_p + 2)
    sbc     #0x01
    lda     *(_ct_p + 1)
    sbc     #0x00
    lda     *_ct_p
    sbc     #0xe0
    bcc     6$
    lda     #0xe0
    sta     *_ct_p
    clra
    sta     *(_ct_p + 1)
    sta     *(_ct_p + 3)
    lda     #0x01
    sta     *(_ct_p + 2)
5$:
    ldhx    12,s                ; clamped: *sat = 1
    lda     #1
    sta     ,x
6$:
    ldhx    10,s
    lda     *_ct_p
    sta     12,x
    lda     *(_ct_p + 1)
    sta     13,x
    lda     *(_ct_p + 2)
    sta     14,x
    lda     *(_ct_p + 3)
    sta     15,x
    ; ---- next axis: the pointers by 4 (tc, c, tt) and by 2
    aix     #4
    sthx    10,s
    ldhx    8,s
    aix     #4
    sthx    8,s
    ldhx    6,s
    aix     #4
    sthx    6,s
    ldhx    2,s
    aix     #2
    sthx    2,s
    dec     1,s
    beq     7$
    jmp     1$
7$:
    ais     #3
    rts

    ; ---- ct_p = fx_mul32_q31(ct_v + ct_q * dT, dT 2^15): ct_v (k1) becomes
    ; inner (its lowest byte with bit 0 cleared), ct_q the fraction byte
ct_val:
    lda     *(_ct_q + 1)        ; Q1 * D1, at bytes 2..3
    ldx     *(_ct_d + 1)
    mul
    add     *(_ct_v + 3)
    sta     *(_ct_v + 3)
    txa
    adc     *(_ct_v + 2)
    sta     *(_ct_v + 2)
    bcc     11$
    inc     *(_ct_v + 1)
    bne     11$
    inc     *_ct_v
11$:
    lda     *_ct_q              ; Q0 * D1, at bytes 1..2
    ldx     *(_ct_d + 1)
    mul
    add     *(_ct_v + 2)
    sta     *(_ct_v + 2)
    txa
    adc     *(_ct_v + 1)
    sta     *(_ct_v + 1)
    bcc     12$
    inc     *_ct_v
12$:
    lda     *(_ct_q + 1)        ; Q1 * D0, at bytes 1..2
    ldx     *_ct_d
    mul
    add     *(_ct_v + 2)
    sta     *(_ct_v + 2)
    txa
    adc     *(_ct_v + 1)
    sta     *(_ct_v + 1)
    bcc     13$
    inc     *_ct_v
13$:
    lda     *_ct_q              ; Q0 * D0, at bytes 0..1
    ldx     *_ct_d
    mul
    add     *(_ct_v + 1)
    sta     *(_ct_v + 1)
    txa
    adc     *_ct_v
    sta     *_ct_v
    lda     *_ct_q              ; k2 < 0: inner -= dT 2^16
    bpl     14$
    lda     *(_ct_v + 1)
    sub     *(_ct_d + 1)
    sta     *(_ct_v + 1)
    lda     *_ct_v
    sbc     *_ct_d
    sta     *_ct_v
14$:
    lda     *_ct_d              ; dT < 0: inner -= k2 2^16
    bpl     15$
    lda     *(_ct_v + 1)
    sub     *(_ct_q + 1)
    sta     *(_ct_v + 1)
    lda     *_ct_v
    sbc     *_ct_q
    sta     *_ct_v
15$:
    ; P = ah * dT, ah = V0:V1 (signed), in ct_p
    lda     *(_ct_v + 1)        ; V1 * D1
    ldx     *(_ct_d + 1)
    mul
    sta     *(_ct_p + 3)
    stx     *(_ct_p + 2)
    lda     *_ct_v              ; V0 * D0
    ldx     *_ct_d
    mul
    sta     *(_ct_p + 1)
    stx     *_ct_p
    lda     *_ct_v              ; V0 * D1, at bytes 1..2
    ldx     *(_ct_d + 1)
    mul
    add     *(_ct_p + 2)
    sta     *(_ct_p + 2)
    txa
    adc     *(_ct_p + 1)
    sta     *(_ct_p + 1)
    bcc     16$
    inc     *_ct_p
16$:
    lda     *(_ct_v + 1)        ; V1 * D0, at bytes 1..2
    ldx     *_ct_d
    mul
    add     *(_ct_p + 2)
    sta     *(_ct_p + 2)
    txa
    adc     *(_ct_p + 1)
    sta     *(_ct_p + 1)
    bcc     17$
    inc     *_ct_p
17$:
    lda     *_ct_v              ; ah < 0: P -= dT 2^16
    bpl     18$
    lda     *(_ct_p + 1)
    sub     *(_ct_d + 1)
    sta     *(_ct_p + 1)
    lda     *_ct_p
    sbc     *_ct_d
    sta     *_ct_p
18$:
    lda     *_ct_d              ; dT < 0: P -= ah 2^16
    bpl     19$
    lda     *(_ct_p + 1)
    sub     *(_ct_v + 1)
    sta     *(_ct_p + 1)
    lda     *_ct_p
    sbc     *_ct_v
    sta     *_ct_p
19$:
    ; F = floor(L hu / 2^16) - L [h < 0], L = V2:V3e (V3e = V3 & 0xfe), in ct_u
    lda     *(_ct_v + 3)
    and     #0xfe
    sta     *(_ct_v + 3)
    ldx     *(_ct_h + 1)        ; V3e * H1: only its high byte counts
    mul
    stx     *_ct_q
    lda     *(_ct_v + 3)        ; V3e * H0, at the fraction byte
    ldx     *_ct_h
    mul
    add     *_ct_q
    sta     *_ct_q
    txa
    adc     #0                  ; a high byte is at most 0xfd: no carry out
    sta     *(_ct_u + 1)
    lda     *(_ct_v + 2)        ; V2 * H1, at the fraction byte
    ldx     *(_ct_h + 1)
    mul
    add     *_ct_q              ; only the carry counts now
    txa
    adc     *(_ct_u + 1)
    sta     *(_ct_u + 1)
    clra
    rola
    sta     *_ct_u
    lda     *(_ct_v + 2)        ; V2 * H0, whole
    ldx     *_ct_h
    mul
    add     *(_ct_u + 1)
    sta     *(_ct_u + 1)
    txa
    adc     *_ct_u
    sta     *_ct_u              ; floor(L hu / 2^16) < 2^16: no carry out
    lda     *_ct_h              ; h < 0: F -= L
    bpl     20$
    lda     *(_ct_u + 1)
    sub     *(_ct_v + 3)
    sta     *(_ct_u + 1)
    lda     *_ct_u
    sbc     *(_ct_v + 2)
    sta     *_ct_u
20$:
    ; value = (P with bit 0 cleared) + 2 F, 2 F sign-extended (|F| <= 2^14)
    lsl     *(_ct_u + 1)
    rol     *_ct_u
    clrx
    lda     *_ct_u
    bpl     21$
    decx
21$:
    lda     *(_ct_p + 3)
    and     #0xfe
    add     *(_ct_u + 1)
    sta     *(_ct_p + 3)
    lda     *(_ct_p + 2)
    adc     *_ct_u
    sta     *(_ct_p + 2)
    txa                         ; (TXA keeps C)
    adc     *(_ct_p + 1)
    sta     *(_ct_p + 1)
    txa
    adc     *_ct_p
    sta     *_ct_p
    rts
    __endasm;
    /* clang-format on */
}

uint8_t corr_triad_temp(const int32_t x[3], const corr_triad_t *c, const corr_tt_t *tt,
                        int32_t out[3]) __naked
{
    x, c, tt, out; /* referenced in the assembly */
    /* clang-format off */
    __asm
    psha
    pshx
    ais     #-16
    ; 1,s sat, 2..13,s the sums out[0..2], 14..15,s c + 4 j (column j of M:
    ; m[i][j] at 12 i,x), 16,s count, 17..18,s x + 4 j, 21..22,s c,
    ; 23..24,s tt + 4 j, 25..26,s out
    tsx
    clra
    sta     ,x
    sta     1,x
    sta     2,x
    sta     3,x
    sta     4,x
    sta     5,x
    sta     6,x
    sta     7,x
    sta     8,x
    sta     9,x
    sta     10,x
    sta     11,x
    sta     12,x
    lda     #3
    sta     16,s
    ldhx    21,s
    sthx    14,s
1$:
    ; ---- v = sat(x[j] - beff[j]) in fx_m_a, e[j] in fx_m_b
    ldhx    17,s
    lda     ,x
    sta     *_fx_m_a
    lda     1,x
    sta     *(_fx_m_a + 1)
    lda     2,x
    sta     *(_fx_m_a + 2)
    lda     3,x
    sta     *(_fx_m_a + 3)
    ldhx    23,s
    lda     *(_fx_m_a + 3)
    sub     3,x
    sta     *(_fx_m_a + 3)
    lda     *(_fx_m_a + 2)
    sbc     2,x
    sta     *(_fx_m_a + 2)
    lda     *(_fx_m_a + 1)
    sbc     1,x
    sta     *(_fx_m_a + 1)
    lda     *_fx_m_a
    sbc     ,x
    psha
    tpa                         ; V (bit 7 of the CCR): signed overflow
    tsta
    pula                        ; (PULA keeps the N of TSTA)
    bmi     2$
    sta     *_fx_m_a
    bra     3$
2$:
    sta     *_fx_m_a
    lda     #1                  ; *sat and the limit of the true sign, the
    sta     1,s                 ; opposite of the wrapped difference
    lda     *_fx_m_a
    jsr     ct_lim_a
3$:
    lda     12,x
    sta     *_fx_m_b
    lda     13,x
    sta     *(_fx_m_b + 1)
    lda     14,x
    sta     *(_fx_m_b + 2)
    lda     15,x
    sta     *(_fx_m_b + 3)
    jsr     fx_m_core           ; p = fx_mul32_q31(v, e): ret3 ret2 fx_m_s
    bcc     4$
    lda     #1
    sta     1,s
4$:
    lsl     *(_fx_m_s + 1)      ; 4 p
    rol     *_fx_m_s
    rol     *___SDCC_hc08_ret2
    rol     *___SDCC_hc08_ret3
    lsl     *(_fx_m_s + 1)
    rol     *_fx_m_s
    rol     *___SDCC_hc08_ret2
    rol     *___SDCC_hc08_ret3
    lda     *(_fx_m_a + 3)      ; d[j] = sat(v + 4 p) in fx_m_b
    add     *(_fx_m_s + 1)
    sta     *(_fx_m_b + 3)
    lda     *(_fx_m_a + 2)
    adc     *_fx_m_s
    sta     *(_fx_m_b + 2)
    lda     *(_fx_m_a + 1)
    adc     *___SDCC_hc08_ret2
    sta     *(_fx_m_b + 1)
    lda     *_fx_m_a
    adc     *___SDCC_hc08_ret3
    psha
    tpa
    tsta
    pula
    bmi     5$
    sta     *_fx_m_b
    bra     6$
5$:
    sta     *_fx_m_b
    lda     #1
    sta     1,s
    lda     *_fx_m_b
    jsr     ct_lim_b
6$:
    ; ---- the sums: out[i] = sat(out[i] + fx_mul32_q31(m[i][j], d[j]))
    ldhx    14,s
    jsr     ct_mrow
    bcc     7$
    lda     #1
    sta     1,s
7$:
    tsx
    aix     #1
    jsr     ct_acc
    ldhx    14,s
    aix     #12
    jsr     ct_mrow
    bcc     8$
    lda     #1
    sta     1,s
8$:
    tsx
    aix     #5
    jsr     ct_acc
    ldhx    14,s
    aix     #24
    jsr     ct_mrow
    bcc     9$
    lda     #1
    sta     1,s
9$:
    tsx
    aix     #9
    jsr     ct_acc
    ; ---- next column: c, x and tt by 4
    ldhx    14,s
    aix     #4
    sthx    14,s
    ldhx    17,s
    aix     #4
    sthx    17,s
    ldhx    23,s
    aix     #4
    sthx    23,s
    dec     16,s
    beq     10$
    jmp     1$
10$:
    ldhx    25,s                ; out
    lda     2,s
    sta     ,x
    lda     3,s
    sta     1,x
    lda     4,s
    sta     2,x
    lda     5,s
    sta     3,x
    lda     6,s
    sta     4,x
    lda     7,s
    sta     5,x
    lda     8,s
    sta     6,x
    lda     9,s
    sta     7,x
    lda     10,s
    sta     8,x
    lda     11,s
    sta     9,x
    lda     12,s
    sta     10,x
    lda     13,s
    sta     11,x
    lda     1,s
    ais     #18
    rts

    ; ---- fx_m_a = the int32 at H:X, then the core (its C: saturated)
ct_mrow:
    lda     ,x
    sta     *_fx_m_a
    lda     1,x
    sta     *(_fx_m_a + 1)
    lda     2,x
    sta     *(_fx_m_a + 2)
    lda     3,x
    sta     *(_fx_m_a + 3)
    jmp     fx_m_core

    ; ---- the sum at H:X += the core result, saturating like fx_add32_sat
    ; (sat at 3,s here: 1,s of the caller)
ct_acc:
    lda     3,x
    add     *(_fx_m_s + 1)
    sta     3,x
    lda     2,x
    adc     *_fx_m_s
    sta     2,x
    lda     1,x
    adc     *___SDCC_hc08_ret2
    sta     1,x
    lda     ,x
    adc     *___SDCC_hc08_ret3
    psha
    tpa
    tsta
    pula
    bmi     1$
    sta     ,x
    rts
1$:
    lda     #1                  ; *sat and the limit of the sign of the
    sta     3,s                 ; product (that of the true sum)
    lda     *___SDCC_hc08_ret3
    bmi     2$
    lda     #0x7f
    sta     ,x
    lda     #0xff
    sta     1,x
    sta     2,x
    sta     3,x
    rts
2$:
    lda     #0x80
    sta     ,x
    clra
    sta     1,x
    sta     2,x
    sta     3,x
    rts

    ; ---- fx_m_a, fx_m_b to the limit opposite to the sign of A (a wrapped
    ; sum or difference): 0x7fffffff for A < 0, else 0x80000000
ct_lim_a:
    tsta
    bmi     1$
    lda     #0x80
    sta     *_fx_m_a
    clra
    sta     *(_fx_m_a + 1)
    sta     *(_fx_m_a + 2)
    sta     *(_fx_m_a + 3)
    rts
1$:
    lda     #0x7f
    sta     *_fx_m_a
    lda     #0xff
    sta     *(_fx_m_a + 1)
    sta     *(_fx_m_a + 2)
    sta     *(_fx_m_a + 3)
    rts
ct_lim_b:
    tsta
    bmi     1$
    lda     #0x80
    sta     *_fx_m_b
    clra
    sta     *(_fx_m_b + 1)
    sta     *(_fx_m_b + 2)
    sta     *(_fx_m_b + 3)
    rts
1$:
    lda     #0x7f
    sta     *_fx_m_b
    lda     #0xff
    sta     *(_fx_m_b + 1)
    sta     *(_fx_m_b + 2)
    sta     *(_fx_m_b + 3)
    rts
    __endasm;
    /* clang-format on */
}
#pragma restore

#else

/* Other compilers use the portable functions of firmware/src/correct.c. */
typedef int corr_temp_s08_unused_t;

#endif
