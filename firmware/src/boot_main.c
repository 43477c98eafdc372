/* boot_main.c - the bootloader's main loop; contract in boot_main.h. */
#include "inclino/boot_main.h"
#include "inclino/boot.h"
#include "inclino/hal.h"
#include "inclino/tx_queue.h"

static boot_t boot;
static uint8_t txq_buf[BOOT_TX_QUEUE];
static tx_queue_t txq;
static uint32_t last_rx_ms;

static void send(const uint8_t *data, uint16_t n)
{
    tx_queue_put(&txq, data, n);
}

uint8_t boot_main_init(void)
{
    hal_init();
    tx_queue_init(&txq, txq_buf, (uint16_t)BOOT_TX_QUEUE);
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
    tx_queue_drain(&txq);
}

uint32_t boot_main_tx_dropped(void)
{
    return txq.dropped;
}

uint8_t boot_main_restart_requested(void)
{
    return (txq.len == 0u) ? boot_after(&boot) : 0u; /* only once the answer has gone out */
}
