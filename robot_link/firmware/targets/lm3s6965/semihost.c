/* ARM semihosting calls: operation number in r0, parameter block address in
 * r1, BKPT 0xAB (the Thumb encoding M-profile cores use), result in r0. */
#include "semihost.h"

#include <stddef.h>

enum {
  SYS_OPEN = 0x01,
  SYS_WRITE = 0x05,
  SYS_READ = 0x06,
  SYS_SEEK = 0x0A,
  SYS_FLEN = 0x0C,
  SYS_GET_CMDLINE = 0x15
};

static int32_t semihost_call(uint32_t op, void* block) {
  int32_t result;
  __asm__ volatile(
      "mov r0, %1\n\t"
      "mov r1, %2\n\t"
      "bkpt 0xAB\n\t"
      "mov %0, r0"
      : "=r"(result)
      : "r"(op), "r"(block)
      : "r0", "r1", "memory");
  return result;
}

int32_t semihost_open(const char* name, uint32_t mode) {
  uint32_t block[3];
  size_t len = 0;
  while (name[len] != '\0') ++len;
  block[0] = (uint32_t)(uintptr_t)name;
  block[1] = mode;
  block[2] = (uint32_t)len;
  return semihost_call(SYS_OPEN, block);
}

int32_t semihost_seek(int32_t handle, uint32_t pos) {
  uint32_t block[2];
  block[0] = (uint32_t)handle;
  block[1] = pos;
  return semihost_call(SYS_SEEK, block);
}

/* SYS_WRITE and SYS_READ return how many bytes were NOT transferred. */
int semihost_write(int32_t handle, const void* data, uint32_t len) {
  uint32_t block[3];
  block[0] = (uint32_t)handle;
  block[1] = (uint32_t)(uintptr_t)data;
  block[2] = len;
  return semihost_call(SYS_WRITE, block) == 0;
}

int semihost_read(int32_t handle, void* data, uint32_t len) {
  uint32_t block[3];
  block[0] = (uint32_t)handle;
  block[1] = (uint32_t)(uintptr_t)data;
  block[2] = len;
  return semihost_call(SYS_READ, block) == 0;
}

int32_t semihost_flen(int32_t handle) {
  uint32_t block[1];
  block[0] = (uint32_t)handle;
  return semihost_call(SYS_FLEN, block);
}

int semihost_get_cmdline(char* buf, uint32_t cap) {
  uint32_t block[2];
  if (cap == 0) return 0;
  block[0] = (uint32_t)(uintptr_t)buf;
  block[1] = cap; /* in: buffer size; out: length without the NUL */
  if (semihost_call(SYS_GET_CMDLINE, block) != 0) return 0;
  if (block[1] >= cap) return 0;
  buf[block[1]] = '\0';
  return 1;
}
