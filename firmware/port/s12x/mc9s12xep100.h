/*
 * mc9s12xep100.h - the MC9S12XEP100 registers the probe's HAL uses, as
 * volatile lvalues at their (local) addresses in the register space.
 * Addresses and bits from the MC9S12XE family reference manual (register
 * maps of S12XINT/SCI/SPI/FTM1024K5/PIT and the port integration module).
 * Only what hal_s12x.c needs; a host compile (tests/test_s12x_port.py) keeps
 * it syntactically valid.
 */
#ifndef MC9S12XEP100_H
#define MC9S12XEP100_H

#include <stdint.h>

#define REG8(a) (*(volatile uint8_t *)(uintptr_t)(a))
#define REG16(a) (*(volatile uint16_t *)(uintptr_t)(a))

/* Ports: B (GPIO in single-chip mode), S (SCI0/SPI0 pins) */
#define PORTB REG8(0x0001u)
#define DDRB REG8(0x0003u)
#define PTS REG8(0x0248u)
#define DDRS REG8(0x024Au)

/* Memory mapping: program page register (16 KB window at 0x8000) */
#define PPAGE REG8(0x0015u)

/* SCI0 */
#define SCI0BDH REG8(0x00C8u)
#define SCI0BDL REG8(0x00C9u)
#define SCI0CR1 REG8(0x00CAu)
#define SCI0CR2 REG8(0x00CBu)
#define SCI0SR1 REG8(0x00CCu)
#define SCI0SR2 REG8(0x00CDu)
#define SCI0DRH REG8(0x00CEu)
#define SCI0DRL REG8(0x00CFu)
#define SCI_CR2_TIE 0x80u
#define SCI_CR2_RIE 0x20u
#define SCI_CR2_TE 0x08u
#define SCI_CR2_RE 0x04u
#define SCI_SR1_TDRE 0x80u
#define SCI_SR1_RDRF 0x20u
#define SCI_SR1_OR 0x08u

/* SPI0 */
#define SPI0CR1 REG8(0x00D8u)
#define SPI0CR2 REG8(0x00D9u)
#define SPI0BR REG8(0x00DAu)
#define SPI0SR REG8(0x00DBu)
#define SPI0DR REG16(0x00DCu) /* SPI0DRH:SPI0DRL, 16-bit access in XFRW mode */
#define SPI0DRL REG8(0x00DDu)
#define SPI_CR1_SPE 0x40u
#define SPI_CR1_MSTR 0x10u
#define SPI_CR1_CPOL 0x08u
#define SPI_CR1_CPHA 0x04u
#define SPI_CR2_XFRW 0x40u
#define SPI_SR_SPIF 0x80u
#define SPI_SR_SPTEF 0x20u

/* Flash module (FTM1024K5) */
#define FCLKDIV REG8(0x0100u)
#define FCCOBIX REG8(0x0102u)
#define FCNFG REG8(0x0104u)
#define FSTAT REG8(0x0106u)
#define FPROT REG8(0x0108u)
#define FCCOB REG16(0x010Au) /* FCCOBHI:FCCOBLO, selected by FCCOBIX */
#define FCLKDIV_FDIVLD 0x80u
#define FSTAT_CCIF 0x80u
#define FSTAT_ACCERR 0x20u
#define FSTAT_FPVIOL 0x10u
#define FSTAT_MGBUSY 0x08u
#define FSTAT_MGSTAT1 0x02u
#define FSTAT_MGSTAT0 0x01u
#define FTM_CMD_PROGRAM_P 0x06u      /* Program P-Flash: FCCOBIX 0..5 */
#define FTM_CMD_ERASE_P_SECTOR 0x0Au /* Erase P-Flash Sector: FCCOBIX 0..1 */

/* Periodic interrupt timer */
#define PITCFLMT REG8(0x0340u)
#define PITFLT REG8(0x0341u)
#define PITCE REG8(0x0342u)
#define PITMUX REG8(0x0343u)
#define PITINTE REG8(0x0344u)
#define PITTF REG8(0x0345u)
#define PITMTLD0 REG8(0x0346u)
#define PITLD0 REG16(0x0348u)
#define PITCNT0 REG16(0x034Au)
#define PITLD1 REG16(0x034Cu)
#define PITCNT1 REG16(0x034Eu)
#define PITCFLMT_PITE 0x80u
#define PIT_CH0 0x01u
#define PIT_CH1 0x02u

#endif /* MC9S12XEP100_H */
