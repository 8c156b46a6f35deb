#include "nonce.h"

#include <avr/eeprom.h>

#define NONCE_ADDRESS ((uint16_t *)0)

uint16_t nonce_boot(void)
{
    /* a fresh (erased) EEPROM reads 0xFFFF: the first boot is 0. 100k writes of endurance
     * are 100k boots. */
    uint16_t nonce = (uint16_t)(eeprom_read_word(NONCE_ADDRESS) + 1);
    eeprom_update_word(NONCE_ADDRESS, nonce);
    return nonce;
}
