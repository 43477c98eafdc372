; c_standin.s - TEST ONLY.  Stand-ins for the C functions the S12X start-up
; calls, so that the start-up code links without an S12X C compiler (Debian
; has none).  They are not the firmware: each returns at once.  The tests
; check the start-up's own code and its placement, never these.
        .sect   .text
        .globl  boot_select, boot_main_init, boot_main_poll, boot_main_restart_requested
        .globl  main, hal_s12x_pit0_isr, hal_s12x_sci0_isr
boot_select:
boot_main_init:
boot_main_poll:
boot_main_restart_requested:
main:
        clrb
        rts
hal_s12x_pit0_isr:
hal_s12x_sci0_isr:
        rti
        .sect   .data
standin_data:
        .dc.b   1, 2, 3, 4      ; an initialised variable: .data gets an image in flash
        .sect   .bss
standin_bss:
        .ds.b   16
