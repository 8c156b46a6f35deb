#include "sensors.h"

#include <avr/interrupt.h>
#include <avr/io.h>
#include <util/atomic.h>

#include "pins.h"

static volatile uint16_t left_ticks, right_ticks;
static const uint8_t ir_channels[IR_COUNT] = IR_CHANNELS;

void sensors_init(void)
{
    IR_EN_DDR |= _BV(IR_EN_BIT);
    IR_EN_PORT |= _BV(IR_EN_BIT);
    /* AVcc reference, ADC clock F_CPU/64 = 125 kHz (50-200 kHz for 10 bits) */
    ADMUX = _BV(REFS0);
    ADCSRA = _BV(ADEN) | _BV(ADPS2) | _BV(ADPS1);
    /* encoder inputs with pull-ups, an interrupt on every edge */
    ENC_PORT |= _BV(LEFT_ENC_BIT) | _BV(RIGHT_ENC_BIT);
    EICRA = _BV(ISC00) | _BV(ISC10);
    EIFR = _BV(INTF0) | _BV(INTF1);
    EIMSK = _BV(INT0) | _BV(INT1);
}

ISR(INT0_vect)
{
    left_ticks++;
}

ISR(INT1_vect)
{
    right_ticks++;
}

static uint16_t convert(void)
{
    ADCSRA |= _BV(ADSC);
    while (ADCSRA & _BV(ADSC))
        ;
    return ADC;
}

static uint16_t read_channel(uint8_t channel)
{
    ADMUX = _BV(REFS0) | (channel & 0x0F);
    (void)convert();  /* the first conversion after a mux change settles the sample cap */
    return convert();
}

void sensors_ir(uint16_t ir[IR_COUNT])
{
    for (uint8_t i = 0; i < IR_COUNT; i++)
        ir[i] = read_channel(ir_channels[i]);
}

uint16_t sensors_battery_mv(void)
{
    return (uint16_t)((uint32_t)read_channel(BATTERY_CHANNEL) * AVCC_MV * BATTERY_DIVIDER
                      / 1024);
}

void sensors_ticks(uint16_t *left, uint16_t *right)
{
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
        *left = left_ticks;
        *right = right_ticks;
    }
}
