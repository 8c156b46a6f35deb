#include "wheels.h"

#include <avr/io.h>

#include "pins.h"

void wheels_init(void)
{
    DIR_PORT &= (uint8_t)~(_BV(LEFT_DIR_BIT) | _BV(RIGHT_DIR_BIT));
    DIR_DDR |= _BV(LEFT_DIR_BIT) | _BV(RIGHT_DIR_BIT);
    LEFT_PWM_OCR = 0;
    RIGHT_PWM_OCR = 0;
    /* 8-bit phase-correct PWM, non-inverting on OC1A/OC1B, F_CPU/64: 245 Hz at 8 MHz, what
     * the example sketches' analogWrite gives on these pins (OCR 0 holds the pin low). */
    TCCR1A = _BV(COM1A1) | _BV(COM1B1) | _BV(WGM10);
    TCCR1B = _BV(CS11) | _BV(CS10);
    PWM_DDR |= _BV(LEFT_PWM_BIT) | _BV(RIGHT_PWM_BIT);
}

uint8_t wheels_pwm(int16_t command)
{
    uint16_t magnitude = command < 0 ? (uint16_t)(-command) : (uint16_t)command;
    if (magnitude == 0)
        return 0;
    if (magnitude > FULL_SPEED)
        magnitude = FULL_SPEED;
    /* rounded: 1 -> DEADBAND, 1000 -> 255 */
    return (uint8_t)(DEADBAND + ((uint32_t)magnitude * (255 - DEADBAND) + FULL_SPEED / 2)
                     / FULL_SPEED);
}

/* Sets the direction bit; the PWM for the 16-bit OCR register (written whole, so its
 * high byte stays 0 in 8-bit mode) */
static uint8_t direction(uint8_t dir_bit, int16_t command)
{
    if (command < 0)
        DIR_PORT |= _BV(dir_bit);
    else
        DIR_PORT &= (uint8_t)~_BV(dir_bit);
    return wheels_pwm(command);
}

void wheels_set(int16_t left, int16_t right)
{
    LEFT_PWM_OCR = direction(LEFT_DIR_BIT, left);
    RIGHT_PWM_OCR = direction(RIGHT_DIR_BIT, right);
}

void wheels_stop(void)
{
    wheels_set(0, 0);
}
