; boot_start.s - the serial bootloader's reset path on the MC9S12XEP100
; (docs/bootloader.md): reset vector, start-up, the choice between the
; bootloader and the application (boot_select, firmware/src/boot.c), the
; jump to the application's entry point, the vector table and the flash
; configuration field with FPROT protecting the bootloader's 4 KiB.
;
; Assemble and link (binutils-m68hc1x, as the tests do):
;   m68hc11-as -mm9s12x -I firmware/port/s12x -o boot_start.o boot_start.s
;   m68hc11-ld -m m68hc12elf -T firmware/port/s12x/boot.ld -o boot.elf boot_start.o <the C, compiled for the S12X>
; The C (boot.c, boot_main.c, the HAL) is not compiled here: Debian has no
; C compiler for the S12X (README.md in this folder).
;
; C calls follow the CodeWarrior HC12 convention: the last argument in B
; (8 bits) / D (16 bits), an 8-bit result in B.

        .include "s12x_regs.inc"

        .globl  _boot_reset
        .globl  boot_start_app
        .globl  boot_request

; ---------------------------------------------------------------- no-init RAM
        .sect   .noinit
boot_request:
        .ds.w   2               ; "BOOT" when the application answered BOOTLOADER

; ---------------------------------------------------------------- reset
        .sect   .text
_boot_reset:
        lds     #STACK_TOP
        movb    #0x00, COPCTL   ; COP off while the loader runs (README: COP policy)
        PLL_TO_40MHZ            ; the 40 MHz bus the HAL's SCI, SPI and timer settings assume
        movb    #0xFF, IVBR     ; the loader's own vectors (the reset value; set again after a jump back)
        ; request = 1 if the application left "BOOT" in the no-init word, then clear it
        clrb
        ldx     boot_request
        cpx     #BOOT_KEY_HI
        bne     1f
        ldx     boot_request+2
        cpx     #BOOT_KEY_LO
        bne     1f
        ldab    #1
1:      movw    #0, boot_request
        movw    #0, boot_request+2
        pshb
        ; clear .bss, copy .data (the C's static state); .noinit is left alone
        ldx     #__bss_start
        ldd     #__bss_size
        beq     7f
6:      clr     1,x+
        subd    #1
        bne     6b
7:      ldx     #__data_load
        ldy     #__data_start
        ldd     #__data_size
        beq     9f
8:      movb    1,x+, 1,y+
        subd    #1
        bne     8b
9:      pulb                    ; the request
        jsr     boot_select     ; C: BOOT_SEL_APP (0) or BOOT_SEL_LOADER (1) in B
        tstb
        bne     2f
        jmp     boot_start_app
2:      jsr     boot_main_init  ; C: the loader's command layer on SCI0
3:      jsr     boot_main_poll  ; C: one pass of its main loop
        jsr     boot_main_restart_requested
        tstb                    ; BOOT_AFTER_NONE (0): keep polling
        beq     3b
        bra     boot_restart    ; RESET or RUN answered: restart through the reset path

; boot_start_app: jump to the application's entry point, the global address
; in the descriptor that boot_select has just checked (inside one of the
; image's ranges, in the application area).  The 16 KiB page of a global
; address is bits 21..14; pages 0xFD and 0xFF are mapped at local
; 0x4000-0x7FFF and 0xC000-0xFFFF without PPAGE, every other page through
; the window at 0x8000-0xBFFF with PPAGE set.  Never returns.
boot_start_app:
        sei                     ; interrupts stay off until the application has set IVBR
        ldd     DESC_ENTRY+1    ; A = entry[23:16], B = entry[15:8]
        lsld
        lsld                    ; A = entry[21:14]: the page
        ldx     DESC_ENTRY+2    ; X = entry[15:0]
        xgdx                    ; D = entry[15:0], X = page:junk
        anda    #0x3F           ; D = the offset in the page
        xgdx                    ; X = offset, A = page
        cmpa    #0xFF
        beq     4f
        cmpa    #0xFD
        beq     5f
        staa    PPAGE
        leax    0x8000,x
        jmp     0,x
4:      leax    0xC000,x
        jmp     0,x
5:      leax    0x4000,x
        jmp     0,x

; boot_restart: a reset through the COP (a wrong ARMCOP write resets at
; once), so the part restarts from the reset vector with its registers at
; their reset values.  Unused vectors land here too.
boot_restart:
_boot_unexpected:
        sei
        movb    #0x00, ARMCOP
        bra     boot_restart

; ---------------------------------------------------------------- flash configuration field
; global 0x7FFF00-0x7FFF0F (local 0xFF00): backdoor key, reserved, FPROT,
; EPROT, FOPT, FSEC; loaded by the part at reset.
        .section .flashcfg,"a"
        .dc.b   0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF  ; backdoor key: none
        .dc.b   0xFF, 0xFF, 0xFF, 0xFF                          ; reserved
; FPROT = 0xCF: FPOPEN=1 (the regions below are protected), RNV6=1,
; FPHDIS=0 (higher region protected), FPHS=01 (4 KiB: 0x7FF000-0x7FFFFF),
; FPLDIS=1 (no lower region), FPLS=11
        .dc.b   0xCF
        .dc.b   0xFF            ; EPROT: the emulated EEPROM unprotected
        .dc.b   0xFF            ; FOPT
        .dc.b   0xFE            ; FSEC: KEYEN=11 (backdoor off), SEC=10 (unsecured)

; ---------------------------------------------------------------- vector table
; local 0xFF10-0xFFFF (IVBR 0xFF): 120 vectors, the reset vector last; the
; loader takes no interrupts, every other vector restarts the part.
        .section .vectors,"a"
        .rept   117
        .dc.w   _boot_unexpected        ; 0xFF10 .. 0xFFF8 (spurious .. unimplemented opcode trap)
        .endr
        .dc.w   _boot_reset             ; 0xFFFA COP reset: the reset path again
        .dc.w   _boot_reset             ; 0xFFFC clock monitor reset
        .dc.w   _boot_reset             ; 0xFFFE reset
