/* The parameter table, canonical serialization and the two-slot storage
 * records. */
#include <stddef.h>
#include <string.h>

#include "odolink/olf.h"
#include "olf_internal.h"

static const olf_param_desc_t kTable[OLF_PARAM_COUNT] = {
    /* Ranges reject what no differential-drive robot odocal targets could
     * have and, importantly, NaN and infinities from a corrupted host. */
    {"left_wheel_diameter_mm", OLF_TYPE_F64, offsetof(olf_params_t, left_wheel_diameter_mm), 1.0,
     2000.0},
    {"right_wheel_diameter_mm", OLF_TYPE_F64, offsetof(olf_params_t, right_wheel_diameter_mm), 1.0,
     2000.0},
    {"track_mm", OLF_TYPE_F64, offsetof(olf_params_t, track_mm), 10.0, 10000.0},
    {"ticks_per_rev", OLF_TYPE_U32, offsetof(olf_params_t, ticks_per_rev), 1.0, 16777216.0},
};

const olf_param_desc_t* olf_param_table(void) { return kTable; }

int olf_param_find(const char* name, size_t len) {
  unsigned i;
  for (i = 0; i < OLF_PARAM_COUNT; ++i) {
    if (strlen(kTable[i].name) == len && memcmp(kTable[i].name, name, len) == 0) return (int)i;
  }
  return -1;
}

size_t olf_param_size(uint8_t type) { return type == OLF_TYPE_F64 ? 8u : 4u; }

size_t olf_param_put(const olf_params_t* params, unsigned index, uint8_t* out) {
  const olf_param_desc_t* d = &kTable[index];
  const unsigned char* field = (const unsigned char*)params + d->offset;
  if (d->type == OLF_TYPE_F64) {
    olf_f64_t v;
    memcpy(&v, field, sizeof v);
    olf_put_f64(out, v);
    return 8;
  } else {
    uint32_t v;
    memcpy(&v, field, sizeof v);
    olf_put_u32(out, v);
    return 4;
  }
}

int olf_param_from_wire(unsigned index, const uint8_t* in, olf_params_t* params) {
  const olf_param_desc_t* d = &kTable[index];
  unsigned char* field = (unsigned char*)params + d->offset;
  if (d->type == OLF_TYPE_F64) {
    const olf_f64_t v = olf_get_f64(in);
    if (!olf_f64_in_range(v, d->min_value, d->max_value)) return 0;
    memcpy(field, &v, sizeof v);
  } else {
    /* In integers: a 32-bit double (AVR) rounds 16777217 down to 2^24. */
    const uint32_t v = olf_get_u32(in);
    if (v < (uint32_t)d->min_value || v > (uint32_t)d->max_value) return 0;
    memcpy(field, &v, sizeof v);
  }
  return 1;
}

void olf_params_serialize(const olf_params_t* params, uint8_t* out) {
  unsigned i;
  size_t at = 0;
  for (i = 0; i < OLF_PARAM_COUNT; ++i) at += olf_param_put(params, i, out + at);
}

void olf_params_deserialize(const uint8_t* in, olf_params_t* params) {
  unsigned i;
  size_t at = 0;
  memset(params, 0, sizeof *params);
  for (i = 0; i < OLF_PARAM_COUNT; ++i) {
    const olf_param_desc_t* d = &kTable[i];
    unsigned char* field = (unsigned char*)params + d->offset;
    if (d->type == OLF_TYPE_F64) {
      const olf_f64_t v = olf_get_f64(in + at);
      memcpy(field, &v, sizeof v);
      at += 8;
    } else {
      uint32_t v = olf_get_u32(in + at);
      memcpy(field, &v, sizeof v);
      at += 4;
    }
  }
}

uint32_t olf_params_crc(const olf_params_t* params) {
  uint8_t bytes[OLF_PARAMS_SERIALIZED_SIZE];
  olf_params_serialize(params, bytes);
  return olf_crc32(bytes, sizeof bytes);
}

uint32_t olf_param_table_crc(void) {
  /* Names with their NUL and the type byte, in table order. */
  uint32_t crc = OLF_CRC32_START;
  unsigned i;
  for (i = 0; i < OLF_PARAM_COUNT; ++i) {
    crc = olf_crc32_update(crc, (const uint8_t*)kTable[i].name, strlen(kTable[i].name) + 1);
    crc = olf_crc32_update(crc, &kTable[i].type, 1);
  }
  return olf_crc32_finish(crc);
}

int olf_params_valid(const olf_params_t* params) {
  uint8_t bytes[OLF_PARAMS_SERIALIZED_SIZE];
  olf_params_t scratch;
  unsigned i;
  size_t at = 0;
  olf_params_serialize(params, bytes);
  for (i = 0; i < OLF_PARAM_COUNT; ++i) {
    if (!olf_param_from_wire(i, bytes + at, &scratch)) return 0;
    at += olf_param_size(kTable[i].type);
  }
  return 1;
}

/* Storage record, OLF_STORAGE_RECORD_SIZE bytes:
 *   magic u32 "ODOP", generation u32, format u8 (1), has_previous u8,
 *   active set (28 B), previous set (28 B), crc32 u32 of everything before. */
#define OLF_RECORD_MAGIC 0x504F444Fu
#define OLF_RECORD_FORMAT 1u

void olf_record_build(uint32_t generation, const olf_params_t* active, const olf_params_t* previous,
                      int has_previous, uint8_t* out) {
  olf_put_u32(out, OLF_RECORD_MAGIC);
  olf_put_u32(out + 4, generation);
  out[8] = OLF_RECORD_FORMAT;
  out[9] = has_previous ? 1u : 0u;
  olf_params_serialize(active, out + 10);
  if (has_previous) {
    olf_params_serialize(previous, out + 10 + OLF_PARAMS_SERIALIZED_SIZE);
  } else {
    memset(out + 10 + OLF_PARAMS_SERIALIZED_SIZE, 0, OLF_PARAMS_SERIALIZED_SIZE);
  }
  olf_put_u32(out + OLF_STORAGE_RECORD_SIZE - 4, olf_crc32(out, OLF_STORAGE_RECORD_SIZE - 4));
}

int olf_record_parse(const uint8_t* in, uint32_t* generation, olf_params_t* active,
                     olf_params_t* previous, int* has_previous) {
  if (olf_get_u32(in) != OLF_RECORD_MAGIC) return 0;
  if (in[8] != OLF_RECORD_FORMAT || in[9] > 1) return 0;
  if (olf_crc32(in, OLF_STORAGE_RECORD_SIZE - 4) != olf_get_u32(in + OLF_STORAGE_RECORD_SIZE - 4)) {
    return 0;
  }
  *generation = olf_get_u32(in + 4);
  olf_params_deserialize(in + 10, active);
  *has_previous = in[9];
  if (*has_previous) olf_params_deserialize(in + 10 + OLF_PARAMS_SERIALIZED_SIZE, previous);
  /* A record that passes its CRC but holds values outside the table (a
   * firmware with different ranges wrote it) is not trusted either. */
  if (!olf_params_valid(active)) return 0;
  if (*has_previous && !olf_params_valid(previous)) *has_previous = 0;
  return 1;
}
