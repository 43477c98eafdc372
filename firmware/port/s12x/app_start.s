; app_start.s - the application's start-up on the MC9S12XEP100: the entry
; point the bootloader jumps to (boot_start_app in boot_start.s), RAM set-up
; for the C, and the application's own vector table, relocated below the
; descriptor as AN4258 does (IVBR 0xEB: local 0xEB10-0xEBFF, global
; 0x7FEB10-0x7FEBFF), with the HAL's two interrupt routines
; (hal_s12x.c: SCI0 receive/transmit, PIT channel 0 tick).
;
;   m68hc11-as -mm9s12x -I firmware/port/s12x -o app_start.o app_start.s
;   m68hc11-ld -m m68hc12elf -T firmware/port/s12x/app.ld -o app.elf app_start.o <the C>
;   m68hc11-objcopy -O srec app.elf app.s19     (global addresses, S8 entry)
;   inclino flash --port P app.s19

        .include "s12x_regs.inc"

APP_IVBR    = 0xEB              ; the application's vector base (local 0xEB10-0xEBFF)

        .globl  _app_start

        .sect   .text
_app_start:
        sei
        lds     #STACK_TOP
        movb    #APP_IVBR, IVBR ; the application's vectors from now on
        PLL_TO_40MHZ            ; the 40 MHz bus the HAL's SCI, SPI and timer settings assume
        ; clear .bss
        ldx     #__bss_start
        ldd     #__bss_size
        beq     2f
1:      clr     1,x+
        subd    #1
        bne     1b
        ; copy .data from its image in flash
2:      ldx     #__data_load
        ldy     #__data_start
        ldd     #__data_size
        beq     4f
3:      movb    1,x+, 1,y+
        subd    #1
        bne     3b
4:      cli                     ; no source is enabled yet: hal_init does that
        jsr     main            ; C: app_main_init, then app_main_poll for ever
5:      bra     5b

; an interrupt nobody expects: reset through the COP (a wrong ARMCOP write)
_app_unexpected:
        sei
        movb    #0x00, ARMCOP
        bra     _app_unexpected

; ---------------------------------------------------------------- vector table
; 120 vectors at IVBR:0x10 .. IVBR:0xFE (MC9S12XE reference manual, vector
; table): PIT channel 0 at IVBR:0x7A, SCI0 at IVBR:0xD6.  The reset vectors
; (IVBR:0xFA-0xFE) are not taken from here: resets always use 0xFFFA-0xFFFE,
; the bootloader's.
        .section .vectors,"a"
        .rept   53
        .dc.w   _app_unexpected         ; IVBR:0x10 .. 0x78
        .endr
        .dc.w   hal_s12x_pit0_isr       ; IVBR:0x7A PIT channel 0
        .rept   45
        .dc.w   _app_unexpected         ; IVBR:0x7C .. 0xD4
        .endr
        .dc.w   hal_s12x_sci0_isr       ; IVBR:0xD6 SCI0
        .rept   19
        .dc.w   _app_unexpected         ; IVBR:0xD8 .. 0xFC
        .endr
        .dc.w   _app_start              ; IVBR:0xFE (not used by the part)
