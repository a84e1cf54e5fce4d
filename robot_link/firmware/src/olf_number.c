/* Numbers on the wire: little-endian integers, and IEEE-754 binary64 on any
 * target. Where `double` is binary64 a value's bits are copied; where it is 32
 * bits (OLF_SOFT_F64) the wire bytes are the value, and the two conversions
 * below are the only place a float meets them. All arithmetic is on 32-bit
 * halves (an 8-bit CPU pays dearly for 64-bit shifts), and every shift is on a
 * type wide enough for it: `int` may be 16 bits. */
#include <string.h>

#include "odolink/olf.h"
#include "olf_internal.h"

void olf_put_u16(uint8_t* out, uint16_t v) {
  out[0] = (uint8_t)v;
  out[1] = (uint8_t)(v >> 8);
}

void olf_put_u32(uint8_t* out, uint32_t v) {
  out[0] = (uint8_t)v;
  out[1] = (uint8_t)(v >> 8);
  out[2] = (uint8_t)(v >> 16);
  out[3] = (uint8_t)(v >> 24);
}

uint16_t olf_get_u16(const uint8_t* in) { return (uint16_t)((uint16_t)in[0] | ((uint16_t)in[1] << 8)); }

uint32_t olf_get_u32(const uint8_t* in) {
  return (uint32_t)in[0] | ((uint32_t)in[1] << 8) | ((uint32_t)in[2] << 16) | ((uint32_t)in[3] << 24);
}

/* A binary64 value as its two 32-bit halves. */
typedef struct {
  uint32_t hi; /* sign, 11 exponent bits, the top 20 fraction bits */
  uint32_t lo; /* the low 32 fraction bits */
} f64_words_t;

#define HI_SIGN 0x80000000u
#define HI_EXP 0x7FF00000u
#define HI_FRAC 0x000FFFFFu

static void words_put(uint8_t* out, f64_words_t w) {
  olf_put_u32(out, w.lo);
  olf_put_u32(out + 4, w.hi);
}

static f64_words_t words_get(const uint8_t* in) {
  f64_words_t w;
  w.lo = olf_get_u32(in);
  w.hi = olf_get_u32(in + 4);
  return w;
}

#if OLF_SOFT_F64

static uint32_t float_bits(float f) {
  uint32_t b;
  memcpy(&b, &f, sizeof b);
  return b;
}

static float float_from_bits(uint32_t b) {
  float f;
  memcpy(&f, &b, sizeof f);
  return f;
}

/* binary64 -> binary32, round to nearest, ties to even. */
static uint32_t words_to_f32_bits(f64_words_t w) {
  const uint32_t sign = w.hi & HI_SIGN;
  const int16_t exp64 = (int16_t)((w.hi & HI_EXP) >> 20);
  int16_t exp32;
  uint32_t kept;
  uint8_t guard;
  uint8_t sticky;
  if (exp64 == 0x7FF) { /* infinity, or NaN kept quiet */
    return sign | 0x7F800000u | (((w.hi & HI_FRAC) | w.lo) != 0 ? 0x00400000u : 0u);
  }
  if (exp64 == 0) return sign; /* zero, or a binary64 subnormal: far below float */
  exp32 = (int16_t)(exp64 - 1023 + 127);
  if (exp32 >= 0xFF) return sign | 0x7F800000u;
  /* The top 24 of the 53 significand bits; the 29 below decide the rounding. */
  kept = (((w.hi & HI_FRAC) | 0x00100000u) << 3) | (w.lo >> 29);
  guard = (uint8_t)((w.lo >> 28) & 1u);
  sticky = (uint8_t)((w.lo & 0x0FFFFFFFu) != 0);
  if (exp32 <= 0) { /* a float subnormal keeps fewer bits */
    const uint8_t extra = (uint8_t)(1 - exp32);
    if (extra > 25u) return sign; /* below half the smallest subnormal */
    sticky = (uint8_t)(sticky || guard || (kept & ((((uint32_t)1) << (extra - 1u)) - 1u)) != 0);
    guard = (uint8_t)((kept >> (extra - 1u)) & 1u);
    kept >>= extra;
    exp32 = 0;
  }
  if (guard && (sticky || (kept & 1u))) ++kept;
  if (exp32 == 0) return sign | kept; /* a carry into bit 23 is the smallest normal */
  if (kept == 0x01000000u) { /* rounding carried out of the significand */
    kept >>= 1;
    ++exp32;
    if (exp32 >= 0xFF) return sign | 0x7F800000u;
  }
  return sign | ((uint32_t)exp32 << 23) | (kept & 0x007FFFFFu);
}

/* binary32 -> binary64, exact. */
static f64_words_t f32_bits_to_words(uint32_t b) {
  const uint32_t sign = b & HI_SIGN;
  const int16_t exp32 = (int16_t)((b >> 23) & 0xFFu);
  uint32_t frac = b & 0x007FFFFFu;
  int16_t exp64;
  f64_words_t w;
  if (exp32 == 0xFF) {
    exp64 = 0x7FF;
  } else if (exp32 == 0) {
    if (frac == 0) {
      w.hi = sign;
      w.lo = 0;
      return w;
    }
    /* A float subnormal is a normal binary64: shift the leading 1 out. */
    exp64 = -126 + 1023;
    while ((frac & 0x00800000u) == 0) {
      frac <<= 1;
      --exp64;
    }
    frac &= 0x007FFFFFu;
  } else {
    exp64 = (int16_t)(exp32 - 127 + 1023);
  }
  w.hi = sign | ((uint32_t)exp64 << 20) | (frac >> 3);
  w.lo = frac << 29;
  return w;
}

static f64_words_t f64_words(olf_f64_t v) { return words_get(v.le); }
float olf_f64_to_float(olf_f64_t value) { return float_from_bits(words_to_f32_bits(f64_words(value))); }
olf_f64_t olf_f64_from_float(float value) {
  olf_f64_t v;
  words_put(v.le, f32_bits_to_words(float_bits(value)));
  return v;
}
void olf_put_f64(uint8_t* out, olf_f64_t v) { memcpy(out, v.le, 8); }
olf_f64_t olf_get_f64(const uint8_t* in) {
  olf_f64_t v;
  memcpy(v.le, in, 8);
  return v;
}
/* The target's double is a float here. */
static f64_words_t double_words(double v) { return f32_bits_to_words(float_bits((float)v)); }
void olf_put_double(uint8_t* out, double v) { words_put(out, double_words(v)); }
double olf_get_double(const uint8_t* in) { return (double)float_from_bits(words_to_f32_bits(words_get(in))); }

#else /* double is binary64 */

typedef char olf_double_is_binary64[(sizeof(double) == 8) ? 1 : -1];

/* Assumes double and uint64_t share a byte order (every current target). */
static f64_words_t double_words(double v) {
  uint64_t b;
  f64_words_t w;
  memcpy(&b, &v, sizeof b);
  w.hi = (uint32_t)(b >> 32);
  w.lo = (uint32_t)b;
  return w;
}
float olf_f64_to_float(olf_f64_t value) { return (float)value; }
olf_f64_t olf_f64_from_float(float value) { return (double)value; }
void olf_put_f64(uint8_t* out, olf_f64_t v) { words_put(out, double_words(v)); }
olf_f64_t olf_get_f64(const uint8_t* in) {
  const f64_words_t w = words_get(in);
  const uint64_t b = ((uint64_t)w.hi << 32) | w.lo;
  double v;
  memcpy(&v, &b, sizeof v);
  return v;
}
void olf_put_double(uint8_t* out, double v) { olf_put_f64(out, v); }
double olf_get_double(const uint8_t* in) { return olf_get_f64(in); }

#endif

/* Compares binary64 values given as wire bytes by their bits (NaN aside):
 * positive patterns sort as unsigned integers, negative ones backwards, and
 * -0 is +0. Byte by byte from the top: no 64-bit arithmetic. */
static uint8_t is_negative_nonzero(const uint8_t* b) {
  uint8_t i, any = (uint8_t)(b[7] & 0x7Fu);
  for (i = 0; i < 7u; ++i) any |= b[i];
  return (uint8_t)((b[7] & 0x80u) != 0 && any != 0);
}

/* -1, 0, 1 as a <, ==, > b. */
static int8_t compare_f64(const uint8_t* a, const uint8_t* b) {
  const uint8_t na = is_negative_nonzero(a), nb = is_negative_nonzero(b);
  int8_t i;
  if (na != nb) return na ? -1 : 1;
  for (i = 7; i >= 0; --i) {
    /* Magnitudes compare as integers; the sign bit is equal or a signed zero. */
    const uint8_t x = (uint8_t)(i == 7 ? a[i] & 0x7Fu : a[i]);
    const uint8_t y = (uint8_t)(i == 7 ? b[i] & 0x7Fu : b[i]);
    if (x != y) return (int8_t)(((x < y) != (na != 0)) ? -1 : 1);
  }
  return 0;
}

int olf_f64_in_range(olf_f64_t value, double min_value, double max_value) {
  uint8_t v[8], lo[8], hi[8];
  olf_put_f64(v, value);
  if ((v[7] & 0x7Fu) == 0x7Fu && (v[6] & 0xF0u) == 0xF0u) { /* exponent all ones */
    uint8_t i, frac = (uint8_t)(v[6] & 0x0Fu);
    for (i = 0; i < 6u; ++i) frac |= v[i];
    if (frac != 0) return 0; /* NaN */
  }
  olf_put_double(lo, min_value);
  olf_put_double(hi, max_value);
  return compare_f64(v, lo) >= 0 && compare_f64(v, hi) <= 0;
}
