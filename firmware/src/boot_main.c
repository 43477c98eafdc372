/* boot_main.c - the bootloader's main loop; contract in boot_main.h. */
#include "inclino/boot_main.h"
#include "inclino/boot.h"
#include "inclino/hal.h"

static boot_t boot;
static uint8_t txq[BOOT_TX_QUEUE];
static uint16_t tx_head, tx_len;
static uint32_t tx_dropped;
static uint32_t last_rx_ms;

static void send(const uint8_t *data, uint16_t n)
{
    uint16_t i;
    if ((uint16_t)(BOOT_TX_QUEUE - tx_len) < n) {
        tx_dropped += n; /* whole answers or nothing: never half a frame */
        return;
    }
    for (i = 0u; i < n; i++) {
        txq[(uint16_t)(tx_head + tx_len) % BOOT_TX_QUEUE] = data[i];
        tx_len++;
    }
}

static void tx_drain(void)
{
    while (tx_len != 0u && hal_sci_putc(txq[tx_head]) != 0u) {
        tx_head = (uint16_t)((tx_head + 1u) % BOOT_TX_QUEUE);
        tx_len--;
    }
}

uint8_t boot_main_init(void)
{
    hal_init();
    tx_head = 0u;
    tx_len = 0u;
    tx_dropped = 0u;
    boot_init(&boot, send);
    last_rx_ms = hal_millis();
    return boot.app_status;
}

void boot_main_poll(void)
{
    uint8_t buf[16];
    uint16_t n = 0u;
    int16_t c;
    uint32_t now;

    /* after RESET or RUN was answered, take no more bytes: the probe restarts */
    while (boot_after(&boot) == BOOT_AFTER_NONE && n < (uint16_t)sizeof buf &&
           (c = hal_sci_getc()) >= 0) {
        buf[n++] = (uint8_t)c;
    }
    now = hal_millis();
    if (n != 0u) {
        last_rx_ms = now;
        boot_rx(&boot, buf, n);
    } else if ((uint32_t)(now - last_rx_ms) >= PROTO_IDLE_MS) {
        boot_idle(&boot);
        last_rx_ms = now;
    }
    tx_drain();
}

uint32_t boot_main_tx_dropped(void)
{
    return tx_dropped;
}

uint8_t boot_main_restart_requested(void)
{
    return (tx_len == 0u) ? boot_after(&boot) : 0u; /* only once the answer has gone out */
}
