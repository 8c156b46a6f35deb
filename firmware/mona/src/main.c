/* Firmware of the classic Mona (ATmega328P, 8 MHz) for the link of docs/link.md: wheel
 * commands in, telemetry out every TELEMETRY_MS, wheels stopped when no valid command came
 * for WATCHDOG_MS. */
#include <avr/interrupt.h>
#include <avr/io.h>

#include "clock.h"
#include "link.h"
#include "nonce.h"
#include "pins.h"
#include "sensors.h"
#include "uart.h"
#include "wheels.h"

#ifndef ROBOT_ID
#define ROBOT_ID 1
#endif
#define WATCHDOG_MS 150
#define TELEMETRY_MS 50

static uint16_t boot_nonce, telemetry_seq;
static uint16_t last_command_ms;
static uint16_t host_nonce, host_seq, ack;
static uint8_t have_host, stopped = 1, cleaning;

static void set_cleaner(uint8_t on)
{
    cleaning = on;
    if (on)
        CLEANER_PORT |= _BV(CLEANER_BIT);
    else
        CLEANER_PORT &= (uint8_t)~_BV(CLEANER_BIT);
}

/* A command is applied if it is newer than the last one of the same host boot; an old or
 * duplicated one (a late radio frame) is ignored and does not feed the watchdog. */
static void apply(const link_command_t *c)
{
    if (c->robot != ROBOT_ID && c->robot != LINK_BROADCAST)
        return;
    if (have_host && c->nonce == host_nonce && (int16_t)(c->seq - host_seq) <= 0)
        return;
    have_host = 1;
    host_nonce = c->nonce;
    host_seq = ack = c->seq;
    last_command_ms = clock_ms();
    stopped = 0;
    wheels_set(c->left, c->right);
    set_cleaner(c->flags & LINK_CLEANER);
}

static void send_telemetry(void)
{
    link_telemetry_t t;
    uint8_t buf[LINK_HEADER + LINK_TELEMETRY_SIZE + 2];
    sensors_ir(t.ir);
    sensors_ticks(&t.left_ticks, &t.right_ticks);
    t.battery_mv = sensors_battery_mv();
    t.ack = ack;
    t.flags = (uint8_t)((stopped ? LINK_STOPPED : 0) | (cleaning ? LINK_CLEANING : 0));
    t.rx_rejected = link_rejected();
    uint8_t n = link_telemetry(buf, ROBOT_ID, telemetry_seq++, boot_nonce, &t);
    uart_write(buf, n);
}

int main(void)
{
    CLEANER_DDR |= _BV(CLEANER_BIT);
    set_cleaner(0);
    wheels_init();
    sensors_init();
    clock_init();
    uart_init();
    boot_nonce = nonce_boot();
    sei();

    uint16_t last_telemetry_ms = clock_ms();
    link_command_t command;
    for (;;) {
        int16_t byte;
        while ((byte = uart_read()) >= 0) {
            if (!link_receive((uint8_t)byte, &command))
                continue;
            do
                apply(&command);
            while (link_next(&command));
        }
        uint16_t now = clock_ms();
        /* "> WATCHDOG_MS" ticks: at least WATCHDOG_MS whole milliseconds have passed */
        if (!stopped && (uint16_t)(now - last_command_ms) > WATCHDOG_MS) {
            stopped = 1;
            wheels_stop();
            set_cleaner(0);
        }
        if ((uint16_t)(now - last_telemetry_ms) >= TELEMETRY_MS) {
            last_telemetry_ms += TELEMETRY_MS;
            send_telemetry();
        }
    }
}
