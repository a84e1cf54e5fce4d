#include "storage_eeprom.h"

#include <avr/eeprom.h>
#include <stdint.h>

/* The whole storage area must exist on the part (1 KiB on the ATmega328P). */
typedef char storage_fits_in_eeprom[(OLF_STORAGE_SIZE <= (uint32_t)E2END + 1u) ? 1 : -1];

static int in_range(uint32_t offset, uint32_t len) {
  return offset <= OLF_STORAGE_SIZE && len <= OLF_STORAGE_SIZE - offset;
}

static int eeprom_read(void* user, uint32_t offset, uint8_t* data, uint32_t len) {
  (void)user;
  if (!in_range(offset, len)) return 0;
  eeprom_read_block(data, (const void*)(uintptr_t)offset, (size_t)len);
  return 1;
}

/* Byte by byte, in order, each one finished before the next starts (about
 * 3.3 ms per changed byte on the real part; eeprom_update_byte skips bytes
 * that already hold the value). A reset in the middle leaves a prefix of the
 * record written: exactly the case the library's slot + CRC scheme covers.
 * Every byte is read back, so a worn cell reports a failure instead of a
 * record that will not survive the next boot. */
static int eeprom_write(void* user, uint32_t offset, const uint8_t* data, uint32_t len) {
  uint32_t i;
  (void)user;
  if (!in_range(offset, len)) return 0;
  for (i = 0; i < len; ++i) {
    uint8_t* const address = (uint8_t*)(uintptr_t)(offset + i);
    eeprom_update_byte(address, data[i]);
    if (eeprom_read_byte(address) != data[i]) return 0;
  }
  return 1;
}

olf_storage_t storage_eeprom(void) {
  olf_storage_t s;
  s.read = eeprom_read;
  s.write = eeprom_write;
  s.user = 0;
  return s;
}
