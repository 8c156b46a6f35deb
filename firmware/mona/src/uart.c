#include "uart.h"

#include <avr/interrupt.h>
#include <avr/io.h>

#ifndef BAUD
#define BAUD 57600
#endif
/* 57600 at 8 MHz is 2.1 % fast even with U2X (UBRR 16 -> 58824 bps): docs/link.md. */
#define BAUD_TOL 3
#include <util/setbaud.h>

#define RX_SIZE 64  /* powers of two: the indices wrap by masking */
#define TX_SIZE 64

static volatile uint8_t rx[RX_SIZE], tx[TX_SIZE];
static volatile uint8_t rx_head, rx_tail, tx_head, tx_tail, overruns;

void uart_init(void)
{
    /* U2X before UBRR: simavr computes the bit time when UBRR is written */
#if USE_2X
    UCSR0A = _BV(U2X0);
#else
    UCSR0A = 0;
#endif
    UBRR0H = UBRRH_VALUE;
    UBRR0L = UBRRL_VALUE;
    UCSR0C = _BV(UCSZ01) | _BV(UCSZ00);
    UCSR0B = _BV(RXEN0) | _BV(TXEN0) | _BV(RXCIE0);
}

ISR(USART_RX_vect)
{
    uint8_t status = UCSR0A;
    uint8_t byte = UDR0;
    uint8_t next = (rx_head + 1) & (RX_SIZE - 1);
    if ((status & _BV(DOR0)) || next == rx_tail) {
        overruns++;
        if (next == rx_tail)
            return;
    }
    rx[rx_head] = byte;
    rx_head = next;
}

ISR(USART_UDRE_vect)
{
    if (tx_head == tx_tail) {
        UCSR0B &= (uint8_t)~_BV(UDRIE0);
        return;
    }
    UDR0 = tx[tx_tail];
    tx_tail = (tx_tail + 1) & (TX_SIZE - 1);
}

int16_t uart_read(void)
{
    if (rx_head == rx_tail)
        return -1;
    uint8_t byte = rx[rx_tail];
    rx_tail = (rx_tail + 1) & (RX_SIZE - 1);
    return byte;
}

void uart_write(const uint8_t *data, uint8_t n)
{
    while (n--) {
        uint8_t next = (tx_head + 1) & (TX_SIZE - 1);
        while (next == tx_tail)
            ;  /* full: the UDRE interrupt drains it */
        tx[tx_head] = *data++;
        tx_head = next;
        UCSR0B |= _BV(UDRIE0);
    }
}

uint8_t uart_overruns(void)
{
    return overruns;
}
