/* Framing, request dispatch, parameter sets and run events. */
#include <string.h>

#include "odolink/olf.h"
#include "olf_internal.h"

#define OLF_ALL_PARAMS ((1u << OLF_PARAM_COUNT) - 1u)

/* ---- Storage ----------------------------------------------------------- */

static void load_from_storage(olf_ctx_t* ctx) {
  uint8_t rec[OLF_STORAGE_RECORD_SIZE];
  int slot;
  int best = -1;
  uint32_t best_gen = 0;
  ctx->active = ctx->config.defaults;
  ctx->has_previous = 0;
  ctx->storage_generation = 0;
  ctx->storage_slot = -1;
  ctx->boot_source = OLF_BOOT_DEFAULTS;
  if (ctx->config.storage.read == NULL) return;
  for (slot = 0; slot < 2; ++slot) {
    uint32_t gen;
    olf_params_t active, previous;
    int has_previous;
    if (!ctx->config.storage.read(ctx->config.storage.user, (uint32_t)slot * OLF_STORAGE_SLOT_SIZE,
                                  rec, OLF_STORAGE_RECORD_SIZE)) {
      continue;
    }
    if (!olf_record_parse(rec, &gen, &active, &previous, &has_previous)) continue;
    /* Serial-number comparison so the generation may wrap. */
    if (best < 0 || (int32_t)(gen - best_gen) > 0) {
      best = slot;
      best_gen = gen;
      ctx->active = active;
      ctx->previous = previous;
      ctx->has_previous = has_previous;
    }
  }
  if (best >= 0) {
    ctx->storage_slot = best;
    ctx->storage_generation = best_gen;
    ctx->boot_source = best == 0 ? OLF_BOOT_SLOT_A : OLF_BOOT_SLOT_B;
  }
}

/* Persists then applies: RAM changes only once the record is fully written,
 * so a failed or interrupted write leaves the robot on its old set. */
static int apply_set(olf_ctx_t* ctx, const olf_params_t* next, const olf_params_t* previous) {
  olf_params_t next_copy = *next;
  olf_params_t prev_copy = *previous;
  if (ctx->config.storage.write != NULL) {
    uint8_t rec[OLF_STORAGE_RECORD_SIZE];
    const int slot = ctx->storage_slot == 0 ? 1 : 0;
    const uint32_t gen = ctx->storage_generation + 1u;
    olf_record_build(gen, &next_copy, &prev_copy, 1, rec);
    if (!ctx->config.storage.write(ctx->config.storage.user, (uint32_t)slot * OLF_STORAGE_SLOT_SIZE,
                                   rec, OLF_STORAGE_RECORD_SIZE)) {
      ++ctx->counters.storage_failures;
      return 0;
    }
    ctx->storage_slot = slot;
    ctx->storage_generation = gen;
  }
  ctx->active = next_copy;
  ctx->previous = prev_copy;
  ctx->has_previous = 1;
  ++ctx->counters.commits;
  if (ctx->config.callbacks.params_applied) {
    ctx->config.callbacks.params_applied(ctx->config.callbacks.user, &ctx->active);
  }
  return 1;
}

/* ---- Output ------------------------------------------------------------ */

/* Replies and events are written through a cursor into the payload area of
 * tx: each put returns the position after what it wrote (short code on an
 * 8-bit CPU). */
#define TX_PAYLOAD_AT 3u
typedef char olf_in_place_cobs_needs_short_payloads[(OLF_MAX_PAYLOAD + OLF_CRC_SIZE < 254u) ? 1 : -1];
typedef char olf_largest_message_fits[(OLF_LARGEST_MESSAGE <= OLF_MAX_PAYLOAD) ? 1 : -1];
static uint8_t* put_u8(uint8_t* p, uint8_t v) {
  *p = v;
  return p + 1;
}
static uint8_t* put_u16(uint8_t* p, uint16_t v) {
  olf_put_u16(p, v);
  return p + 2;
}
static uint8_t* put_u32(uint8_t* p, uint32_t v) {
  olf_put_u32(p, v);
  return p + 4;
}
static uint8_t* put_double(uint8_t* p, double v) {
  olf_put_double(p, v);
  return p + 8;
}
/* t_ms, left and right ticks, x, y, heading: TELEMETRY and RUN_COMPLETE. */
static uint8_t* put_sample(uint8_t* p, const olf_telemetry_t* s) {
  p = put_u32(p, s->t_ms);
  p = put_u32(p, (uint32_t)s->left_ticks);
  p = put_u32(p, (uint32_t)s->right_ticks);
  p = put_double(p, s->x_mm);
  p = put_double(p, s->y_mm);
  return put_double(p, s->heading_rad);
}

static uint8_t* begin_payload(olf_ctx_t* ctx, uint8_t type, uint16_t seq) {
  uint8_t* payload = ctx->tx + TX_PAYLOAD_AT;
  payload[0] = OLF_PROTOCOL_VERSION;
  payload[1] = type;
  olf_put_u16(payload + 2, seq);
  return payload + OLF_HEADER_SIZE;
}

/* Body length, CRC, COBS, delimiters on both sides (the leading one flushes whatever
 * garbage the receiver holds), then out. Returns the frame length in tx. */
static size_t send_payload(olf_ctx_t* ctx, const uint8_t* end) {
  uint8_t* payload = ctx->tx + TX_PAYLOAD_AT;
  const size_t len = (size_t)(end - payload);
  uint16_t crc;
  size_t n;
  payload[4] = (uint8_t)(len - OLF_HEADER_SIZE);
  crc = olf_crc16(payload, len);
  payload[len] = (uint8_t)(crc >> 8);
  payload[len + 1] = (uint8_t)crc;
  n = olf_cobs_encode(payload, len + OLF_CRC_SIZE, ctx->tx + 1, sizeof ctx->tx - 2);
  if (n == 0) return 0; /* cannot happen: payloads are bounded by construction */
  ctx->tx[0] = 0;
  ctx->tx[n + 1] = 0;
  if (ctx->config.callbacks.write) {
    ctx->config.callbacks.write(ctx->config.callbacks.user, ctx->tx, n + 2);
  }
  return n + 2;
}

typedef struct {
  uint8_t type;
  uint16_t seq;
  uint16_t crc; /* the request's frame CRC: its identity for retries */
  const uint8_t* body;
  size_t body_len;
} request_t;

static void send_reply(olf_ctx_t* ctx, const request_t* req, const uint8_t* end) {
  const size_t n = send_payload(ctx, end);
  if (n > 0) {
    memcpy(ctx->cached_reply, ctx->tx, n);
    ctx->cached_reply_len = n;
    ctx->cached_seq = req->seq;
    ctx->cached_request_crc = req->crc;
    ctx->has_cached_reply = 1;
  }
}

static void nack(olf_ctx_t* ctx, const request_t* req, uint8_t error) {
  uint8_t* p = begin_payload(ctx, OLF_MSG_NACK, req->seq);
  p = put_u8(p, req->type);
  p = put_u8(p, error);
  if (error == OLF_ERR_BAD_VERSION) p = put_u8(p, OLF_PROTOCOL_VERSION);
  send_reply(ctx, req, p);
}

static uint8_t* begin_ack(olf_ctx_t* ctx, const request_t* req) {
  return put_u8(begin_payload(ctx, OLF_MSG_ACK, req->seq), req->type);
}

/* ACK carrying the active set's checksum: SET, COMMIT, ROLLBACK. */
static void ack_with_active_crc(olf_ctx_t* ctx, const request_t* req) {
  send_reply(ctx, req, put_u32(begin_ack(ctx, req), olf_params_crc(&ctx->active)));
}

/* NACK `error` unless the body is exactly `len` bytes; 1 if it is. */
static int body_is(olf_ctx_t* ctx, const request_t* req, size_t len) {
  if (req->body_len == len) return 1;
  nack(ctx, req, OLF_ERR_MALFORMED);
  return 0;
}

/* ---- Requests ---------------------------------------------------------- */

/* Parses [name_len][name][type][value]; on success *index is the parameter
 * and *value points at its wire bytes. Returns OLF_ERR_NONE or the error. */
static uint8_t parse_param_value(const request_t* req, int* index, const uint8_t** value) {
  size_t name_len;
  uint8_t type;
  if (req->body_len < 2) return OLF_ERR_MALFORMED;
  name_len = req->body[0];
  if (req->body_len < 1 + name_len + 1) return OLF_ERR_MALFORMED;
  *index = olf_param_find((const char*)req->body + 1, name_len);
  type = req->body[1 + name_len];
  if (*index < 0) return OLF_ERR_UNKNOWN_PARAM;
  if (type != olf_param_table()[*index].type) return OLF_ERR_TYPE_MISMATCH;
  if (req->body_len != 1 + name_len + 1 + olf_param_size(type)) return OLF_ERR_MALFORMED;
  *value = req->body + 1 + name_len + 1;
  return OLF_ERR_NONE;
}

static void handle_hello(olf_ctx_t* ctx, const request_t* req) {
  uint8_t* p;
  uint8_t name_len = 0;
  const char* name = ctx->config.robot_name ? ctx->config.robot_name : "";
  if (!body_is(ctx, req, 0)) return;
  while (name[name_len] != '\0' && name_len < OLF_MAX_NAME) ++name_len;
  p = begin_ack(ctx, req);
  p = put_u8(p, OLF_PROTOCOL_VERSION);
  p = put_u8(p, OLF_PARAM_COUNT);
  p = put_u32(p, olf_param_table_crc());
  p = put_u32(p, olf_params_crc(&ctx->active));
  p = put_u8(p, (uint8_t)ctx->boot_source);
  p = put_u8(p, name_len);
  memcpy(p, name, name_len);
  send_reply(ctx, req, p + name_len);
}

static void handle_param_get(olf_ctx_t* ctx, const request_t* req) {
  int index;
  uint8_t* p;
  if (req->body_len < 1 || req->body_len != 1u + req->body[0]) {
    nack(ctx, req, OLF_ERR_MALFORMED);
    return;
  }
  index = olf_param_find((const char*)req->body + 1, req->body[0]);
  if (index < 0) {
    nack(ctx, req, OLF_ERR_UNKNOWN_PARAM);
    return;
  }
  p = put_u8(begin_ack(ctx, req), olf_param_table()[index].type);
  send_reply(ctx, req, p + olf_param_put(&ctx->active, (unsigned)index, p));
}

static void handle_param_write(olf_ctx_t* ctx, const request_t* req) {
  int index;
  const uint8_t* value;
  olf_params_t* target;
  olf_params_t single;
  uint8_t err = parse_param_value(req, &index, &value);
  if (err != OLF_ERR_NONE) {
    nack(ctx, req, err);
    return;
  }
  if (req->type == OLF_MSG_PARAM_SET && ctx->state == OLF_STATE_RUNNING) {
    nack(ctx, req, OLF_ERR_BUSY);
    return;
  }
  single = ctx->active;
  target = req->type == OLF_MSG_STAGE_PUT ? &ctx->staged : &single;
  if (!olf_param_from_wire((unsigned)index, value, target)) {
    nack(ctx, req, OLF_ERR_OUT_OF_RANGE);
    return;
  }
  if (req->type == OLF_MSG_STAGE_PUT) {
    ctx->staged_mask |= (uint32_t)1 << index;
    send_reply(ctx, req, begin_ack(ctx, req));
    return;
  }
  /* PARAM_SET: the whole set with one value changed goes through the same
   * atomic persist-then-apply path as a commit. */
  if (!apply_set(ctx, &single, &ctx->active)) {
    nack(ctx, req, OLF_ERR_STORAGE);
    return;
  }
  ack_with_active_crc(ctx, req);
}

static void handle_stage_begin(olf_ctx_t* ctx, const request_t* req) {
  if (!body_is(ctx, req, 0)) return;
  ctx->staged = ctx->active;
  ctx->staged_mask = 0;
  send_reply(ctx, req, begin_ack(ctx, req));
}

static void handle_params_read(olf_ctx_t* ctx, const request_t* req) {
  const olf_params_t* set;
  uint32_t mask = OLF_ALL_PARAMS;
  uint8_t* p;
  unsigned i;
  if (!body_is(ctx, req, 1)) return;
  switch (req->body[0]) {
    case OLF_SET_ACTIVE: set = &ctx->active; break;
    case OLF_SET_STAGED: set = &ctx->staged; mask = ctx->staged_mask; break;
    case OLF_SET_PREVIOUS:
      if (!ctx->has_previous) {
        nack(ctx, req, OLF_ERR_NO_PREVIOUS);
        return;
      }
      set = &ctx->previous;
      break;
    default: nack(ctx, req, OLF_ERR_MALFORMED); return;
  }
  p = begin_ack(ctx, req);
  p = put_u8(p, req->body[0]);
  p = put_u32(p, mask);
  p = put_u32(p, olf_params_crc(set));
  p = put_u8(p, OLF_PARAM_COUNT);
  /* Table order, type and value only: the names are covered by the table
   * checksum the host verified in HELLO, and a short frame survives a noisy
   * line far more often (at 1 % byte errors, 42 bytes arrive intact 66 % of
   * the time, 120 bytes 30 %). */
  for (i = 0; i < OLF_PARAM_COUNT; ++i) {
    p = put_u8(p, olf_param_table()[i].type);
    p += olf_param_put(set, i, p);
  }
  send_reply(ctx, req, p);
}

/* NACK BUSY while a run lasts; 1 if idle. */
static int idle(olf_ctx_t* ctx, const request_t* req) {
  if (ctx->state != OLF_STATE_RUNNING) return 1;
  nack(ctx, req, OLF_ERR_BUSY);
  return 0;
}

static void handle_commit(olf_ctx_t* ctx, const request_t* req) {
  if (!body_is(ctx, req, 4) || !idle(ctx, req)) return;
  if (ctx->staged_mask != OLF_ALL_PARAMS) {
    nack(ctx, req, OLF_ERR_STAGE_INCOMPLETE);
    return;
  }
  if (olf_get_u32(req->body) != olf_params_crc(&ctx->staged)) {
    nack(ctx, req, OLF_ERR_CHECKSUM);
    return;
  }
  if (!apply_set(ctx, &ctx->staged, &ctx->active)) {
    nack(ctx, req, OLF_ERR_STORAGE);
    return;
  }
  /* A stale staging area must not be committed twice by accident. */
  ctx->staged_mask = 0;
  ack_with_active_crc(ctx, req);
}

static void handle_rollback(olf_ctx_t* ctx, const request_t* req) {
  if (!body_is(ctx, req, 0) || !idle(ctx, req)) return;
  if (!ctx->has_previous) {
    nack(ctx, req, OLF_ERR_NO_PREVIOUS);
    return;
  }
  /* Swap, so a second rollback restores the set rolled back from. */
  if (!apply_set(ctx, &ctx->previous, &ctx->active)) {
    nack(ctx, req, OLF_ERR_STORAGE);
    return;
  }
  ack_with_active_crc(ctx, req);
}

/* The amount is checked on its wire bytes, exactly and without float maths
 * (which would pull a soft-float library into an 8-bit image). */
static int amount_within(const uint8_t* wire, double min_value, double max_value) {
  uint8_t i, any = (uint8_t)(wire[7] & 0x7Fu);
  for (i = 0; i < 7u; ++i) any |= wire[i];
  return any != 0 && olf_f64_in_range(olf_get_f64(wire), min_value, max_value); /* never 0 */
}

static int run_cmd_valid(const olf_run_cmd_t* cmd, const uint8_t* amount_wire) {
  const int count_ok = cmd->count >= 1 && cmd->count <= 100;
  if (cmd->direction != OLF_DIR_CW && cmd->direction != OLF_DIR_CCW) return 0;
  switch (cmd->procedure) {
    case OLF_PROC_UMBMARK: return amount_within(amount_wire, 0.0, 100000.0);
    case OLF_PROC_STRAIGHT: return amount_within(amount_wire, -100000.0, 100000.0);
    case OLF_PROC_SPIN: return count_ok;
    case OLF_PROC_OUT_AND_BACK: return amount_within(amount_wire, 0.0, 100000.0) && count_ok;
    default: return 0;
  }
}

static void handle_run_start(olf_ctx_t* ctx, const request_t* req) {
  olf_run_cmd_t cmd;
  const int with_speeds = req->body_len == 18;
  /* 14 bytes; 18 with the optional speed and turn rate. */
  if (req->body_len != 14 && !with_speeds) {
    nack(ctx, req, OLF_ERR_MALFORMED);
    return;
  }
  if (!idle(ctx, req)) return;
  cmd.procedure = req->body[0];
  cmd.direction = req->body[1];
  cmd.amount_mm = olf_get_double(req->body + 2);
  cmd.count = olf_get_u32(req->body + 10);
  cmd.speed_mm_s = with_speeds ? olf_get_u16(req->body + 14) : 0u;
  cmd.turn_rate_ddeg_s = with_speeds ? olf_get_u16(req->body + 16) : 0u;
  if (!run_cmd_valid(&cmd, req->body + 2)) {
    nack(ctx, req, OLF_ERR_BAD_PROCEDURE);
    return;
  }
  cmd.run_id = (uint16_t)(ctx->run_id + 1u);
  if (cmd.run_id == 0) cmd.run_id = 1; /* 0 means "no run" in STATUS */
  if (ctx->config.callbacks.start_run == NULL ||
      !ctx->config.callbacks.start_run(ctx->config.callbacks.user, &cmd)) {
    nack(ctx, req, OLF_ERR_REJECTED);
    return;
  }
  ctx->run_id = cmd.run_id;
  ctx->state = OLF_STATE_RUNNING;
  ctx->telemetry_sent = 0;
  send_reply(ctx, req, put_u16(begin_ack(ctx, req), cmd.run_id));
}

static void handle_stop(olf_ctx_t* ctx, const request_t* req) {
  if (!body_is(ctx, req, 0)) return;
  if (ctx->state == OLF_STATE_RUNNING && ctx->config.callbacks.stop) {
    ctx->config.callbacks.stop(ctx->config.callbacks.user);
  }
  send_reply(ctx, req, put_u8(begin_ack(ctx, req), ctx->state));
}

static void handle_telemetry_rate(olf_ctx_t* ctx, const request_t* req) {
  uint16_t rate;
  if (!body_is(ctx, req, 2)) return;
  rate = olf_get_u16(req->body);
  if (rate > 1000) {
    nack(ctx, req, OLF_ERR_OUT_OF_RANGE);
    return;
  }
  ctx->telemetry_rate_hz = rate;
  ctx->telemetry_sent = 0;
  send_reply(ctx, req, begin_ack(ctx, req));
}

static void handle_status(olf_ctx_t* ctx, const request_t* req) {
  const olf_telemetry_t* end = &ctx->last_run_end;
  uint8_t* p;
  if (!body_is(ctx, req, 0)) return;
  p = begin_ack(ctx, req);
  p = put_u8(p, ctx->state);
  p = put_u16(p, ctx->state == OLF_STATE_RUNNING ? ctx->run_id : 0);
  p = put_u16(p, ctx->last_run_id);
  p = put_u8(p, ctx->last_run_status);
  p = put_u32(p, end->t_ms);
  p = put_double(p, end->x_mm);
  p = put_double(p, end->y_mm);
  p = put_double(p, end->heading_rad);
  p = put_u32(p, ctx->counters.frames_ok);
  p = put_u32(p, ctx->counters.crc_errors);
  p = put_u32(p, ctx->counters.framing_errors);
  send_reply(ctx, req, p);
}

static void handle_frame(olf_ctx_t* ctx, size_t n) {
  const uint8_t* frame = ctx->rx;
  request_t req;
  uint16_t crc;
  if (n < OLF_HEADER_SIZE + OLF_CRC_SIZE) {
    ++ctx->counters.framing_errors;
    return;
  }
  crc = (uint16_t)(((uint16_t)frame[n - 2] << 8) | frame[n - 1]);
  if (olf_crc16(frame, n - 2) != crc) {
    ++ctx->counters.crc_errors;
    return;
  }
  if (frame[4] != n - OLF_HEADER_SIZE - OLF_CRC_SIZE) {
    ++ctx->counters.framing_errors;
    return;
  }
  ++ctx->counters.frames_ok;
  req.type = frame[1];
  req.seq = olf_get_u16(frame + 2);
  req.crc = crc;
  req.body = frame + OLF_HEADER_SIZE;
  req.body_len = n - OLF_HEADER_SIZE - OLF_CRC_SIZE;
  /* Replies and events are never requests (e.g. an echoing line). */
  if (req.type >= OLF_MSG_ACK) return;

  /* A retry of the request answered last: send the same reply again, do not
   * execute twice (a commit or a run start must happen once). HELLO is
   * exempt: it opens every session and is read-only, so executing it always
   * both answers fresh and replaces the cache, and a new session can never be
   * answered from an old session's cache even if its seq happens to repeat. */
  if (req.type != OLF_MSG_HELLO && ctx->has_cached_reply && req.seq == ctx->cached_seq &&
      req.crc == ctx->cached_request_crc) {
    ++ctx->counters.retries_answered_from_cache;
    if (ctx->config.callbacks.write) {
      ctx->config.callbacks.write(ctx->config.callbacks.user, ctx->cached_reply,
                                  ctx->cached_reply_len);
    }
    return;
  }
  if (frame[0] != OLF_PROTOCOL_VERSION) {
    nack(ctx, &req, OLF_ERR_BAD_VERSION);
    return;
  }
  switch (req.type) {
    case OLF_MSG_HELLO: handle_hello(ctx, &req); break;
    case OLF_MSG_PARAM_GET: handle_param_get(ctx, &req); break;
    case OLF_MSG_PARAM_SET: handle_param_write(ctx, &req); break;
    case OLF_MSG_STAGE_BEGIN: handle_stage_begin(ctx, &req); break;
    case OLF_MSG_STAGE_PUT: handle_param_write(ctx, &req); break;
    case OLF_MSG_PARAMS_READ: handle_params_read(ctx, &req); break;
    case OLF_MSG_COMMIT: handle_commit(ctx, &req); break;
    case OLF_MSG_ROLLBACK: handle_rollback(ctx, &req); break;
    case OLF_MSG_RUN_START: handle_run_start(ctx, &req); break;
    case OLF_MSG_STOP: handle_stop(ctx, &req); break;
    case OLF_MSG_TELEMETRY_RATE: handle_telemetry_rate(ctx, &req); break;
    case OLF_MSG_STATUS: handle_status(ctx, &req); break;
    default: nack(ctx, &req, OLF_ERR_UNKNOWN_TYPE); break;
  }
}

/* ---- Public ------------------------------------------------------------ */

void olf_init(olf_ctx_t* ctx, const olf_config_t* config) {
  memset(ctx, 0, sizeof *ctx);
  ctx->config = *config;
  load_from_storage(ctx);
  ctx->staged = ctx->active;
  if (ctx->config.callbacks.params_applied) {
    ctx->config.callbacks.params_applied(ctx->config.callbacks.user, &ctx->active);
  }
}

void olf_feed(olf_ctx_t* ctx, uint8_t byte) {
  if (byte == 0) {
    if (ctx->rx_overflow) {
      ++ctx->counters.framing_errors;
    } else if (ctx->rx_len > 0) {
      /* In place: each COBS block is as long decoded as encoded. */
      const int n = olf_cobs_decode(ctx->rx, ctx->rx_len, ctx->rx, sizeof ctx->rx);
      if (n < 0) {
        ++ctx->counters.framing_errors;
      } else {
        handle_frame(ctx, (size_t)n);
      }
    }
    /* Empty frames (two delimiters in a row) are the normal resync idiom. */
    ctx->rx_len = 0;
    ctx->rx_overflow = 0;
    return;
  }
  if (ctx->rx_overflow) return;
  if (ctx->rx_len >= sizeof ctx->rx) {
    ctx->rx_overflow = 1;
    return;
  }
  ctx->rx[ctx->rx_len++] = byte;
}

void olf_feed_bytes(olf_ctx_t* ctx, const uint8_t* data, size_t len) {
  size_t i;
  for (i = 0; i < len; ++i) olf_feed(ctx, data[i]);
}

int olf_emit_telemetry(olf_ctx_t* ctx, const olf_telemetry_t* s) {
  uint8_t* p;
  if (ctx->state != OLF_STATE_RUNNING || ctx->telemetry_rate_hz == 0) return 0;
  if (ctx->telemetry_sent &&
      (uint32_t)(s->t_ms - ctx->last_telemetry_ms) < 1000u / ctx->telemetry_rate_hz) {
    return 0;
  }
  ctx->telemetry_sent = 1;
  ctx->last_telemetry_ms = s->t_ms;
  p = put_sample(begin_payload(ctx, OLF_MSG_TELEMETRY, ++ctx->event_seq), s);
  p = put_u8(p, ctx->state);
  send_payload(ctx, put_u16(p, ctx->run_id));
  return 1;
}

void olf_run_complete(olf_ctx_t* ctx, uint8_t status, const olf_telemetry_t* end) {
  uint8_t* p;
  if (ctx->state != OLF_STATE_RUNNING) return;
  ctx->state = OLF_STATE_IDLE;
  ctx->last_run_id = ctx->run_id;
  ctx->last_run_status = status;
  ctx->last_run_end = *end;
  p = put_u16(begin_payload(ctx, OLF_MSG_RUN_COMPLETE, ++ctx->event_seq), ctx->run_id);
  p = put_u8(p, status);
  send_payload(ctx, put_sample(p, end));
}
