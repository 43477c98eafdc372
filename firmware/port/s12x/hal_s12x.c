/*
 * hal_s12x.c - the HAL (inclino/hal.h) on the MC9S12XEP100, written against
 * the MC9S12XE family reference manual: SPI0 master, SCI0 with an
 * interrupt-filled receive ring, the periodic interrupt timer for the tick
 * and the microsecond delay, and the flash command interface (FCCOBIX /
 * FCCOB / FSTAT) for P-Flash phrase programming and sector erase.
 *
 * Board (docs/firmware-app.md):
 *   SPI0 on PS4..PS7; PS7 (SS0 as GPIO) = ADIS16210 /CS; PB0 = ADS1256 /CS;
 *   PB1 = ADS1256 /DRDY input; SCI0 on PS0/PS1 at HAL_S12X_BAUD, 8N1.
 *   Clocks set by the start-up code (not part of the HAL): bus
 *   S12X_BUS_HZ (40 MHz, PLL), oscillator S12X_OSC_HZ (16 MHz, the flash
 *   clock source).
 * Linking: hal_flash_* change PPAGE and run flash commands, so they must be
 * placed in non-banked memory, in a P-Flash block other than the one being
 * programmed (the calibration slots are in block 1, the code in block 0).
 * The two ISRs go into the vector table (SCI0, PIT channel 0) through the
 * linker parameter file.
 */
#include "inclino/hal.h"
#include "mc9s12xep100.h"

#ifndef S12X_BUS_HZ
#define S12X_BUS_HZ 40000000UL
#endif
#ifndef S12X_OSC_HZ
#define S12X_OSC_HZ 16000000UL
#endif
#ifndef HAL_S12X_BAUD
#define HAL_S12X_BAUD 115200UL
#endif

/* CodeWarrior (HIWARE) marks ISRs with `interrupt`; elsewhere (the host
 * syntax check) they are plain functions. */
#if defined(__HIWARE__)
#define S12X_ISR interrupt
#else
#define S12X_ISR
#endif

#define CS_ADIS_BIT 0x80u  /* PTS7 */
#define CS_ADC_BIT 0x01u   /* PORTB0 */
#define DRDY_ADC_BIT 0x02u /* PORTB1 */

/* SPI0: 40 MHz / ((SPPR + 1) * 2^(SPR + 1)) = 40 MHz / (3 * 16) = 833 kHz */
#define SPI0BR_VALUE 0x23u
#define SPI_SPIN 2000u /* status polls per byte/word (a frame is < 1000 bus cycles) */

/* SCI0: SBR = bus / (16 * baud), rounded: 22 -> 113 636 baud (-1.4 %) */
#define SCI_SBR ((S12X_BUS_HZ + 8UL * HAL_S12X_BAUD) / (16UL * HAL_S12X_BAUD))

/* PIT: micro-timer 0 at 1 MHz; channel 0 = 1 ms tick, channel 1 = free 1 MHz */
#define PIT_MT0_LOAD ((uint8_t)(S12X_BUS_HZ / 1000000UL - 1UL))

/* Flash clock 0.8..1.05 MHz from the oscillator: FDIV = OSC / 1 MHz - 1 */
#define FCLKDIV_VALUE ((uint8_t)(S12X_OSC_HZ / 1000000UL - 1UL))
#define FTM_SPIN 0x000FFFFFUL /* polls of CCIF: > 25 ms at 40 MHz, sector erase is ~20 ms */

#define PFLASH_START 0x700000UL
#define PFLASH_END 0x800000UL

static volatile uint32_t tick_ms;
static volatile uint8_t rx_ring[HAL_SCI_RX_BUF];
static volatile uint8_t rx_head; /* written by the ISR only */
static volatile uint8_t rx_tail; /* written by hal_sci_getc only */
static volatile uint16_t rx_lost;
static volatile uint8_t tx_ring[HAL_SCI_TX_BUF];
static volatile uint8_t tx_head; /* written by hal_sci_putc only */
static volatile uint8_t tx_tail; /* written by the ISR only */
static uint8_t spi_dev = 0xFFu;

void hal_init(void)
{
    /* chip selects high, DRDY input */
    PTS = (uint8_t)(PTS | CS_ADIS_BIT);
    DDRS = (uint8_t)(DDRS | CS_ADIS_BIT);
    PORTB = (uint8_t)(PORTB | CS_ADC_BIT);
    DDRB = (uint8_t)((DDRB | CS_ADC_BIT) & (uint8_t)~DRDY_ADC_BIT);

    /* SPI0 master, software chip selects (SSOE = MODFEN = 0) */
    SPI0BR = SPI0BR_VALUE;
    SPI0CR2 = 0x00u;
    SPI0CR1 = (uint8_t)(SPI_CR1_SPE | SPI_CR1_MSTR | SPI_CR1_CPHA);

    /* SCI0 8N1, receive interrupt */
    SCI0BDH = (uint8_t)((SCI_SBR >> 8) & 0x1Fu);
    SCI0BDL = (uint8_t)(SCI_SBR & 0xFFu);
    SCI0CR1 = 0x00u;
    SCI0CR2 = (uint8_t)(SCI_CR2_TE | SCI_CR2_RE | SCI_CR2_RIE);

    /* PIT */
    PITMTLD0 = PIT_MT0_LOAD;
    PITMUX = 0x00u; /* channels 0 and 1 on micro-timer 0 */
    PITLD0 = 999u;
    PITLD1 = 0xFFFFu;
    PITCE = (uint8_t)(PIT_CH0 | PIT_CH1);
    PITINTE = PIT_CH0;
    PITTF = PIT_CH0;
    PITCFLMT = PITCFLMT_PITE;

    /* flash clock divider (write once after reset) */
    if ((FCLKDIV & FCLKDIV_FDIVLD) == 0u) {
        FCLKDIV = FCLKDIV_VALUE;
    }
}

/* ---- interrupts --------------------------------------------------------- */

S12X_ISR void hal_s12x_pit0_isr(void)
{
    PITTF = PIT_CH0; /* write 1 to clear */
    tick_ms = tick_ms + 1UL;
}

S12X_ISR void hal_s12x_sci0_isr(void)
{
    uint8_t st = SCI0SR1; /* reading SR1 then DRL clears RDRF and OR */
    if ((st & (SCI_SR1_RDRF | SCI_SR1_OR)) != 0u) {
        uint8_t b = SCI0DRL;
        uint8_t next = (uint8_t)((rx_head + 1u) % HAL_SCI_RX_BUF);
        if ((st & SCI_SR1_OR) != 0u) {
            rx_lost = (uint16_t)(rx_lost + 1u);
        }
        if ((st & SCI_SR1_RDRF) != 0u) {
            if (next == rx_tail) {
                rx_lost = (uint16_t)(rx_lost + 1u);
            } else {
                rx_ring[rx_head] = b;
                rx_head = next;
            }
        }
    }
    /* transmit: TDRE with TIE set -> next byte of the ring, or stop asking */
    if ((st & SCI_SR1_TDRE) != 0u && (SCI0CR2 & SCI_CR2_TIE) != 0u) {
        if (tx_tail != tx_head) {
            SCI0DRL = tx_ring[tx_tail];
            tx_tail = (uint8_t)((tx_tail + 1u) % HAL_SCI_TX_BUF);
        } else {
            SCI0CR2 = (uint8_t)(SCI0CR2 & (uint8_t)~SCI_CR2_TIE);
        }
    }
}

/* ---- SPI ------------------------------------------------------------------ */

void hal_spi_select(uint8_t dev)
{
    hal_spi_deselect();
    if (dev == HAL_DEV_ADIS) {
        SPI0CR1 = (uint8_t)(SPI_CR1_SPE | SPI_CR1_MSTR | SPI_CR1_CPOL | SPI_CR1_CPHA); /* mode 3 */
        SPI0CR2 = SPI_CR2_XFRW;
        PTS = (uint8_t)(PTS & (uint8_t)~CS_ADIS_BIT);
        spi_dev = dev;
    } else if (dev == HAL_DEV_ADC) {
        SPI0CR1 = (uint8_t)(SPI_CR1_SPE | SPI_CR1_MSTR | SPI_CR1_CPHA); /* mode 1 */
        SPI0CR2 = 0x00u;
        PORTB = (uint8_t)(PORTB & (uint8_t)~CS_ADC_BIT);
        spi_dev = dev;
    } else {
        spi_dev = 0xFFu;
    }
}

void hal_spi_deselect(void)
{
    PTS = (uint8_t)(PTS | CS_ADIS_BIT);
    PORTB = (uint8_t)(PORTB | CS_ADC_BIT);
    spi_dev = 0xFFu;
}

static uint8_t spi_wait(uint8_t flag)
{
    uint16_t i;
    for (i = 0u; i < SPI_SPIN; i++) {
        if ((SPI0SR & flag) != 0u) {
            return 1u;
        }
    }
    return 0u;
}

uint16_t hal_spi_xfer16(uint16_t out)
{
    if (spi_dev != HAL_DEV_ADIS || !spi_wait(SPI_SR_SPTEF)) {
        return 0xFFFFu;
    }
    SPI0DR = out;
    if (!spi_wait(SPI_SR_SPIF)) {
        return 0xFFFFu;
    }
    return SPI0DR;
}

uint8_t hal_spi_xfer8(uint8_t out)
{
    if (spi_dev != HAL_DEV_ADC || !spi_wait(SPI_SR_SPTEF)) {
        return 0xFFu;
    }
    SPI0DRL = out;
    if (!spi_wait(SPI_SR_SPIF)) {
        return 0xFFu;
    }
    return SPI0DRL;
}

uint8_t hal_adc_drdy(void)
{
    return (uint8_t)((PORTB & DRDY_ADC_BIT) != 0u);
}

/* ---- time ----------------------------------------------------------------- */

uint32_t hal_millis(void)
{
    /* a 32-bit read is two bus accesses: read until two agree (the ISR
     * runs at most once per millisecond, so the second try agrees) */
    uint32_t a = tick_ms;
    uint32_t b = tick_ms;
    uint8_t i;
    for (i = 0u; i < 4u && a != b; i++) {
        a = b;
        b = tick_ms;
    }
    return b;
}

void hal_delay_us(uint16_t us)
{
    uint16_t start = PITCNT1; /* counts down at 1 MHz */
    uint32_t bound = (uint32_t)((uint32_t)us * 64u + 64u);
    uint32_t i;
    for (i = 0u; i < bound; i++) {
        /* PITCNT1 is volatile and moves; cppcheck takes both reads as equal */
        // cppcheck-suppress unsignedLessThanZero
        if ((uint16_t)(start - PITCNT1) >= us) {
            return;
        }
    }
}

/* ---- SCI ------------------------------------------------------------------ */

int16_t hal_sci_getc(void)
{
    uint8_t b;
    if (rx_tail == rx_head) {
        return -1;
    }
    b = rx_ring[rx_tail];
    rx_tail = (uint8_t)((rx_tail + 1u) % HAL_SCI_RX_BUF);
    return (int16_t)b;
}

uint8_t hal_sci_putc(uint8_t byte)
{
    uint8_t next = (uint8_t)((tx_head + 1u) % HAL_SCI_TX_BUF);
    if (next == tx_tail) {
        return 0u; /* ring full */
    }
    tx_ring[tx_head] = byte;
    tx_head = next;
    SCI0CR2 = (uint8_t)(SCI0CR2 | SCI_CR2_TIE); /* the ISR sends it */
    return 1u;
}

/* ---- flash ---------------------------------------------------------------- */

static uint8_t ftm_wait_idle(void)
{
    uint32_t i;
    for (i = 0u; i < FTM_SPIN; i++) {
        if ((FSTAT & FSTAT_CCIF) != 0u) {
            return 1u;
        }
    }
    return 0u;
}

/* FCCOB word 0: command and global address [22:16]; word 1: address [15:0]. */
static void ftm_load_address(uint8_t cmd, uint32_t addr)
{
    FCCOBIX = 0u;
    FCCOB = (uint16_t)(((uint16_t)cmd << 8) | (uint16_t)((addr >> 16) & 0x7FUL));
    FCCOBIX = 1u;
    FCCOB = (uint16_t)(addr & 0xFFFFUL);
}

/* Launch the loaded command, wait for CCIF, map FSTAT to HAL_FLASH_*. */
static uint8_t ftm_launch(void)
{
    uint8_t st;
    FSTAT = FSTAT_CCIF; /* writing 1 to CCIF starts the command */
    if (!ftm_wait_idle()) {
        return HAL_FLASH_E_TIMEOUT;
    }
    st = FSTAT;
    if ((st & FSTAT_ACCERR) != 0u) {
        return HAL_FLASH_E_ACCESS;
    }
    if ((st & FSTAT_FPVIOL) != 0u) {
        return HAL_FLASH_E_PROTECT;
    }
    if ((st & (FSTAT_MGSTAT1 | FSTAT_MGSTAT0)) != 0u) {
        return HAL_FLASH_E_VERIFY;
    }
    return HAL_FLASH_OK;
}

/* Ready for a new command: idle, old ACCERR/FPVIOL cleared (write 1). */
static uint8_t ftm_prepare(void)
{
    if (!ftm_wait_idle()) {
        return 0u;
    }
    FSTAT = (uint8_t)(FSTAT_ACCERR | FSTAT_FPVIOL);
    return 1u;
}

uint8_t hal_flash_read(uint32_t addr, uint8_t *dst, uint16_t n)
{
    uint8_t saved = PPAGE;
    uint16_t i;
    if (addr < PFLASH_START || addr > PFLASH_END || (uint32_t)n > PFLASH_END - addr) {
        return HAL_FLASH_E_ACCESS;
    }
    for (i = 0u; i < n; i++) {
        uint32_t a = addr + i;
        /* PPAGE window 0x8000..0xBFFF shows global 0x400000 + PPAGE * 16 KB */
        PPAGE = (uint8_t)((a - 0x400000UL) >> 14);
        dst[i] = *(volatile const uint8_t *)(uintptr_t)(0x8000UL + (a & 0x3FFFUL));
    }
    PPAGE = saved;
    return HAL_FLASH_OK;
}

uint8_t hal_flash_program(uint32_t addr, const uint8_t *data)
{
    uint8_t i;
    if (!ftm_prepare()) {
        return HAL_FLASH_E_TIMEOUT;
    }
    ftm_load_address(FTM_CMD_PROGRAM_P, addr);
    for (i = 0u; i < 4u; i++) {
        FCCOBIX = (uint8_t)(2u + i);
        FCCOB = (uint16_t)(((uint16_t)data[2u * i] << 8) | data[2u * i + 1u]);
    }
    return ftm_launch();
}

uint8_t hal_flash_erase(uint32_t addr)
{
    if (!ftm_prepare()) {
        return HAL_FLASH_E_TIMEOUT;
    }
    ftm_load_address(FTM_CMD_ERASE_P_SECTOR, addr & ~(uint32_t)(HAL_FLASH_PHRASE - 1u));
    return ftm_launch();
}

/* Receive bytes lost to a full ring or an SCI overrun since reset. */
uint16_t hal_s12x_rx_lost(void)
{
    return rx_lost;
}
