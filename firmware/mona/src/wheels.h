/* The wheels: a command in per-mille of full speed -> deadband map -> PWM and direction. */
#ifndef MONA_WHEELS_H
#define MONA_WHEELS_H
#include <stdint.h>

#ifndef DEADBAND
#define DEADBAND 25  /* the smallest PWM that turns a wheel (MonaMk2's calibration, ~25/255) */
#endif
#define FULL_SPEED 1000

void wheels_init(void);
uint8_t wheels_pwm(int16_t command);     /* the deadband map: 0 -> 0, else DEADBAND..255 */
void wheels_set(int16_t left, int16_t right);
void wheels_stop(void);
#endif
