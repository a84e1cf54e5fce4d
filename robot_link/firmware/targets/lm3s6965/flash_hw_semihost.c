/* Flash backend for QEMU: the storage region is a host file, one byte per
 * flash byte (file offset = address - FLASH_PARAMS_BASE), read and written
 * through ARM semihosting. Every erase and program is a host write() on the
 * file right away (QEMU's native semihosting does not buffer), so killing
 * QEMU mid-operation is a power cut: what reached the file stays, nothing
 * else.
 *
 * Which file: the semihosting command line (QEMU option
 * -semihosting-config enable=on,target=native,arg=odolink,arg=IMAGE), i.e.
 * everything after the first word; without an argument, "odolink_flash.img"
 * in QEMU's working directory. A missing file is created; a short one
 * (fresh) is extended with 0xFF, the erased state.
 *
 * For power-cut tests the command line may carry "flash_delay_ms=N" before
 * the image ("odolink flash_delay_ms=5 IMAGE"): every page erase and every
 * word program then takes N ms more, as if the flash were slow, so that a
 * kill at a random moment often lands in the middle of a record. */
#include <string.h>

#include "bsp.h"
#include "flash_hw.h"
#include "semihost.h"

#define DEFAULT_IMAGE "odolink_flash.img"

#define DELAY_OPTION "flash_delay_ms="

static int32_t g_handle = -1;
static uint32_t g_delay_ms;

static void slow_flash(void) {
  const uint32_t start = bsp_millis();
  while (bsp_millis() - start < g_delay_ms) {
  }
}

static int fill_erased(uint32_t offset, uint32_t len) {
  uint8_t ff[128];
  memset(ff, 0xFF, sizeof ff);
  if (semihost_seek(g_handle, offset) != 0) return 0;
  while (len > 0) {
    const uint32_t n = len < sizeof ff ? len : (uint32_t)sizeof ff;
    if (!semihost_write(g_handle, ff, n)) return 0;
    len -= n;
  }
  return 1;
}

int flash_hw_init(void) {
  static char cmdline[256];
  const char* name = DEFAULT_IMAGE;
  int32_t flen;
  if (semihost_get_cmdline(cmdline, sizeof cmdline)) {
    const char* rest = strchr(cmdline, ' ');
    if (rest != NULL && strncmp(rest + 1, DELAY_OPTION, strlen(DELAY_OPTION)) == 0) {
      rest += 1 + strlen(DELAY_OPTION);
      while (*rest >= '0' && *rest <= '9') g_delay_ms = g_delay_ms * 10u + (uint32_t)(*rest++ - '0');
      if (*rest != ' ') rest = NULL;
    }
    if (rest != NULL && rest[1] != '\0') name = rest + 1;
  }
  g_handle = semihost_open(name, SEMIHOST_MODE_RPLUS_B);
  if (g_handle < 0) g_handle = semihost_open(name, SEMIHOST_MODE_WPLUS_B);
  if (g_handle < 0) return 0;
  flen = semihost_flen(g_handle);
  if (flen < 0) return 0;
  if ((uint32_t)flen < FLASH_PARAMS_SIZE) {
    return fill_erased((uint32_t)flen, FLASH_PARAMS_SIZE - (uint32_t)flen);
  }
  return 1;
}

int flash_hw_erase_page(uint32_t page_addr) {
  if (g_handle < 0) return 0;
  slow_flash();
  return fill_erased(page_addr - FLASH_PARAMS_BASE, 1024u);
}

int flash_hw_program_word(uint32_t addr, uint32_t word) {
  uint8_t cell[4];
  uint32_t old;
  const uint32_t offset = addr - FLASH_PARAMS_BASE;
  if (g_handle < 0) return 0;
  slow_flash();
  if (semihost_seek(g_handle, offset) != 0 || !semihost_read(g_handle, cell, 4)) return 0;
  /* NOR flash physics: programming only pulls bits from 1 to 0. */
  old = (uint32_t)cell[0] | ((uint32_t)cell[1] << 8) | ((uint32_t)cell[2] << 16) |
        ((uint32_t)cell[3] << 24);
  word &= old;
  cell[0] = (uint8_t)word;
  cell[1] = (uint8_t)(word >> 8);
  cell[2] = (uint8_t)(word >> 16);
  cell[3] = (uint8_t)(word >> 24);
  if (semihost_seek(g_handle, offset) != 0) return 0;
  return semihost_write(g_handle, cell, 4);
}

int flash_hw_read(uint32_t addr, uint8_t* out, uint32_t len) {
  if (g_handle < 0) return 0;
  if (semihost_seek(g_handle, addr - FLASH_PARAMS_BASE) != 0) return 0;
  return semihost_read(g_handle, out, len);
}
