#include "clock.h"

#include <avr/interrupt.h>
#include <avr/io.h>
#include <util/atomic.h>

static volatile uint16_t ticks;

void clock_init(void)
{
    /* CTC, F_CPU/64 = 125 kHz, 125 counts: 1 kHz at 8 MHz */
    TCCR2A = _BV(WGM21);
    TCCR2B = _BV(CS22);
    OCR2A = (uint8_t)(F_CPU / 64 / 1000 - 1);
    TIMSK2 = _BV(OCIE2A);
}

ISR(TIMER2_COMPA_vect)
{
    ticks++;
}

uint16_t clock_ms(void)
{
    uint16_t now;
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { now = ticks; }
    return now;
}
