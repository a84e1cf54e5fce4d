/* The three flash operations the parameter storage is built on. This is the
 * whole hardware dependence of bsp_storage.c: a port to another part, or a
 * board with an external EEPROM, replaces these three functions (plus init).
 *
 *   flash_hw_semihost.c  QEMU: the storage pages live in a host file, reached
 *                        through ARM semihosting (the default build).
 *   flash_hw_fmc.c       the LM3S6965 flash memory controller; written from
 *                        the datasheet, UNTESTED (QEMU does not emulate flash
 *                        writes and no board was at hand).
 *
 * Addresses are absolute flash addresses inside the storage region that
 * lm3s6965.ld reserves (__params_start .. __params_end). The backend behaves
 * like NOR flash: erase sets a whole page to 0xFF, programming a word can only
 * clear bits (the result is old AND new). bsp_storage.c checks alignment and
 * bounds before calling, so backends may assume valid arguments. */
#ifndef ODOLINK_LM3S6965_FLASH_HW_H_
#define ODOLINK_LM3S6965_FLASH_HW_H_

#include <stdint.h>

/* The storage region, from lm3s6965.ld: two 1 KB pages. */
extern const uint8_t __params_start[];
extern const uint8_t __params_end[];
#define FLASH_PARAMS_BASE ((uint32_t)(uintptr_t)__params_start)
#define FLASH_PARAMS_SIZE ((uint32_t)(__params_end - __params_start))

/* All return 1 on success, 0 on failure. */
int flash_hw_init(void);
int flash_hw_erase_page(uint32_t page_addr);           /* 1 KB aligned */
int flash_hw_program_word(uint32_t addr, uint32_t word); /* 4-byte aligned */
int flash_hw_read(uint32_t addr, uint8_t* out, uint32_t len);

#endif /* ODOLINK_LM3S6965_FLASH_HW_H_ */
