/* The classic Mona's pins (Arduino Pro Mini numbering in comments), as the public example
 * sketches use them: docs/link.md, "Pins", cites where each comes from. */
#ifndef MONA_PINS_H
#define MONA_PINS_H

#include <avr/io.h>

/* Wheels: PWM on Timer1's outputs, one direction bit each (0 forward, 1 reverse). */
#define LEFT_PWM_OCR   OCR1A   /* D9  = PB1 = OC1A */
#define RIGHT_PWM_OCR  OCR1B   /* D10 = PB2 = OC1B */
#define PWM_DDR        DDRB
#define LEFT_PWM_BIT   PB1
#define RIGHT_PWM_BIT  PB2
#define DIR_PORT       PORTD
#define DIR_DDR        DDRD
#define LEFT_DIR_BIT   PD6     /* D6 */
#define RIGHT_DIR_BIT  PD5     /* D5 */

/* IR: an enable line and five ADC channels, right to left (the order of telemetry). */
#define IR_EN_PORT     PORTD
#define IR_EN_DDR      DDRD
#define IR_EN_BIT      PD4     /* D4 */
#define IR_CHANNELS    {3, 2, 1, 0, 7}  /* A3 right, A2 right-front, A1 front, A0 left-front,
                                           A7 left */
#define BATTERY_CHANNEL 6      /* A6: MonaMk2's battery input; unverified on the classic Mona */

/* Encoders: single channel, on the external interrupts, both edges counted. */
#define ENC_PORT_IN    PIND
#define ENC_PORT       PORTD
#define LEFT_ENC_BIT   PD2     /* D2 = INT0 */
#define RIGHT_ENC_BIT  PD3     /* D3 = INT1 */

/* The cleaner has no actuator on a Mona: its bit lights the top LED, for the camera. */
#define CLEANER_PORT   PORTB
#define CLEANER_DDR    DDRB
#define CLEANER_BIT    PB5     /* D13, LED1 */

#endif
